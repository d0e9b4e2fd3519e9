"""Tests of fingerfriction.forces.readers: every format written in tmp_path and read back."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pandas as pd
import pytest
import scipy.io
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

from fingerfriction.forces import ForceFileError, read_force_file
from fingerfriction.study.trial import read_trial_forces

FS = 10_000.0


@pytest.fixture
def channels():
    rng = np.random.default_rng(7)
    f1 = rng.normal(0.2, 0.05, 500)
    f2 = rng.normal(0.1, 0.05, 500)
    return f1, f2


def _check(rec, f1, f2, fmt):
    assert rec.format == fmt
    assert rec.n_samples == f1.size
    np.testing.assert_array_equal(rec.f1, f1)
    np.testing.assert_array_equal(rec.f2, f2)
    assert rec.f1.dtype == np.float64


# --- NPZ -----------------------------------------------------------------------------------


def test_npz_round_trip_with_manifest_names(tmp_path, channels):
    f1, f2 = channels
    p = tmp_path / "forces.npz"
    np.savez(p, ai0=f1, ai1=f2, other=np.arange(3))
    rec = read_force_file(p, fs_hz=FS, channels={"F1": "ai0", "F2": "ai1"}, t0_s=-0.0125, n_samples=500)
    _check(rec, f1, f2, "npz")
    assert rec.t0_s == -0.0125
    np.testing.assert_allclose(rec.times()[[0, 1, -1]], [-0.0125, -0.0124, -0.0125 + 499 / FS])


def test_npz_missing_channel_lists_arrays(tmp_path, channels):
    p = tmp_path / "forces.npz"
    np.savez(p, F1=channels[0], G2=channels[1])
    with pytest.raises(ForceFileError, match=r"no array 'F2' \(channel F2\).*\['F1', 'G2'\]"):
        read_force_file(p, fs_hz=FS)


def test_npz_object_array_is_refused_not_unpickled(tmp_path, channels):
    p = tmp_path / "forces.npz"
    obj = np.empty(2, dtype=object)
    obj[0], obj[1] = {"a": 1}, [1, 2]
    np.savez(p, F1=obj, F2=channels[1])  # np.savez pickles object arrays
    with pytest.raises(ForceFileError, match="without unpickling"):
        read_force_file(p, fs_hz=FS)


def test_npz_length_differs_from_manifest(tmp_path, channels):
    p = tmp_path / "forces.npz"
    np.savez(p, F1=channels[0], F2=channels[1])
    with pytest.raises(
        ForceFileError, match=r"holds 500 samples per channel but the manifest says n_samples=5000"
    ):
        read_force_file(p, fs_hz=FS, n_samples=5000)


def test_channels_of_different_lengths(tmp_path, channels):
    p = tmp_path / "forces.npz"
    np.savez(p, F1=channels[0], F2=channels[1][:-1])
    with pytest.raises(ForceFileError, match=r"500 samples\) and F2 \('F2', 499 samples\)"):
        read_force_file(p, fs_hz=FS)


def test_two_dimensional_channel_refused(tmp_path):
    p = tmp_path / "forces.npz"
    np.savez(p, F1=np.zeros((10, 3)), F2=np.zeros(10))
    with pytest.raises(ForceFileError, match=r"shape \(10, 3\), expected one vector"):
        read_force_file(p, fs_hz=FS)


@pytest.mark.parametrize("fs", [0.0, -1.0, float("nan"), "fast"])
def test_bad_fs(tmp_path, channels, fs):
    p = tmp_path / "forces.npz"
    np.savez(p, F1=channels[0], F2=channels[1])
    with pytest.raises(ValueError, match="fs_hz must be"):
        read_force_file(p, fs_hz=fs)


# --- CSV -----------------------------------------------------------------------------------


def test_csv_round_trip(tmp_path, channels):
    f1, f2 = channels
    p = tmp_path / "forces.csv"
    pd.DataFrame({"time_s": np.arange(500) / FS, "Fz_a": f1, "Fz_b": f2}).to_csv(
        p, index=False, float_format="%.17g"
    )
    rec = read_force_file(p, fs_hz=FS, channels={"F1": "Fz_a", "F2": "Fz_b"})
    _check(rec, f1, f2, "csv")


def test_csv_missing_column_and_non_numeric(tmp_path, channels):
    p = tmp_path / "forces.csv"
    pd.DataFrame({"F1": channels[0], "X": channels[1]}).to_csv(p, index=False)
    with pytest.raises(ForceFileError, match=r"no column 'F2' .*columns: \['F1', 'X'\]"):
        read_force_file(p, fs_hz=FS)
    df = pd.DataFrame({"F1": channels[0].astype(object), "F2": channels[1]})
    df.loc[17, "F1"] = "overload"
    df.to_csv(p, index=False)
    with pytest.raises(ForceFileError, match=r"non-numeric value 'overload' at data row 17"):
        read_force_file(p, fs_hz=FS)


def test_csv_empty_cells_are_nan(tmp_path, channels):
    f1, f2 = channels
    p = tmp_path / "forces.csv"
    df = pd.DataFrame({"F1": f1, "F2": f2})
    df.loc[3:5, "F1"] = np.nan
    df.to_csv(p, index=False, float_format="%.17g")
    rec = read_force_file(p, fs_hz=FS)
    assert np.isnan(rec.f1[3:6]).all() and np.isfinite(rec.f1[6:]).all()


# --- MATLAB ---------------------------------------------------------------------------------


def test_mat_v5_round_trip_column_vectors_and_struct(tmp_path, channels):
    f1, f2 = channels
    p = tmp_path / "forces.mat"
    scipy.io.savemat(p, {"F1": f1[:, None], "rec": {"ch2": f2[None, :]}})  # column and row vectors
    rec = read_force_file(p, fs_hz=FS, channels={"F1": "F1", "F2": "rec.ch2"})
    _check(rec, f1, f2, "mat")
    with pytest.raises(ForceFileError, match=r"no variable 'rec.ch3' \(channel F2\).*\['F1', 'rec'\]"):
        read_force_file(p, fs_hz=FS, channels={"F1": "F1", "F2": "rec.ch3"})


def _write_mat73(path, arrays: dict, classes: dict | None = None):
    """A file laid out like MATLAB's ``save -v7.3``: HDF5 with a 512-byte user block whose
    first 128 bytes are the MATLAB text header, variables at the root stored transposed
    (an n x 1 column vector is a (1, n) dataset) with a MATLAB_class attribute."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, arr in arrays.items():
            d = f.create_dataset(name, data=np.asarray(arr).T)
            d.attrs["MATLAB_class"] = np.bytes_((classes or {}).get(name, "double"))
    header = (
        b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Sun Nov 22 13:00:00 2026 HDF5 schema 1.00 ."
    )
    header = header.ljust(116) + b"\x00" * 8 + b"\x00\x02" + b"IM"
    with open(path, "r+b") as fh:
        fh.write(header)


