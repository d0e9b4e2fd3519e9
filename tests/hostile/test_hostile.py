"""Hostile inputs and faults on a 2-trial study: each case has its expected
outcome, and every case is held to four invariants.

Outcomes: ``error`` (exit status 2, one ``error:`` line naming what is wrong), ``flagged``
(exit status 1, the run done and the trouble said), ``handled`` (exit status 0, the
right thing done). Invariants, checked after every command of every case:

* no traceback (an exception escaping a command, or one printed);
* no read outside the study: every file a case points at from inside the study lives in
  one folder, ``outside/``, watched with Linux inotify for opens and reads (by any process:
  the command and the Dask workers);
* no lost result: a trial analysed OK before keeps tables that verify (size and SHA-256)
  unless it was computed again from its present inputs;
* no silent stale result: every trial whose status is ok was computed from the inputs the
  study holds now (their SHA-256), or is marked ``input missing``; a report exits 0 only
  with a fit of the present analysis.

The study is simulated once per session (bridged-foundation contact model, a 1280 x 360
camera at 250 frames/s: about 100 frames a trial) and analysed on one Dask cluster kept for
the session, so each case costs its own work only. Processes are used where a case needs
one: ``kill -9`` mid-run, two runs at once, a read-only folder.
"""

from __future__ import annotations

import ctypes
import errno
import hashlib
import json
import os
import re
import shutil
import signal
import struct
import subprocess
import sys
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.study.store import ResultsStore

pytestmark = [pytest.mark.slow, pytest.mark.skipif(sys.platform != "linux", reason="inotify is Linux's")]

SRC = Path(__file__).resolve().parents[2] / "src"
DATA = Path(__file__).resolve().parents[1] / "data"
runner = CliRunner()
IDS = ("s1-bump-2mm-v120-r1", "s1-bump-2mm-v120-r2")
T1, T2 = IDS


# --------------------------------------------------------------------------------------
# watching a folder for opens and reads (inotify through ctypes)
# --------------------------------------------------------------------------------------

IN_ACCESS, IN_OPEN = 0x001, 0x020
IN_NONBLOCK = os.O_NONBLOCK


class Watch:
    """Opens and reads of the files of one folder, by any process (inotify)."""

    def __init__(self, folder: Path):
        libc = ctypes.CDLL(None, use_errno=True)
        self.fd = libc.inotify_init1(IN_NONBLOCK)
        if self.fd < 0:
            raise OSError(ctypes.get_errno(), "inotify_init1")
        if libc.inotify_add_watch(self.fd, str(folder).encode(), IN_ACCESS | IN_OPEN) < 0:
            raise OSError(ctypes.get_errno(), "inotify_add_watch")

    def events(self) -> list[str]:
        """The names opened or read since the last call."""
        out = []
        while True:
            try:
                buf = os.read(self.fd, 65536)
            except BlockingIOError:
                return out
            i = 0
            while i < len(buf):
                _wd, mask, _cookie, n = struct.unpack_from("iIII", buf, i)
                name = buf[i + 16:i + 16 + n].rstrip(b"\0").decode()
                out.append(f"{'open' if mask & IN_OPEN else 'read'} {name}")
                i += 16 + n


# --------------------------------------------------------------------------------------
# the session: one study, its analysed and fitted results, a Dask cluster, the outside
# --------------------------------------------------------------------------------------


@dataclass
class Session:
    base: Path
    study: Path
    results: Path
    outside: Path
    scheduler: str
    watch: Watch
    log: list = field(default_factory=list)  # (case, outcome, status) of every case


def _simulate(study: Path) -> None:
    from fingerfriction.sim import SimOptions, simulate_study
    from fingerfriction.sim.camera import CameraParams

    # a coarse one-load contact table (0.05 mm, 0.3 N; the default is 0.02 mm at three loads):
    # the cases are about the files, not the contact
    simulate_study(study, SimOptions(reps=2, subjects=("1",), surfaces=("bump-2mm",), speeds=(120.0,), seed=3,
                                     contact_model="bridged-foundation", table_step=0.05, table_loads=(0.3,),
                                     camera=CameraParams(fps=250.0, height=360, y0_row=320.0)), workers=1)


def _outside_files(outside: Path) -> None:
    """What the hostile files point at, outside the study: distinctive data everywhere."""
    outside.mkdir()
    with h5py.File(outside / "forces.h5", "w") as f:
        f["F1"] = np.full(6638, 1e6)
        f["F2"] = np.full(6638, 1e6)
    np.full(6638, 1e6).tofile(outside / "raw.bin")
    import tifffile

    tifffile.imwrite(outside / "frame.tif", np.zeros((360, 1280), np.uint8))
    (outside / "segment.ts").write_bytes(b"\0" * 188)
    (outside / "profile.csv").write_text("x,h\n-1,0\n0,0.1\n1,0\n2,0\n")
    (outside / "bump:W=3,H=0.5").write_text("x,h\n-1,0\n0,0.1\n1,0\n2,0\n")  # a file named as a spec
    (outside / "index.tdms_index").write_bytes(b"TDSh" + b"\0" * 28)


