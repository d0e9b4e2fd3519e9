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
from fingerfriction.pipeline.trial import read_trial_forces

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
    with pytest.raises(ForceFileError, match=r"no variable 'rec.ch3' \(channel F2\).*\['F1', 'rec.ch2'\]"):
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
    with pytest.raises(ForceFileError, match=r"channel name 'Dev1_ai0' \(channel F1\) is ambiguous.*"
                       r"2 channels answer to it, in groups \['Other', 'Piezo'\]; give 'group/channel'"):
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
    with pytest.raises(ForceFileError, match=r"suffix '.bin' \(known: .csv.*\); pass format= one of"):
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
    with pytest.raises(ValueError, match=r"trial 't1': force.units 'mV' needs exactly one of sensitivity"):
        read_trial_forces(tmp_path, _trial(units="mV"))
    with pytest.raises(ForceFileError, match="n_samples=600"):
        read_trial_forces(tmp_path, _trial(n_samples=600))


# --- lab files: CSV layouts, time columns, volts, rates from the file ----------------------

from fingerfriction.forces.readers import (  # noqa: E402
    channel_scale,
    csv_layout,
    list_channels,
    probe_force_file,
)


def _write_delimited(path, columns, *, delimiter=",", decimal=".", header=None, comments=()):
    lines = [f"# {c}" for c in comments]
    if header is not None:
        lines.append(delimiter.join(header))
    for row in zip(*columns, strict=True):
        fields = [repr(float(v)) for v in row]
        if decimal == ",":
            fields = [f.replace(".", ",") for f in fields]
        lines.append(delimiter.join(fields))
    path.write_text("\n".join(lines) + "\n")


_LAYOUTS = [(d, dec) for d in (",", ";", "\t", "|", "   ") for dec in (".", ",") if (d, dec) != (",", ",")]


@pytest.mark.parametrize("delimiter, decimal", _LAYOUTS)
@pytest.mark.parametrize("header", [True, False])
def test_csv_layouts_read_back_exactly(tmp_path, channels, delimiter, decimal, header):
    f1, f2 = channels
    t = np.arange(f1.size) / FS
    p = tmp_path / "forces.txt"
    _write_delimited(p, [t, f1, f2], delimiter=delimiter, decimal=decimal,
                     header=["time_s", "ai0", "ai1"] if header else None, comments=["DAQ export"])
    lay = csv_layout(p)
    assert lay.decimal == decimal and lay.n_columns == 3
    assert lay.delimiter == (r"\s+" if delimiter == "   " else delimiter)
    assert (lay.header == ("time_s", "ai0", "ai1")) if header else lay.header is None
    chans = {"F1": "ai0", "F2": "ai1"} if header else {"F1": 1, "F2": 2}
    rec = read_force_file(p, channels=chans, time="time_s" if header else 0, format="csv")
    _check(rec, f1, f2, "csv")
    assert rec.fs_hz == pytest.approx(FS, rel=1e-9)


def test_headerless_semicolon_csv_in_volts_with_time_column(tmp_path, channels):
    """A lab's file as its acquisition software wrote it: no header, ';', a time column
    starting at 0.25 s, two piezo channels in volts from charge amplifiers set to 10 and 20 N/V."""
    f1, f2 = channels
    v1, v2 = f1 / 10.0, f2 / 20.0
    t = 0.25 + np.arange(f1.size) / FS
    p = tmp_path / "S1_bump.csv"
    _write_delimited(p, [t, v1, v2], delimiter=";")
    rec = read_force_file(p, fs_hz=FS, channels={"F1": 1, "F2": "2"}, time=0, t0_s=-0.5, units="V",
                          sensitivity_n_per_v={"F1": 10.0, "F2": 20.0}, n_samples=500)
    np.testing.assert_allclose(rec.f1, f1, rtol=1e-14)
    np.testing.assert_allclose(rec.f2, f2, rtol=1e-14)
    assert rec.units == "V" and rec.scale == {"F1": 10.0, "F2": 20.0}
    # sample n at t0_s + time[n]: the file's clock shifted by the manifest's offset
    assert rec.t0_s == pytest.approx(-0.25, abs=1e-12)
    np.testing.assert_allclose(rec.times(), -0.5 + t, atol=1e-12)
    # the same through the manifest fields
    (tmp_path / "trials").mkdir()
    trial = {"id": "S1", "force": {"path": "S1_bump.csv", "format": "csv", "channels": {"F1": 1, "F2": 2},
                                   "time": 0, "t0_s": -0.5, "units": "mV",
                                   "gain_v_per_n": {"F1": 0.1, "F2": 0.05}}}
    rec2 = read_trial_forces(tmp_path, trial)  # 0.1 and 0.05 V/N = 10 and 20 N/V
    np.testing.assert_allclose(rec2.f1, f1 * 1e-3, rtol=1e-14)  # the file holds volts, read as mV
    assert rec2.fs_hz == pytest.approx(FS, rel=1e-9)  # from the time column, no fs_hz given