def test_mat_v73_round_trip(tmp_path, channels):
    f1, f2 = channels
    p = tmp_path / "forces73.mat"
    _write_mat73(p, {"piezo1": f1[:, None], "piezo2": f2[:, None]})
    assert h5py.File(p, "r")["piezo1"].shape == (1, 500)  # MATLAB's transposed layout
    with pytest.raises(NotImplementedError):
        scipy.io.loadmat(p)  # scipy cannot: the reader must take the h5py path
    rec = read_force_file(p, fs_hz=FS, channels={"F1": "piezo1", "F2": "piezo2"})
    _check(rec, f1, f2, "mat")


def test_mat_v73_refuses_cell_and_char(tmp_path, channels):
    p = tmp_path / "forces73.mat"
    _write_mat73(p, {"F1": channels[0][:, None], "F2": np.frombuffer(b"abcd", np.uint8)}, {"F2": "char"})
    with pytest.raises(ForceFileError, match=r"'F2' .* is a MATLAB char"):
        read_force_file(p, fs_hz=FS)


# --- TDMS -----------------------------------------------------------------------------------


def _write_tdms(path, f1, f2, *, increment=1 / FS, second_group=False):
    props = {"wf_increment": increment, "wf_start_offset": 0.0, "unit_string": "N"}
    objs = [
        RootObject({"title": "slide"}),
        GroupObject("Piezo"),
        ChannelObject("Piezo", "Dev1_ai0", f1, properties=props),
        ChannelObject("Piezo", "Dev1_ai1", f2, properties=props),
    ]
    if second_group:
        objs += [GroupObject("Other"), ChannelObject("Other", "Dev1_ai0", f1 * 0, properties=props)]
    with TdmsWriter(path) as w:
        w.write_segment(objs)


def test_tdms_round_trip(tmp_path, channels):
    f1, f2 = channels
    p = tmp_path / "forces.tdms"
    _write_tdms(p, f1, f2)
    rec = read_force_file(p, fs_hz=FS, channels={"F1": "Dev1_ai0", "F2": "Piezo/Dev1_ai1"})
    _check(rec, f1, f2, "tdms")