@pytest.fixture(scope="session")
def session(tmp_path_factory):
    from distributed import LocalCluster

    base = tmp_path_factory.mktemp("hostile")
    study, results = base / "study", base / "results"
    _simulate(study)
    _outside_files(base / "outside")
    cluster = LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                           silence_logs=40)
    try:
        s = Session(base, study, results, base / "outside", cluster.scheduler_address,
                    Watch(base / "outside"))
        code, out = _cli(s, "analyze", study, "--out", results, "--scheduler", s.scheduler)
        assert code == 0 and "2 computed" in out, out
        code, out = _cli(s, "fit", results)
        assert code == 0, out
        s.watch.events()
        yield s
    finally:
        cluster.close()
    n = {k: sum(1 for _, o, _ in s.log if o == k) for k in ("error", "flagged", "handled")}
    print(f"\nhostile cases run in this process: {len(s.log)} ({n})")


def _cli(s: Session, *args) -> tuple[int, str]:
    """One command in this process; no traceback, ever."""
    r = runner.invoke(app, [str(a) for a in args])
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise AssertionError(f"traceback from {args}: {r.exception!r}\n{r.output}")
    assert "Traceback" not in r.output, r.output
    return r.exit_code, " ".join(r.output.split())


@dataclass
class Work:
    """One case's copies of the study and of the analysed, fitted results."""

    s: Session
    study: Path
    results: Path
    analyzed: bool = False  # an analyze ran on the results (the invariants are about what it left)

    @property
    def manifest(self) -> dict:
        return json.loads((self.study / "manifest.json").read_text())

    def write_manifest(self, m) -> None:
        (self.study / "manifest.json").write_text(m if isinstance(m, str) else json.dumps(m, indent=1))

    def entry(self, i: int, **changes) -> None:
        m = self.manifest
        for path, value in changes.items():
            node = m["trials"][i]
            *head, last = path.split("__")
            for k in head:
                node = node[k]
            node[last] = value
        self.write_manifest(m)

    def file(self, trial: int, key: str) -> Path:
        return self.study / self.manifest["trials"][trial][key]["path"]

    def run(self, *args) -> tuple[int, str]:
        self.s.watch.events()  # what the case's own set-up opened
        code, out = _cli(self.s, *args)
        seen = self.s.watch.events()
        assert not seen, f"{args} read outside the study: {seen}"
        return code, out

    def analyze(self, *extra) -> tuple[int, str]:
        self.analyzed = self.analyzed or "--dry-run" not in extra
        return self.run("analyze", self.study, "--out", self.results, "--scheduler", self.s.scheduler, *extra)

    def check(self) -> tuple[int, str]:
        return self.run("check", self.study)


@pytest.fixture
def w(session, tmp_path):
    study, results = tmp_path / "study", tmp_path / "results"
    shutil.copytree(session.study, study)
    shutil.copytree(session.results, results)
    run = json.loads((results / "run.json").read_text())  # these results are of this copy
    (results / "run.json").write_text(json.dumps({**run, "study": str(study.resolve())}))
    work = Work(session, study, results)
    yield work
    _invariants(work)


def _invariants(w: Work) -> None:
    """No lost and no silent stale result in the case's results folder, after an analyze."""
    store = ResultsStore(w.results)
    if not w.analyzed or not (w.results / "run.json").is_file():
        return
    try:
        entries = {t["id"]: t for t in json.loads((w.study / "manifest.json").read_text())["trials"]}
    except (ValueError, KeyError, TypeError, OSError, RecursionError):  # a hostile manifest
        entries = {}
    for tid in store.trial_ids():
        st = store.status(tid) or {}
        if st.get("status") != "ok":
            continue
        assert _damaged(store, tid, st) is None, f"{tid}: a damaged result looks ok"
        if st.get("input_missing") or tid not in entries:
            continue
        for key in ("video", "force"):
            p = w.study / entries[tid][key]["path"]
            if not p.exists():
                continue
            if (st["inputs"][key]["path"] == entries[tid][key]["path"]
                    and st["inputs"][key]["sha256"] != _digest(p)):
                raise AssertionError(f"{tid}: ok, but computed from another {key} than the study holds")


def _digest(path: Path) -> str:
    """SHA-256 of a file, or of a TIFF folder as the results record it (the test's own
    reading of what the results say they were computed from)."""
    if path.is_dir():
        from fingerfriction.study.store import sha256_input  # how a folder is summed

        return sha256_input(path)
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _damaged(store: ResultsStore, tid: str, status: dict) -> str | None:
    """Why a trial's stored tables are not the ones its status says were written, or None:
    the recorded size and SHA-256 (``tables``), else a readable Parquet file (its footer)."""
    import pyarrow.parquet as pq

    for name in ("frames.parquet", "forces.parquet"):
        p = store.root / "trials" / tid / name
        rec = (status.get("tables") or {}).get(name)
        try:
            if rec:
                if hashlib.sha256(p.read_bytes()).hexdigest() != rec["sha256"]:
                    return f"{name}: not the bytes written"
            else:
                pq.read_metadata(p)
        except Exception as exc:  # noqa: BLE001 - any failure to read is damage
            return f"{name}: {exc!r}"
    return None