def test_headerless_csv_names_columns_by_index(tmp_path, channels):
    p = tmp_path / "f.csv"
    _write_delimited(p, [channels[0], channels[1]], delimiter=";")
    with pytest.raises(ForceFileError, match=r"no column 'F1' \(channel F1\).*no header row.*"
                                              r"0-based index \(0\.\.1\); first row: \['"):
        read_force_file(p, fs_hz=FS)
    with pytest.raises(ForceFileError, match=r"column index 2 \(channel F2\) is out of range.*2 columns"):
        read_force_file(p, fs_hz=FS, channels={"F1": 0, "F2": 2})
    assert list_channels(p) == ["0", "1"]


def test_decimal_comma_semicolon_file_the_sniffer_gets_wrong(tmp_path):
    import csv

    text = "0,0001;0,12;-0,3\n0,0002;0,13;-0,31\n0,0003;0,1;-0,3\n"
    assert csv.Sniffer().sniff(text, delimiters=",;\t|").delimiter == ","  # why csv_layout counts first
    p = tmp_path / "f.csv"
    p.write_text(text)
    rec = read_force_file(p, channels={"F1": 1, "F2": 2}, time=0)
    np.testing.assert_allclose(rec.f1, [0.12, 0.13, 0.1])
    np.testing.assert_allclose(rec.f2, [-0.3, -0.31, -0.3])
    assert rec.fs_hz == pytest.approx(10_000.0)


def test_time_column_checked_against_fs(tmp_path, channels):
    f1, f2 = channels
    p = tmp_path / "f.csv"
    pd.DataFrame({"t": np.arange(500) / FS, "a": f1, "b": f2}).to_csv(p, index=False)
    ch = {"F1": "a", "F2": "b"}
    with pytest.raises(ForceFileError, match=r"time column 't' gives a sampling rate of 10000 Hz but "
                                              r"fs_hz=5000 Hz"):
        read_force_file(p, fs_hz=5000.0, channels=ch, time="t")
    pd.DataFrame({"t": np.arange(500) / FS * 1e3, "a": f1, "b": f2}).to_csv(p, index=False)
    with pytest.raises(ForceFileError, match=r"is the time column in ms\? it must be in s"):
        read_force_file(p, fs_hz=FS, channels=ch, time="t")


@pytest.mark.parametrize("defect, message", [
    ("gap", r"not uniformly sampled: row \d+ .* sample periods off the line .* missing or repeated"),
    ("repeat", r"does not increase at row 201"),
    ("nan", r"has a missing value at row 7"),
])
def test_time_column_defects(tmp_path, channels, defect, message):
    t = np.arange(500) / FS
    if defect == "gap":
        t[250:] += 1 / FS  # one sample missing
    elif defect == "repeat":
        t[201] = t[200]
    else:
        t[7] = np.nan
    p = tmp_path / "f.csv"
    pd.DataFrame({"t": t, "F1": channels[0], "F2": channels[1]}).to_csv(p, index=False)
    with pytest.raises(ForceFileError, match=message):
        read_force_file(p, time="t")


def test_time_column_jitter_below_a_quarter_sample_is_accepted(tmp_path, channels):
    rng = np.random.default_rng(1)
    t = 0.1 + np.arange(500) / FS + rng.uniform(-0.2, 0.2, 500) / FS
    p = tmp_path / "f.csv"
    pd.DataFrame({"t": t, "F1": channels[0], "F2": channels[1]}).to_csv(p, index=False)
    rec = read_force_file(p, time="t", fs_hz=FS)
    assert rec.t0_s == pytest.approx(0.1, abs=0.05 / FS)


def test_rate_from_the_file_when_fs_is_omitted(tmp_path, channels):
    p = tmp_path / "forces.tdms"
    _write_tdms(p, *channels, increment=1 / 2000.0)
    rec = read_force_file(p, channels={"F1": "Dev1_ai0", "F2": "Dev1_ai1"})
    assert rec.fs_hz == pytest.approx(2000.0)
    q = tmp_path / "forces.npz"
    np.savez(q, F1=channels[0], F2=channels[1])
    with pytest.raises(ForceFileError, match=r"states no sampling rate; give fs_hz \(manifest force.fs_hz\)"):
        read_force_file(q)


