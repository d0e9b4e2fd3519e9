"""The force readers on files other software wrote, compared with independent readers.

* LabVIEW TDMS files shipped inside the installed npTDMS wheel (read in place; LGPL-3.0,
  never copied), against npTDMS's own API;
* MATLAB v4, v5 and v7.3 files shipped inside the SciPy wheel (read in place), against
  :func:`scipy.io.loadmat` and h5py;
* files written here in the shapes the real software writes: a TDMS with LabVIEW's
  date-named group, MATLAB v7.3 empty and sparse variables (h5py with MATLAB's attributes).
"""

from __future__ import annotations

import importlib.resources as resources
import shutil

import h5py
import numpy as np
import pytest
import scipy.io
import scipy.sparse
from nptdms import ChannelObject, GroupObject, RootObject, TdmsFile, TdmsWriter

from fingerfriction.forces import ForceFileError, read_force_file
from fingerfriction.forces.readers import list_channels, probe_force_file

TDMS_DIR = resources.files("nptdms") / "test" / "data"
MAT_DIR = resources.files("scipy.io.matlab") / "tests" / "data"
FS = 10_000.0
#: LabVIEW's default group name: the date and time the acquisition started.
DATE_GROUP = "07/09/2012 06:58:23 PM - Piezo - All Data"


def _tdms(name: str) -> str:
    p = TDMS_DIR / name
    assert p.is_file(), f"npTDMS no longer ships {name}"
    return str(p)


# --- TDMS: LabVIEW's files ---------------------------------------------------------------


def test_labview_digital_input_groups_with_slashes_against_nptdms():
    """Digital_Input.tdms: LabVIEW's date-named groups hold '/', and one channel name is in
    three groups (the data and two decimation levels)."""
    path = _tdms("Digital_Input.tdms")
    ref = TdmsFile.read(path)
    groups = ref.groups()
    assert len(groups) == 3 and all("/" in g.name for g in groups)
    expected = sorted(f"{g.name}/{c.name}" for g in groups for c in g.channels())
    assert list_channels(path) == expected
    for g in groups:
        ch = g.channels()[0]
        full = f"{g.name}/{ch.name}"
        if len(ch) < 2:
            continue
        rec = read_force_file(path, channels={"F1": full, "F2": full})  # the rate the file states
        assert rec.fs_hz == pytest.approx(1.0 / ch.properties["wf_increment"], rel=1e-12)
        np.testing.assert_array_equal(rec.f1, ch[:].astype(np.float64))
        np.testing.assert_array_equal(rec.f2, ch[:].astype(np.float64))
    bare = groups[0].channels()[0].name
    msg = rf"channel name '{bare}' \(channel F1\) is ambiguous.*3 channels answer to it.*give 'group/channel'"
    with pytest.raises(ForceFileError, match=msg):
        read_force_file(path, fs_hz=FS, channels={"F1": bare, "F2": bare})


@pytest.mark.parametrize("name", ["raw1.tdms", "big_endian.tdms", "raw_timestamps.tdms"])
def test_labview_files_read_as_nptdms_reads_them(name):
    """Every channel of npTDMS's own test files, by its bare (unique) name, equals what
    npTDMS gives (scaled data, as LabVIEW shows them); the rate is the waveform's."""
    path = _tdms(name)
    ref = TdmsFile.read(path)
    chans = [(g, c) for g in ref.groups() for c in g.channels()]
    assert chans
    for g, c in chans:
        rec = read_force_file(path, fs_hz=None if "wf_increment" in c.properties else FS,
                              channels={"F1": c.name, "F2": f"{g.name}/{c.name}"})
        want = np.asarray(c.read_data(scaled=True), dtype=np.float64)
        np.testing.assert_array_equal(rec.f1, want)
        np.testing.assert_array_equal(rec.f2, want)
        if "wf_increment" in c.properties:
            assert rec.fs_hz == pytest.approx(1.0 / c.properties["wf_increment"], rel=1e-12)


def test_a_tdms_index_beside_the_file_is_not_read(tmp_path):
    """npTDMS given a path also reads '<file>_index'; the reader gives it the data file
    only, so a stale (or foreign) index cannot change what is read."""
    src = _tdms("raw1.tdms")
    p = tmp_path / "raw1.tdms"
    shutil.copy(src, p)
    (tmp_path / "raw1.tdms_index").write_bytes(b"TDSh" + b"\x00" * 60)  # garbage index
    ref = TdmsFile.read(src)
    c = ref.groups()[0].channels()[0]
    rec = read_force_file(p, channels={"F1": c.name, "F2": c.name})
    np.testing.assert_array_equal(rec.f1, c[:])


# --- TDMS: written here as LabVIEW writes them ---------------------------------------------