def _expect(w: Work, case: str, outcome: str, code: int, out: str, pattern: str) -> None:
    """The outcome of a case: its exit status, and what it said."""
    want = {"error": 2, "flagged": 1, "handled": 0}[outcome]
    assert code == want, f"{case}: exit status {code}, expected {want} ({outcome}): {out}"
    assert re.search(pattern, out), f"{case}: {pattern!r} not in: {out}"
    if outcome == "error":
        assert out.count("error:") == 1, out  # one error line
    w.s.log.append((case, outcome, code))


# --------------------------------------------------------------------------------------
# files other software wrote, and files pointing outside the study
# --------------------------------------------------------------------------------------


def _load_forces(w: Work, i: int) -> tuple[np.ndarray, np.ndarray]:
    with np.load(w.file(i, "force")) as z:
        return z["F1"].copy(), z["F2"].copy()


def _use_force_file(w: Work, i: int, name: str, **force) -> Path:
    p = w.file(i, "force").with_name(name)
    w.entry(i, force__path=str(p.relative_to(w.study)), force__format=force.pop("format", None) or
            {"tdms": "tdms", "mat": "mat", "h5": "hdf5"}[name.rsplit(".", 1)[1]],
            **{f"force__{k}": v for k, v in force.items()})
    return p


def _tdms(path: Path, groups: dict, rate: float = 10_000.0) -> None:
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    props = {"wf_increment": 1.0 / rate, "wf_start_offset": 0.0}
    objs = [RootObject({})]
    for g, chans in groups.items():
        objs.append(GroupObject(g))
        objs += [ChannelObject(g, c, v, properties=props) for c, v in chans.items()]
    with TdmsWriter(path) as wr:
        wr.write_segment(objs)


DATE = "07/09/2012 06:58:23 PM - Piezo - All Data"


def test_tdms_date_named_group_default_channels(w):
    f1, f2 = _load_forces(w, 0)
    _tdms(_use_force_file(w, 0, "forces.tdms"), {DATE: {"F1": f1, "F2": f2}})
    code, out = w.check()
    _expect(w, "tdms-date-group", "handled", code, out, "2 trials, no problem found")


def test_tdms_name_in_three_groups_is_ambiguous(w):
    f1, f2 = _load_forces(w, 0)
    _tdms(_use_force_file(w, 0, "forces.tdms", channels={"F1": "ai0", "F2": "F2"}),
          {DATE: {"ai0": f1, "F2": f2}, "Trig": {"ai0": f1}, "Aux": {"ai0": f1}})
    code, out = w.check()
    _expect(w, "tdms-ambiguous", "error", code, out, r"channel name 'ai0' \(channel F1\) is ambiguous")


def test_tdms_index_beside_it_links_outside(w):
    f1, f2 = _load_forces(w, 0)
    p = _use_force_file(w, 0, "forces.tdms")
    _tdms(p, {DATE: {"F1": f1, "F2": f2}})
    os.symlink(w.s.outside / "index.tdms_index", p.with_name("forces.tdms_index"))
    code, out = w.check()
    _expect(w, "tdms-index-outside", "handled", code, out, "no problem found")


def _mat73(path: Path, build) -> None:
    with h5py.File(path, "w", userblock_size=512) as f:
        build(f)
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 .")


def test_mat73_empty_variable(w):
    f1, f2 = _load_forces(w, 0)

    def build(f):
        f["F2"] = f2[None, :]
        f["F1"] = np.array([0, 10], np.uint64)
        f["F1"].attrs["MATLAB_class"] = np.bytes_("double")
        f["F1"].attrs["MATLAB_empty"] = np.uint8(1)

    _mat73(_use_force_file(w, 0, "forces.mat"), build)
    code, out = w.check()
    _expect(w, "mat73-empty", "error", code, out, r"is an empty MATLAB double array")


def _sparse_column(f, name: str, values: np.ndarray) -> None:
    """A MATLAB v7.3 sparse column: a group of data, ir, jc with MATLAB_sparse = its rows."""
    g = f.create_group(name)
    g.attrs["MATLAB_class"] = np.bytes_("double")
    g.attrs["MATLAB_sparse"] = np.uint64(values.size)
    g["data"], g["ir"] = values, np.arange(values.size, dtype=np.uint64)
    g["jc"] = np.array([0, values.size], np.uint64)


@pytest.mark.parametrize("case,sparse,channels,pattern", [
    ("mat73-sparse", "F1", None, r"'F1' \(channel F1\) .* is a MATLAB sparse matrix"),
    ("mat73-sparse-internals", "S", {"F1": "S.data", "F2": "F2"}, r"'S.data' .* is part of the variable 'S'"),
])
def test_mat73_sparse(w, case, sparse, channels, pattern):
    f1, f2 = _load_forces(w, 0)

    def build(f):
        f["F2"] = f2[None, :]
        _sparse_column(f, sparse, f1)

    _mat73(_use_force_file(w, 0, "forces.mat", **({"channels": channels} if channels else {})), build)
    code, out = w.check()
    _expect(w, case, "error", code, out, pattern)