def test_tdms_rate_in_file_contradicts_manifest(tmp_path, channels):
    p = tmp_path / "forces.tdms"
    _write_tdms(p, *channels, increment=1e-3)
    with pytest.raises(ForceFileError, match=r"states a sampling rate of 1000 Hz but fs_hz=10000 Hz"):
        read_force_file(p, fs_hz=FS, channels={"F1": "Dev1_ai0", "F2": "Dev1_ai1"})


def test_tdms_ambiguous_channel_name(tmp_path, channels):
    p = tmp_path / "forces.tdms"
    _write_tdms(p, *channels, second_group=True)
    with pytest.raises(ForceFileError, match=r"2 channel named 'Dev1_ai0'.*'group/channel'"):
        read_force_file(p, fs_hz=FS, channels={"F1": "Dev1_ai0", "F2": "Dev1_ai1"})
    rec = read_force_file(p, fs_hz=FS, channels={"F1": "Piezo/Dev1_ai0", "F2": "Dev1_ai1"})
    np.testing.assert_array_equal(rec.f1, channels[0])


# --- HDF5 -----------------------------------------------------------------------------------


def test_hdf5_round_trip_nested_paths(tmp_path, channels):
    f1, f2 = channels
    p = tmp_path / "forces.h5"
    with h5py.File(p, "w") as f:
        f["daq/piezo/a"] = f1
        f["daq/piezo/b"] = f2
    rec = read_force_file(p, fs_hz=FS, channels={"F1": "daq/piezo/a", "F2": "daq/piezo/b"})
    _check(rec, f1, f2, "hdf5")
    with pytest.raises(ForceFileError, match=r"no dataset 'daq/piezo/c'.*daq/piezo/a"):
        read_force_file(p, fs_hz=FS, channels={"F1": "daq/piezo/a", "F2": "daq/piezo/c"})


def test_hdf5_fs_attribute_checked(tmp_path, channels):
    p = tmp_path / "forces.hdf5"
    with h5py.File(p, "w") as f:
        f["F1"] = channels[0]
        f["F2"] = channels[1]
        f["F1"].attrs["fs_hz"] = 5000.0
    with pytest.raises(ForceFileError, match=r"5000 Hz but fs_hz=10000 Hz"):
        read_force_file(p, fs_hz=FS)


# --- dispatch and study ----------------------------------------------------------------------


def test_unknown_suffix_and_format(tmp_path):
    p = tmp_path / "forces.bin"
    p.write_bytes(b"\x00" * 16)
    with pytest.raises(ForceFileError, match=r"suffix '.bin'; pass format= one of"):
        read_force_file(p, fs_hz=FS)
    with pytest.raises(ValueError, match=r"format must be one of .* got 'xls'"):
        read_force_file(p, fs_hz=FS, format="xls")
    with pytest.raises(FileNotFoundError, match="does not exist"):
        read_force_file(tmp_path / "none.npz", fs_hz=FS)


def test_corrupt_npz_is_a_clear_error(tmp_path):
    p = tmp_path / "forces.npz"
    p.write_bytes(b"not a zip file at all")
    with pytest.raises(ForceFileError, match="cannot read .* as an .npz archive"):
        read_force_file(p, fs_hz=FS)


def _trial(path="trials/t1/forces.npz", **force):
    f = {
        "path": path,
        "format": "npz",
        "fs_hz": FS,
        "n_samples": 500,
        "channels": {"F1": "a", "F2": "b"},
        "units": "N",
        "t0_s": 0.01,
    }
    f.update(force)
    return {"id": "t1", "force": f}


def test_read_trial_forces_uses_manifest_fields(tmp_path, channels):
    d = tmp_path / "trials" / "t1"
    d.mkdir(parents=True)
    np.savez(d / "forces.npz", a=channels[0], b=channels[1])
    trial = json.loads(json.dumps(_trial()))  # as parsed from manifest.json
    rec = read_trial_forces(tmp_path, trial)
    _check(rec, *channels, "npz")
    assert rec.t0_s == 0.01 and rec.fs_hz == FS
    with pytest.raises(ValueError, match=r"force.path '../outside.npz' escapes the study folder"):
        read_trial_forces(tmp_path, _trial(path="../outside.npz"))
    with pytest.raises(ValueError, match=r"force.units is 'mV'; only 'N'"):
        read_trial_forces(tmp_path, _trial(units="mV"))
    with pytest.raises(ForceFileError, match="n_samples=600"):
        read_trial_forces(tmp_path, _trial(n_samples=600))