def _write_dated_tdms(path, f1, f2, *, more_groups=()):
    props = {"wf_increment": 1.0 / FS, "wf_start_offset": 0.0, "unit_string": "N"}
    objs = [RootObject({"name": "session"}), GroupObject(DATE_GROUP),
            ChannelObject(DATE_GROUP, "F1", f1, properties=props),
            ChannelObject(DATE_GROUP, "F2", f2, properties=props)]
    for g in more_groups:
        objs += [GroupObject(g), ChannelObject(g, "ai0", f1, properties=props)]
    with TdmsWriter(path) as w:
        w.write_segment(objs)


def test_date_named_group_bare_and_default_channels(tmp_path):
    rng = np.random.default_rng(1)
    f1, f2 = rng.normal(size=400), rng.normal(size=400)
    p = tmp_path / "S1_bump.tdms"
    _write_dated_tdms(p, f1, f2, more_groups=[DATE_GROUP.replace("Piezo", k) for k in ("Trig", "Aux", "Cam")])
    # the default F1/F2, found by probe_force_file, are then read by read_force_file
    info = probe_force_file(p)
    assert info.n_samples == 400 and info.fs_hz == pytest.approx(FS)
    rec = read_force_file(p)
    np.testing.assert_array_equal(rec.f1, f1)
    np.testing.assert_array_equal(rec.f2, f2)
    # a unique bare name, and the full 'group/channel' path with its slashes
    rec = read_force_file(p, channels={"F1": "F1", "F2": f"{DATE_GROUP}/F2"})
    np.testing.assert_array_equal(rec.f2, f2)
    # a name in three groups is ambiguous, listed as such
    with pytest.raises(ForceFileError, match=r"channel name 'ai0' \(channel F1\) is ambiguous.*"
                                             r"3 channels answer to it"):
        read_force_file(p, channels={"F1": "ai0", "F2": "F2"})
    with pytest.raises(ForceFileError, match=r"no channel named 'ai9'"):
        read_force_file(p, channels={"F1": "ai9", "F2": "F2"})


# --- MATLAB: SciPy's files -------------------------------------------------------------------


def _mat_files():
    return sorted(p.name for p in MAT_DIR.iterdir() if p.name.endswith(".mat"))


def _scipy_value(data: dict, dotted: str):
    node = data
    for part in dotted.split("."):
        node = node[part]
    return node


@pytest.mark.parametrize("name", _mat_files())
def test_scipy_mat_files_agree_with_scipy_and_h5py(name):
    """Every MATLAB file SciPy tests itself with: either a one-line ForceFileError, or
    channels whose values are exactly scipy.io.loadmat's (v4, v5) or h5py's (v7.3)."""
    path = str(MAT_DIR / name)
    try:
        names = list_channels(path)
    except ForceFileError as exc:
        assert "\n" not in str(exc)
        return
    v73 = h5py.is_hdf5(path)
    ref = None if v73 else scipy.io.loadmat(path, simplify_cells=True)
    for n in names:
        try:
            rec = read_force_file(path, fs_hz=FS, channels={"F1": n, "F2": n})
        except ForceFileError as exc:
            assert "\n" not in str(exc)
            continue
        if v73:
            with h5py.File(path, "r") as f:
                want = np.asarray(f[n.replace(".", "/")][()], dtype=np.float64).ravel()
        else:
            want = np.asarray(_scipy_value(ref, n), dtype=np.float64).ravel()
        np.testing.assert_array_equal(rec.f1, want)


@pytest.mark.parametrize("name", [n for n in _mat_files() if n.startswith("testsparse")])
def test_scipy_sparse_matrices_are_named_as_such(name):
    path = str(MAT_DIR / name)
    ref = scipy.io.loadmat(path)
    var = next(k for k, v in ref.items() if scipy.sparse.issparse(v))
    assert var not in list_channels(path)
    with pytest.raises(ForceFileError, match=rf"variable '{var}' \(channel F1\) .* is a MATLAB sparse matrix "
                                             r"\(\d+ x \d+\); a channel must be a numeric vector"):
        read_force_file(path, fs_hz=FS, channels={"F1": var, "F2": var})


def test_scipy_v73_file_against_h5py():
    path = str(MAT_DIR / "testhdf5_7.4_GLNX86.mat")
    assert h5py.is_hdf5(path)
    names = list_channels(path)
    assert names
    with h5py.File(path, "r") as f:
        for n in names:
            want = np.asarray(f[n][()], dtype=np.float64).ravel()
            if want.size < 2:
                continue
            rec = read_force_file(path, fs_hz=FS, channels={"F1": n, "F2": n})
            np.testing.assert_array_equal(rec.f1, want)


# --- MATLAB v7.3: written here with MATLAB's attributes ------------------------------------