def test_mat_v5_sparse_variable(w):
    import scipy.io
    import scipy.sparse

    f1, f2 = _load_forces(w, 0)
    p = _use_force_file(w, 0, "forces.mat")
    scipy.io.savemat(p, {"F1": scipy.sparse.csc_matrix(f1[:, None]), "F2": f2})
    code, out = w.check()
    _expect(w, "mat5-sparse", "error", code, out, r"'F1' \(channel F1\) .* is a MATLAB sparse matrix")


def _external_links(w: Work) -> None:
    """Trial 1's forces: an HDF5 file whose F1, F2 are links to a file outside the study."""
    p = _use_force_file(w, 0, "forces.h5", fs_hz=10_000.0)
    with h5py.File(p, "w") as f:
        f["F1"] = h5py.ExternalLink(str(w.s.outside / "forces.h5"), "/F1")
        f["F2"] = h5py.ExternalLink(str(w.s.outside / "forces.h5"), "/F2")


def test_hdf5_external_link_outside(w):
    _external_links(w)
    code, out = w.check()
    _expect(w, "hdf5-external-link", "error", code, out,
            r"takes data from another file \('F1' is an external link")


def test_hdf5_external_link_is_a_failed_trial_in_analyze(w):
    _external_links(w)
    code, out = w.analyze()
    _expect(w, "hdf5-external-link-analyze", "flagged", code, out,
            r"1 analysis failure .* takes data fr.*0 computed, 1 already done, 1 failed of 2 trials")
    status = ResultsStore(w.results).status(T1)
    assert status["status"] == "failed"
    assert "takes data from another file ('F1' is an external" in status["reason"]


def test_hdf5_virtual_dataset_outside(w):
    p = _use_force_file(w, 0, "forces.h5", fs_hz=10_000.0)
    with h5py.File(p, "w") as f:
        for name in ("F1", "F2"):
            layout = h5py.VirtualLayout(shape=(6638,), dtype="f8")
            layout[:] = h5py.VirtualSource(str(w.s.outside / "forces.h5"), name, shape=(6638,))
            f.create_virtual_dataset(name, layout)
    code, out = w.check()
    _expect(w, "hdf5-virtual-dataset", "error", code, out, r"is a virtual dataset mapped from")


def test_hdf5_external_raw_storage_outside(w):
    p = _use_force_file(w, 0, "forces.h5", fs_hz=10_000.0)
    with h5py.File(p, "w") as f:
        for name in ("F1", "F2"):
            f.create_dataset(name, shape=(6638,), dtype="f8",
                             external=[(str(w.s.outside / "raw.bin"), 0, 8 * 6638)])
    code, out = w.check()
    _expect(w, "hdf5-external-storage", "error", code, out, r"keeps its data in external file")


def test_mat73_external_link_outside(w):
    def build(f):
        f["F1"] = h5py.ExternalLink(str(w.s.outside / "forces.h5"), "/F1")
        f["F2"] = h5py.ExternalLink(str(w.s.outside / "forces.h5"), "/F2")

    _mat73(_use_force_file(w, 0, "forces.mat", fs_hz=10_000.0), build)
    code, out = w.check()
    _expect(w, "mat73-external-link", "error", code, out, r"takes data from another file")


def test_truncated_force_file(w):
    p = w.file(0, "force")
    p.write_bytes(p.read_bytes()[:500])
    code, out = w.check()
    _expect(w, "force-truncated", "error", code, out, r"cannot read .* as an \.npz archive")


def test_npz_that_inflates_beyond_the_bound(w):
    """An archive whose F1 says it inflates to 4 GB (its central directory's uncompressed
    size, what a zip bomb has and what is read before inflating anything)."""
    p = w.file(0, "force")
    f1, f2 = _load_forces(w, 0)
    np.savez_compressed(p, F1=f1, F2=f2)
    data = bytearray(p.read_bytes())
    entry = data.index(b"PK\x01\x02")  # the central directory's first entry: F1.npy
    assert data[entry + 46:entry + 52] == b"F1.npy"
    data[entry + 24:entry + 28] = (4_000_000_000).to_bytes(4, "little")  # uncompressed size
    p.write_bytes(bytes(data))
    with zipfile.ZipFile(p) as z:
        assert z.getinfo("F1.npy").file_size == 4_000_000_000
    code, out = w.check()
    _expect(w, "npz-bomb", "error", code, out, r"more than the 50000000 a trial may have")


def test_npz_with_a_pickled_object(w):
    obj = np.empty(2, dtype=object)
    obj[0] = {"a": 1}
    np.savez(w.file(0, "force"), F1=obj, F2=np.zeros(2))
    code, out = w.check()
    _expect(w, "npz-pickle", "error", code, out, r"cannot be read without unpickling")


@pytest.mark.parametrize("key,pattern", [("force", r"force.path: .* is not a file"),
                                         ("video", r"video.path: .* not a regular file")])
