"""A flag keeps its level from the stage that raises it, through the results store's JSON,
to the report (one :class:`fingerfriction.flags.Flag` type all the way)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from fingerfriction.fit.common import fit_flag
from fingerfriction.flags import LEVELS, Flag
from fingerfriction.forces import process_forces
from fingerfriction.pipeline.trial import force_info
from fingerfriction.report.data import ReportData
from fingerfriction.report.flags import collect_flags
from fingerfriction.selfcheck import Check
from fingerfriction.study.results import AnalysedTrial as TrialData

from .test_forces_processing import synthetic_trial

TID = "s1-bump-2mm-v080-r1"


def _report_flags(stored: list, fit_flags: list | None = None) -> list[Flag]:
    """The report's flags of one trial whose ``status.json`` holds ``stored`` as its force
    stage's flags (after a JSON round trip, as the store writes and reads them)."""
    status = json.loads(json.dumps({"ok": True, "info": {"forces": {"flags": stored}}}))
    frames = pd.DataFrame({"frame": [0, 1, 2], "t_s": [0.0, 0.001, 0.002], "x_mm": [0.0, 0.1, 0.2],
                           "flag": ["", "", ""]})
    t = TrialData(id=TID, subject="1", surface="bump-2mm", speed_mm_s=80.0, repetition=1, frames=frames,
                  regions=np.full((3, 1, 2), np.nan), forces=pd.DataFrame(), status=status)
    fit = None if fit_flags is None else json.loads(json.dumps({"flags": [f.to_dict() for f in fit_flags]}))
    data = ReportData(root=None, run={"trials": [{"id": TID, "subject": "1"}]}, surfaces={}, trials=[t],
                      failed=[], fit=fit)
    return collect_flags(data)


def test_the_force_stage_flags_reach_the_report_unchanged():
    rec, tv, xv = synthetic_trial(lift=False)
    prof = process_forces(rec, tv, xv, feature_extent_mm=(-1.0, 1.0))
    assert prof.success and [f.code for f in prof.flags] == ["no-post-baseline"]
    assert all(isinstance(f, Flag) for f in prof.flags)
    got = _report_flags(force_info(prof)["flags"])
    assert got == [f.at(trial=TID, subject="1") for f in prof.flags]


@pytest.mark.parametrize("level", LEVELS)
def test_every_level_is_kept_from_stage_to_report(level):
    raised = [Flag(level, "some-code", f"a finding at level {level}")]
    got = _report_flags([f.to_dict() for f in raised])
    want = [(level, "some-code", raised[0].message, TID)]
    assert [(f.level, f.code, f.message, f.trial) for f in got] == want


def test_consistency_and_fit_flags_keep_their_level():
    check = Check("sync-offset", "warning", 4.0, "ms", "the force clock looks 4 ms late")
    fit = [fit_flag("error", "negative-p1", "1", TID, "load", "p1 < 0"),
           fit_flag("warning", "kappa-limited", "1", "", "load", "kappa held")]
    got = _report_flags([check.to_flag().to_dict()], fit)
    by_code = {f.code: f for f in got}
    assert by_code["sync-offset"].level == "warning"
    assert by_code["negative-p1"].level == "error" and by_code["negative-p1"].model == "load"
    assert by_code["kappa-limited"].level == "warning" and by_code["kappa-limited"].trial == ""
    assert got[0].code == "negative-p1"  # most serious first


def test_results_written_before_keep_reading_as_warnings():
    got = _report_flags(["extrapolated: x(t) was extended by 1.2 mm", "no colon here"])
    assert [(f.level, f.code, f.message) for f in got] == [
        ("warning", "extrapolated", "x(t) was extended by 1.2 mm"),
        ("warning", "no colon here", "no colon here"),
    ]


def test_flag_checks_its_fields():
    with pytest.raises(ValueError, match="Flag.level must be one of error, warning, info, got 'fatal'"):
        Flag("fatal", "x", "y")
    with pytest.raises(ValueError, match="Flag.code must be a non-empty string"):
        Flag("error", "", "y")
    f = Flag("info", "regions-clipped", "cut by the edge", trial="t1")
    assert Flag.from_dict(f.to_dict()) == f and f["level"] == "info"
    assert f.line() == "regions-clipped: cut by the edge"
    with pytest.raises(ValueError, match="a flag must be a dict"):
        Flag.from_dict(3)