def _mat73(path, build):
    """A MATLAB v7.3 file: HDF5 with a 512-byte user block holding MATLAB's text header."""
    with h5py.File(path, "w", userblock_size=512) as f:
        build(f)
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 "
                 b"HDF5 schema 1.00 .")


def _double(f, name, values):
    d = f.create_dataset(name, data=np.asarray(values, dtype=np.float64)[None, :])
    d.attrs["MATLAB_class"] = np.bytes_("double")


def test_mat73_empty_array_is_refused(tmp_path):
    """MATLAB writes an empty array as a dataset of its dimensions with MATLAB_empty=1:
    ``zeros(0, 10)`` is stored as [0, 10], which must not be read as two samples."""
    p = tmp_path / "forces.mat"

    def build(f):
        _double(f, "F2", np.arange(100.0))
        d = f.create_dataset("F1", data=np.array([0, 10], dtype=np.uint64))
        d.attrs["MATLAB_class"] = np.bytes_("double")
        d.attrs["MATLAB_empty"] = np.uint8(1)

    _mat73(p, build)
    assert list_channels(p) == ["F2"]
    with pytest.raises(ForceFileError, match=r"variable 'F1' \(channel F1\) in MATLAB v7.3 file .* is an "
                                             r"empty MATLAB double array \(MATLAB_empty\)"):
        read_force_file(p, fs_hz=FS)
    with pytest.raises(ForceFileError, match="empty"):
        probe_force_file(p, channels={"F1": "F1", "F2": "F2"})


def test_mat73_sparse_matrix_is_refused_and_its_parts_are_not_channels(tmp_path):
    """A sparse matrix is a group (MATLAB_sparse = its row count) of data, ir, jc."""
    p = tmp_path / "forces.mat"

    def build(f):
        _double(f, "F1", np.arange(50.0))
        _double(f, "F2", np.arange(50.0))
        g = f.create_group("A")
        g.attrs["MATLAB_class"] = np.bytes_("double")
        g.attrs["MATLAB_sparse"] = np.uint64(50)
        g.create_dataset("data", data=np.array([1.0, 2.0, 3.0]))
        g.create_dataset("ir", data=np.array([0, 7, 9], dtype=np.uint64))
        g.create_dataset("jc", data=np.array([0, 3], dtype=np.uint64))

    _mat73(p, build)
    assert list_channels(p) == ["F1", "F2"]  # not A.data, A.ir, A.jc
    with pytest.raises(ForceFileError, match=r"variable 'A' \(channel F1\) .* is a MATLAB sparse matrix "
                                             r"\(50 rows\)"):
        read_force_file(p, fs_hz=FS, channels={"F1": "A", "F2": "F2"})
    with pytest.raises(ForceFileError, match=r"'A.data' .* is part of the variable 'A', a MATLAB sparse"):
        read_force_file(p, fs_hz=FS, channels={"F1": "A.data", "F2": "F2"})
    rec = read_force_file(p, fs_hz=FS)
    np.testing.assert_array_equal(rec.f1, np.arange(50.0))


def test_mat_v5_sparse_and_empty_written_by_scipy(tmp_path):
    p = tmp_path / "forces.mat"
    scipy.io.savemat(p, {"F1": np.arange(20.0), "F2": np.arange(20.0),
                         "S": scipy.sparse.csc_matrix(np.eye(20)), "E": np.zeros((0, 3))})
    assert list_channels(p) == ["F1", "F2"]
    with pytest.raises(ForceFileError, match=r"variable 'S' \(channel F1\) .* is a MATLAB sparse matrix "
                                             r"\(20 x 20\)"):
        read_force_file(p, fs_hz=FS, channels={"F1": "S", "F2": "F2"})
    with pytest.raises(ForceFileError, match=r"variable 'E' \(channel F1\) .* is an empty MATLAB array"):
        read_force_file(p, fs_hz=FS, channels={"F1": "E", "F2": "F2"})


# --- damaged copies of real files: an error naming the file, never a crash -------------------


@pytest.mark.parametrize("src", [str(TDMS_DIR / "raw1.tdms"), str(MAT_DIR / "testdouble_7.1_GLNX86.mat"),
                                 str(MAT_DIR / "testhdf5_7.4_GLNX86.mat"),
                                 str(MAT_DIR / "corrupted_zlib_checksum.mat")])
def test_truncated_real_files_give_one_line_errors(tmp_path, src):
    data = open(src, "rb").read()
    suffix = src.rsplit(".", 1)[1]
    for frac in (0.1, 0.5, 0.9):
        p = tmp_path / f"cut{int(frac * 10)}.{suffix}"
        p.write_bytes(data[: int(len(data) * frac)])
        try:
            names = list_channels(p)
            if names:
                read_force_file(p, fs_hz=FS, channels={"F1": names[0], "F2": names[0]})
        except ForceFileError as exc:
            assert "\n" not in str(exc) and p.name in str(exc)