def test_input_is_a_fifo(w, key, pattern):
    """A named pipe where a recording should be: opening it would wait for ever."""
    p = w.file(0, key)
    p.unlink()
    os.mkfifo(p)
    code, out = w.check()
    _expect(w, f"{key}-fifo", "error", code, out, pattern)


# --------------------------------------------------------------------------------------
# videos
# --------------------------------------------------------------------------------------


def _tiff_folder(w: Work, i: int, name: str = "frames") -> Path:
    import tifffile

    from fingerfriction.video.readers import open_video

    folder = w.file(i, "video").with_name(name)
    folder.mkdir()
    with open_video(w.file(i, "video")) as r:
        for start, chunk in r.iter_chunks(64):
            for k, frame in enumerate(chunk):
                tifffile.imwrite(folder / f"frame{start + k}.tif", frame)
    w.entry(i, video__path=str(folder.relative_to(w.study)), video__format="tiff")
    return folder


def test_tiff_folder_video_is_analysed(w):
    _tiff_folder(w, 1)
    code, out = w.analyze()
    _expect(w, "tiff-folder", "handled", code, out, r"1 computed, 1 already done, 0 failed of 2 trials")
    st = ResultsStore(w.results).status(T2)
    assert st["inputs"]["video"]["sha256"] == _digest(w.study / st["inputs"]["video"]["path"])


def test_tiff_folder_frame_linking_outside(w):
    folder = _tiff_folder(w, 1)
    os.symlink(w.s.outside / "frame.tif", folder / "frame999.tif")
    code, out = w.check()
    _expect(w, "tiff-frame-outside", "error", code, out,
            r"frame999.tif: frame file links to .*outside the folder")


def test_video_that_is_a_playlist_of_outside_files(w):
    p = w.file(0, "video")
    p.write_text("#EXTM3U\n#EXT-X-TARGETDURATION:1\n#EXTINF:1,\n"
                 f"{w.s.outside / 'segment.ts'}\n#EXT-X-ENDLIST\n")
    code, out = w.check()
    _expect(w, "video-playlist", "error", code, out, r"cannot be read as a video")


def test_video_symlink_outside(w):
    p = w.file(0, "video")
    p.unlink()
    os.symlink(w.s.outside / "frame.tif", p)
    code, out = w.check()
    _expect(w, "video-symlink-outside", "error", code, out, r"outside the study folder")


def test_packed_10_bit_cine(w):
    p = w.file(0, "video").with_name("video.cine")
    shutil.copy(DATA / "cine" / "packed_10.cine", p)
    w.entry(0, video__path=str(p.relative_to(w.study)), video__format="cine")
    code, out = w.check()
    _expect(w, "cine-packed-10", "error", code, out, r"packed 10/12-bit pixels")


# --------------------------------------------------------------------------------------
# manifests
# --------------------------------------------------------------------------------------


def _one_sub(pattern: str, repl: str, text: str) -> str:
    """``text`` with the first match of ``pattern`` replaced; fails if nothing matched."""
    out, n = re.subn(pattern, lambda _m: repl, text, count=1)
    assert n == 1, f"the manifest has no {pattern!r} to edit"
    return out


@pytest.mark.parametrize("case,edit,pattern", [
    ("n-frames-10e400", lambda w: w.write_manifest(_one_sub(r'"n_frames": \d+', '"n_frames": 1' + "0" * 400,
                                                            (w.study / "manifest.json").read_text())),
     r"n_frames: must be at most 1e\+07 frames"),
    ("sensitivity-400-digits", lambda w: (w.entry(0, force__units="V", force__sensitivity_n_per_v="S"),
                                          w.write_manifest((w.study / "manifest.json").read_text().replace(
                                              '"S"', "1" + "0" * 400)))[1],
     r"sensitivity_n_per_v for F1 must be within 1e-9 and 1e9 in magnitude"),
    ("manifest-deeply-nested",
     lambda w: w.write_manifest('{"trials": ' + "[" * 100_000 + "]" * 100_000 + "}"),
     r"nested too deeply"),
    ("manifest-5000-digit-integer", lambda w: w.write_manifest('{"x": ' + "7" * 5000 + "}"),
     r"not valid JSON"),
    ("manifest-not-utf8", lambda w: (w.study / "manifest.json").write_bytes(b"\xff\xfe{}"),
     r"manifest is not UTF-8|not valid JSON"),
    ("manifest-nan", lambda w: w.entry(0, speed_mm_s=float("nan")), r"speed_mm_s: must be finite"),
    ("speed-1e9", lambda w: w.entry(0, speed_mm_s=1e9), r"speed_mm_s: must be at most 10000 mm/s"),
    ("fs-1e12", lambda w: w.entry(0, force__fs_hz=1e12), r"fs_hz: must be at most 1e\+07 Hz"),
    ("path-dotdot", lambda w: w.entry(0, video__path="../outside/frame.tif"), r"escapes the study folder"),
    ("path-absolute", lambda w: w.entry(0, force__path=str(w.s.outside / "forces.h5")), r"absolute path"),
    ("surface-1e9", lambda w: w.entry(0, surface="bump:W=1e9,H=1e9"),
     r"width W = 1e\+09 mm is outside the physical range"),
    ("surface-steep", lambda w: w.entry(0, surface="bump:W=1,H=8"), r"steeper than the 80 degrees"),
    ("sampled-surface-1e9", lambda w: w.write_manifest(json.dumps(dict(w.manifest, surfaces={"bump-2mm": {
        "kind": "sampled", "x": [0, 1e9, 2e9, 3e9], "h": [0, 1, 0, 0]}}))), r"a profile may span 200 mm"),
    ("trial-id-bad-characters", lambda w: w.entry(0, id="../../x"), r"trial id must be letters"),
    ("calibration-height-1e6", lambda w: w.entry(0, calibration__surface_height_mm=1e6),
     r"surface_height_mm: must be at most 10 mm"),
])
def test_manifest(w, case, edit, pattern):
    edit(w)
    code, out = w.check()
    _expect(w, case, "error", code, out, pattern)
    code, out = w.analyze()  # analyze refuses the same manifest: nothing is run
    assert code == 2 and "error:" in out, out


