"""A lab-style folder of recordings, written with the project's own writers.

:func:`simulate_source` runs the virtual experiment (``fingerfriction.sim``) on 2 subjects
x 2 surfaces x 2 repetitions at 120 mm/s, with a lab camera of 1280 x 360 pixels (the
paper's analysis crop) at 250 frames/s and coarse contact tables; :func:`write_lab_folder`
rewrites its recordings the way a lab's instruments would have left them, with lab file names and no manifest:

* videos ``raw/S<subject>_<surface>_120mms_<rep>``: ``.cine`` (Phantom) for subject 1,
  multi-page ``.tif`` (no frame rate in the file) for subject 2, through
  ``fingerfriction.video.writers.write_video``;
* forces of repetition 1 as TDMS (group ``Piezo``, channels ``ai0``, ``ai1`` and a
  ``trigger`` channel; rate in ``wf_increment``), of repetition 2 as headerless ``;``
  CSV (time in s, then the two channels), both in volts from charge amplifiers set to
  10 N/V (F1) and 20 N/V (F2);
* the step-up surface is called ``SU4`` in the file names, the bump ``bump-2mm``;
* a stray ``raw/notes.txt`` and a video without its force file.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

SENSITIVITY_N_PER_V = {"F1": 10.0, "F2": 20.0}
TOKENS = {"bump-2mm": "bump-2mm", "step-up-4mm": "SU4"}
LAB_FPS = 250.0
#: the common-clock time of frame 0 in the simulator's manifests (forces start at 0)
VIDEO_T0_S = 0.08


def simulate_source(out: Path, *, workers: int = 2) -> Path:
    from fingerfriction.sim import SimOptions, simulate_study
    from fingerfriction.sim.camera import CameraParams

    # coarse one-load contact tables (0.05 mm, 0.3 N; the default 0.02 mm at three loads is
    # two thirds of the simulation's time): what is tested is the lab's files against the
    # simulator's own, not the contact model
    simulate_study(out, SimOptions(reps=2, subjects=("1", "2"), surfaces=tuple(TOKENS), speeds=(120.0,),
                                   seed=5, camera=CameraParams(fps=LAB_FPS, height=360, y0_row=320.0),
                                   table_step=0.05, table_loads=(0.3,)),
                   workers=workers)
    return out


def lab_name(trial: dict) -> str:
    return f"S{trial['subject']}_{TOKENS[trial['surface']]}_{trial['speed_mm_s']:g}mms_{trial['repetition']}"


def write_lab_folder(source: Path, lab: Path) -> dict:
    """Rewrite the simulated study ``source`` as a lab folder ``lab``; returns
    ``{lab stem: source trial id}``."""
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    from fingerfriction.video.readers import open_video
    from fingerfriction.video.writers import write_video

    manifest = json.loads((source / "manifest.json").read_text())
    raw = lab / "raw"
    raw.mkdir(parents=True)
    names = {}
    for t in manifest["trials"]:
        assert t["video"]["t0_s"] == VIDEO_T0_S and t["force"]["t0_s"] == 0.0
        stem = lab_name(t)
        names[stem] = t["id"]
        with open_video(source / t["video"]["path"]) as r:
            frames = np.concatenate([c.copy() for _, c in r.iter_chunks(64)])
        ext = ".cine" if t["subject"] == "1" else ".tif"
        write_video(raw / (stem + ext), frames, fps=LAB_FPS)
        with np.load(source / t["force"]["path"]) as z:
            v1 = z["F1"] / SENSITIVITY_N_PER_V["F1"]
            v2 = z["F2"] / SENSITIVITY_N_PER_V["F2"]
        fs = t["force"]["fs_hz"]
        if t["repetition"] == 1:
            props = {"wf_increment": 1.0 / fs, "wf_start_offset": 0.0, "unit_string": "V"}
            with TdmsWriter(raw / (stem + ".tdms")) as w:
                w.write_segment([
                    RootObject({"operator": "lab"}), GroupObject("Piezo"),
                    ChannelObject("Piezo", "ai0", v1, properties=props),
                    ChannelObject("Piezo", "ai1", v2, properties=props),
                    ChannelObject("Piezo", "trigger", np.zeros_like(v1), properties=props),
                ])
        else:
            time = np.arange(v1.size) / fs
            rows = zip(time.tolist(), v1.tolist(), v2.tolist(), strict=True)
            (raw / (stem + ".csv")).write_text("".join(f"{a:.6f};{b!r};{c!r}\n" for a, b, c in rows))
    (raw / "notes.txt").write_text("session of 2024-05-02: two subjects, charge amplifiers 10 and 20 N/V\n")
    extra = next(s for s in names if s.startswith("S1_"))
    write_video(raw / (extra.rsplit("_", 1)[0] + "_3.cine"), frames[:5], fps=LAB_FPS)  # no force file
    return names


INIT_ARGS = [
    "--video", "raw/S{subject}_{surface}_{speed}mms_{repetition}.cine",
    "--video", "raw/S{subject}_{surface}_{speed}mms_{repetition}.tif",
    "--forces", "raw/S{subject}_{surface}_{speed}mms_{repetition}.tdms",
    "--forces", "raw/S{subject}_{surface}_{speed}mms_{repetition}.csv",
    "--surface", "SU4=step-up-4mm",
    "--channels", "tdms:Piezo/ai0,Piezo/ai1",
    "--channels", "csv:1,2", "--time", "csv:0",
    "--units", "V", "--sensitivity", "10,20",
    "--fps", "250", "--video-t0-s", "0.08",
]
