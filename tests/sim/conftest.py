"""Shared fixtures of the simulator tests: tiny, fast studies."""

from __future__ import annotations

import pytest

from fingerfriction.sim import KinematicsParams, SimOptions


def tiny_options(**kw) -> SimOptions:
    """One short trial: the feature crossed over a 2 mm window, the fast contact model,
    a coarse one-load contact table."""
    d = dict(
        reps=1, subjects=("1",), surfaces=("bump-2mm",), speeds=(120.0,), seed=3,
        kinematics=KinematicsParams(window=2.0, x_start=-2.0, x_stop=1.5),
        video_end_mm=1.5, contact_model="bridged-foundation", table_step=0.05, table_loads=(0.3,),
    )
    d.update(kw)
    return SimOptions(**d)


@pytest.fixture
def tiny():
    return tiny_options