def test_surface_spec_named_like_a_file_in_the_working_folder(w, monkeypatch):
    """A trial's surface 'bump:W=3,H=0.5' is a spec, even where a file of that name exists
    (the working folder is no part of the study)."""
    monkeypatch.chdir(w.s.outside)
    w.entry(0, surface="bump:W=3,H=0.5", calibration__surface_height_mm=0.5)
    w.entry(1, surface="bump:W=3,H=0.5", calibration__surface_height_mm=0.5)
    code, out = w.check()
    _expect(w, "surface-spec-named-like-a-file", "handled", code, out, "2 trials, no problem found")


def test_a_300_character_id_is_that_trials_error(w):
    w.entry(1, id="x" * 300)
    code, out = w.check()
    assert code == 2 and "longer than 128 characters" in out, out
    code, out = w.analyze()
    _expect(w, "id-300-characters", "flagged", code, out,
            r"0 computed, 1 already done, 1 failed of 2 trials")
    run = ResultsStore(w.results).read_run()
    assert "longer than 128" in run["invalid_entries"][0]["reason"]


# --------------------------------------------------------------------------------------
# options out of bounds, finger files
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("case,args,pattern", [
    ("fit-mu-step-1e-9", ["fit", "{results}", "--mu-step", "1e-9"], r"--mu-step must be in \[0.0001, 1\]"),
    ("predict-step-1e-7", ["predict", "--surface", "bump-2mm", "--subject", "1", "--step", "1e-7", "--out",
                           "{tmp}/p"], r"--step must be in \[0.001, 1\] mm"),
    ("analyze-workers-100000", ["analyze", "{study}", "--out", "{results}", "--workers", "100000"],
     r"--workers must be in \[1, 256\]"),
    ("report-sample-negative", ["report", "{results}", "--sample", "-1"], r"--sample must be in"),
    ("overlay-scale-1e9", ["overlay", "{study}", T1, "--out", "{tmp}/o.mp4", "--scale", "1e9"],
     r"--scale must be"),
    ("render-rate-1e12", ["render", "--surface", "bump-2mm", "--subject", "1", "--out", "{tmp}/c.wav",
                          "--rate", "1e12"], r"--rate must be in"),
    ("simulate-reps-1e6", ["simulate", "--out", "{tmp}/sim", "--reps", "1000000"], r"--reps must be in"),
    ("fit-seed-negative", ["fit", "{results}", "--seed", "-5"], r"--seed must be in"),
    ("simulate-speed-0.0001", ["simulate", "--out", "{tmp}/sim", "--speeds", "0.0001"],
     r"--speeds must be in \[1, 1000\] mm/s"),
    ("window-nan", ["analyze", "{study}", "--out", "{results}", "--window-mm", "nan"],
     r"--window-mm must be in"),
    ("predict-surface-1e9", ["predict", "--surface", "bump:W=1e9,H=1e9", "--subject", "1", "--out",
                             "{tmp}/p"],
     r"outside the physical range"),
    ("out-inside-the-study", ["analyze", "{study}", "--out", "{study}/results"],
     r"is inside the study folder"),
])
def test_option(w, tmp_path, case, args, pattern):
    args = [a.format(results=w.results, study=w.study, tmp=tmp_path) for a in args]
    code, out = w.run(*args)
    _expect(w, case, "error", code, out, pattern)


@pytest.mark.parametrize("case,finger,pattern", [
    ("finger-wooden-leg", {"radius": 8, "modulus": 0.1, "width": 10, "model": "wooden-leg"},
     r"model 'wooden-leg' is not a known finger model"),
    ("finger-radius-1e6", {"radius": 1e6, "modulus": 0.1, "width": 10}, r"radius = 1e\+06 mm is outside"),
    ("finger-steel", {"radius": 8, "modulus": 2e5, "width": 10}, r"modulus = 200000 MPa is outside"),
    ("finger-nested", "[" * 100_000 + "]" * 100_000, r"nested too deeply"),
])
def test_finger_file(w, tmp_path, case, finger, pattern):
    p = tmp_path / "finger.json"
    p.write_text(finger if isinstance(finger, str) else json.dumps(finger))
    code, out = w.run("predict", "--surface", "bump-2mm", "--subject", "1", "--finger", p,
                      "--out", tmp_path / "p")
    _expect(w, case, "error", code, out, pattern)