def test_tdms_missing_channel_lists_group_channel_paths(tmp_path, channels):
    p = tmp_path / "forces.tdms"
    _write_tdms(p, *channels, second_group=True)
    names = r"\['Other/Dev1_ai0', 'Piezo/Dev1_ai0', 'Piezo/Dev1_ai1'\]"
    with pytest.raises(ForceFileError, match=r"no channel named 'ai7' \(channel F2\).*'group/channel', "
                       "one of " + names):
        read_force_file(p, fs_hz=FS, channels={"F1": "Piezo/Dev1_ai0", "F2": "ai7"})
    with pytest.raises(ForceFileError, match=r"column index 0, but .* is a tdms file"):
        read_force_file(p, fs_hz=FS, channels={"F1": 0, "F2": 1})
    assert list_channels(p) == ["Other/Dev1_ai0", "Piezo/Dev1_ai0", "Piezo/Dev1_ai1"]


def test_mat73_missing_variable_lists_struct_fields(tmp_path, channels):
    p = tmp_path / "forces73.mat"
    with h5py.File(p, "w", userblock_size=512) as f:
        f.create_dataset("daq/ai0", data=channels[0][None, :])
        f.create_dataset("daq/ai1", data=channels[1][None, :])
    rec = read_force_file(p, fs_hz=FS, channels={"F1": "daq.ai0", "F2": "daq/ai1"})
    _check(rec, *channels, "mat")
    with pytest.raises(ForceFileError, match=r"no variable 'daq.ai2' .*\['daq.ai0', 'daq.ai1'\]"):
        read_force_file(p, fs_hz=FS, channels={"F1": "daq.ai0", "F2": "daq.ai2"})


def test_probe_force_file_counts_samples_and_reads_rates(tmp_path, channels):
    p = tmp_path / "forces.tdms"
    _write_tdms(p, *channels)
    info = probe_force_file(p, channels={"F1": "Dev1_ai0", "F2": "Dev1_ai1"})
    assert (info.format, info.n_samples, info.fs_hz) == ("tdms", 500, pytest.approx(FS))
    assert info.names == ("Piezo/Dev1_ai0", "Piezo/Dev1_ai1")
    q = tmp_path / "f.csv"
    _write_delimited(q, [0.5 + np.arange(500) / 2000.0, *channels], delimiter=";")
    info = probe_force_file(q, channels={"F1": 1, "F2": 2}, time=0)
    assert info.header is False and info.delimiter == ";" and info.n_samples == 500
    assert info.fs_hz == pytest.approx(2000.0) and info.time0_s == pytest.approx(0.5)
    r = tmp_path / "forces.npz"
    np.savez(r, F1=channels[0], F2=channels[1], T=np.zeros(3))
    info = probe_force_file(r)  # F1/F2 by default when the file has them
    assert info.n_samples == 500 and info.fs_hz is None and set(info.names) == {"F1", "F2", "T"}


def test_channel_scale_rules():
    assert channel_scale() == {"F1": 1.0, "F2": 1.0}
    assert channel_scale("V", 10.0) == {"F1": 10.0, "F2": 10.0}
    assert channel_scale("mV", gain_v_per_n={"F1": 0.5, "F2": -0.25}) == {"F1": 2e-3, "F2": -4e-3}
    with pytest.raises(ValueError, match=r"units 'V' needs exactly one of .* got both"):
        channel_scale("V", 10.0, 0.1)
    with pytest.raises(ValueError, match=r"sensitivity_n_per_v is for channels in volts, but units is 'N'"):
        channel_scale("N", 10.0)
    with pytest.raises(ValueError, match=r"sensitivity_n_per_v for F2 must be finite and non-zero"):
        channel_scale("V", {"F1": 1.0, "F2": 0.0})
    with pytest.raises(ValueError, match=r"units must be one of N, V, mV, got 'kN'"):
        channel_scale("kN")


def test_tdms_start_offset_places_sample_zero(tmp_path, channels):
    p = tmp_path / "forces.tdms"
    props = {"wf_increment": 1 / FS, "wf_start_offset": -0.02}
    with TdmsWriter(p) as w:
        w.write_segment([RootObject({}), GroupObject("Piezo"),
                         ChannelObject("Piezo", "ai0", channels[0], properties=props),
                         ChannelObject("Piezo", "ai1", channels[1], properties=props)])
    rec = read_force_file(p, channels={"F1": "ai0", "F2": "ai1"}, t0_s=0.5)
    assert rec.t0_s == pytest.approx(0.48) and rec.fs_hz == pytest.approx(FS)
    assert probe_force_file(p, channels={"F1": "ai0", "F2": "ai1"}).time0_s == pytest.approx(-0.02)