def test_params_file_nested(w, tmp_path):
    p = tmp_path / "params.json"
    p.write_text('{"mu": ' + "[" * 100_000 + "]" * 100_000 + "}")
    code, out = w.run("predict", "--surface", "bump-2mm", "--subject", "1", "--params", p,
                      "--out", tmp_path / "p")
    _expect(w, "params-nested", "error", code, out, r"nested too deeply")


# --------------------------------------------------------------------------------------
# nothing lost, never stale
# --------------------------------------------------------------------------------------


def _tables(w: Work, tid: str) -> dict:
    d = w.results / "trials" / tid
    return {n: (d / n).read_bytes() for n in ("frames.parquet", "forces.parquet")}


def test_missing_video_keeps_the_results(w):
    before = _tables(w, T1)
    w.file(0, "video").unlink()
    code, out = w.analyze()
    _expect(w, "video-missing", "flagged", code, out, r"1 input missing \(last results kept\)")
    assert _tables(w, T1) == before
    code, out = w.run("report", w.results, "--no-animations", "--sample", "0")
    _expect(w, "video-missing-report", "flagged", code, out, r"input-missing x1")


def test_whole_data_drive_missing(w):
    before = {t: _tables(w, t) for t in IDS}
    shutil.rmtree(w.study / "trials")
    code, out = w.analyze("--force")
    _expect(w, "drive-missing", "flagged", code, out, r"2 input missing \(last results kept\)")
    assert {t: _tables(w, t) for t in IDS} == before


def test_unreadable_force_file_keeps_the_results(w):
    before = _tables(w, T2)
    p = w.file(1, "force")
    p.unlink()
    os.mkfifo(p)  # (root reads through any permission: a FIFO is unreadable to everybody)
    code, out = w.analyze()
    _expect(w, "force-unreadable", "flagged", code, out, r"1 input missing \(last results kept\)")
    assert _tables(w, T2) == before
    assert "forces.npz: not a regular file)" in ResultsStore(w.results).status(T2)["input_missing"]["reason"]


def test_force_file_edited_in_place_same_size_and_time(w):
    p = w.file(0, "force")
    f1, f2 = _load_forces(w, 0)
    np.savez(p, F1=f1, F2=f2)  # uncompressed: an edit of the values keeps the size
    code, out = w.analyze()
    assert code == 0 and "1 computed" in out, out
    st = p.stat()
    np.savez(p, F1=f1 * 1.5, F2=f2)
    assert p.stat().st_size == st.st_size
    os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns))
    code, out = w.analyze("--dry-run")
    assert f"{T1}: compute (input changed: force)" in out, out
    code, out = w.analyze()
    _expect(w, "force-edited-in-place", "handled", code, out, r"1 computed, 1 already done, 0 failed")


def test_truncated_stored_table_is_recomputed(w):
    p = w.results / "trials" / T2 / "forces.parquet"
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    code, out = w.analyze()
    _expect(w, "forces-parquet-truncated", "handled", code, out, r"1 computed, 1 already done, 0 failed")


def test_report_after_reanalysis_without_refit(w):
    p = w.file(1, "force")
    f1, f2 = _load_forces(w, 1)
    np.savez(p, F1=f1 * 1.2, F2=f2)
    code, out = w.analyze()
    assert code == 0 and "1 computed" in out, out
    code, out = w.run("report", w.results, "--no-animations", "--sample", "0")
    _expect(w, "report-stale-fit", "flagged", code, out,
            r"The fit is out of date and left out .*1 analysed again")
    code, out = w.run("fit", w.results)
    assert code == 0, out
    code, out = w.run("report", w.results, "--no-animations", "--sample", "0")
    _expect(w, "report-after-refit", "handled", code, out, r"report: 2 trials")


def test_results_folder_of_another_study(w, tmp_path):
    other = tmp_path / "other"
    shutil.copytree(w.study, other)
    m = json.loads((other / "manifest.json").read_text())
    m["trials"] = m["trials"][:1]
    m["trials"][0]["id"] = "other-1"
    (other / "manifest.json").write_text(json.dumps(m))
    code, out = w.run("analyze", other, "--out", w.results, "--scheduler", w.s.scheduler)
    _expect(w, "another-study", "error", code, out, r"holds the results of another study")
    code, out = w.run("analyze", other, "--out", w.results, "--scheduler", w.s.scheduler, "--force")
    _expect(w, "another-study-force", "handled", code, out, r"1 computed")
    assert sorted(p.name for p in (w.results / "trials").iterdir()) == ["other-1"]
    assert not (w.results / "fit").exists()


def test_every_trial_failed_is_not_success(w):
    for i in (0, 1):
        w.file(i, "force").write_bytes(b"not an archive")
    code, out = w.analyze("--force")
    _expect(w, "all-trials-failed", "flagged", code, out, r"0 computed, 0 already done, 2 failed of 2 trials")


def test_corrupt_status_is_recomputed(w):
    (w.results / "trials" / T1 / "status.json").write_text("{garbage")
    code, out = w.analyze()
    _expect(w, "status-corrupt", "handled", code, out, r"1 computed, 1 already done, 0 failed")


def test_corrupt_run_record(w):
    (w.results / "run.json").write_text("[" * 100_000)
    code, out = w.analyze()
    _expect(w, "run-json-corrupt", "error", code, out,
            r"run.json.*--force to start this results folder again")


def test_fit_drops_a_damaged_trial_and_says_so(w):
    p = w.results / "trials" / T2 / "forces.parquet"
    p.write_bytes(p.read_bytes()[:100])
    code, out = w.run("fit", w.results)
    _expect(w, "fit-damaged-table", "flagged", code, out, r"could not be prepared for the fit|1 failed")
    code, out = w.analyze()  # and the next analyze repairs it
    _expect(w, "fit-damaged-table-analyze", "handled", code, out, r"1 computed, 1 already done, 0 failed")


# --------------------------------------------------------------------------------------
# processes: kill -9 mid-run, two runs at once, a read-only results folder
# --------------------------------------------------------------------------------------


def _analyze_process(w: Work, *extra) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    return subprocess.Popen([sys.executable, "-m", "fingerfriction.cli", "analyze", str(w.study), "--out",
                             str(w.results), "--scheduler", w.s.scheduler, *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, start_new_session=True)


def _wait_running(w: Work, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    """Until the process holds the results folder and has started its run."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        try:
            if json.loads((w.results / "run.json").read_text()).get("state") == "running":
                return
        except (OSError, ValueError):
            pass
        assert proc.poll() is None, proc.stdout.read().decode()
        time.sleep(0.01)
    raise AssertionError("the run never started")


def test_kill_9_mid_run_then_resume(w):
    proc = _analyze_process(w, "--force")
    _wait_running(w, proc)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    store = ResultsStore(w.results)
    assert store.read_run()["state"] == "running"  # cut off mid-run
    for tid in store.trial_ids():  # what says ok is whole
        st = store.status(tid)
        assert st["status"] != "ok" or _damaged(store, tid, st) is None
    code, out = w.analyze()  # the lock died with the process
    _expect(w, "kill-9-resume", "handled", code, out, r"0 failed of 2 trials")
    assert store.read_run()["state"] == "complete"


def test_two_runs_at_once_on_one_results_folder(w):
    proc = _analyze_process(w, "--force")
    _wait_running(w, proc)
    code, out = w.analyze("--force")
    first = proc.communicate(timeout=300)[0].decode()
    _expect(w, "two-runs-at-once", "error", code, out, r"is in use by `fingerfriction analyze` \(process "
                                                       rf"{proc.pid}")
    assert proc.returncode == 0 and "2 computed" in " ".join(first.split()), first


def test_read_only_results_folder(w):
    before = {p: p.read_bytes() for p in w.results.rglob("*") if p.is_file()}
    mounted = False
    if os.geteuid() == 0:  # root writes through permission bits: a read-only bind mount instead
        r = subprocess.run(["mount", "--bind", str(w.results), str(w.results)], capture_output=True)
        if r.returncode == 0:
            mounted = subprocess.run(["mount", "-o", "remount,ro,bind", str(w.results)],
                                     capture_output=True).returncode == 0
            if not mounted:
                subprocess.run(["umount", str(w.results)], check=True)
    else:
        for p in [w.results, *w.results.rglob("*")]:
            p.chmod(p.stat().st_mode & ~0o222)
    if not mounted and os.geteuid() == 0:
        pytest.fail("cannot make a read-only folder here (root, and no read-only bind mount)")
    try:
        (w.results / "probe").touch()
        writable = True
    except OSError as exc:
        writable = exc.errno not in (errno.EROFS, errno.EACCES, errno.EPERM)
    try:
        assert not writable
        code, out = w.analyze("--force")
        _expect(w, "read-only-results", "error", code, out, r"cannot be written")
        code, out = w.run("fit", w.results)
        assert code == 2 and out.count("error:") == 1, out
    finally:
        if mounted:
            subprocess.run(["umount", str(w.results)], check=True)
        else:
            for p in [w.results, *w.results.rglob("*")]:
                p.chmod(p.stat().st_mode | 0o200)
    assert {p: p.read_bytes() for p in w.results.rglob("*") if p.is_file() and p.name != ".lock"} == \
        {p: d for p, d in before.items() if p.name != ".lock"}


def test_the_script_has_at_least_40_cases(request):
    """The cases collected (each test above checks its own outcome; with pytest-xdist they
    run on several workers, each with its own session study), and all three outcomes."""
    here = [i for i in request.session.items if i.path == request.path and i.name != request.node.name]
    assert len(here) >= 40, len(here)
    source = request.path.read_text()
    assert all(f'"{kind}", code, out' in source for kind in ("error", "flagged", "handled"))
