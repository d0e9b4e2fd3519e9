"""Deprecated: the synthetic trials (a test fixture) now live in
:mod:`fingerfriction.testing`. This module re-exports the former names for one release."""

from __future__ import annotations

import warnings

from .testing import PAPER_MU, finger_contact_regions, synthetic_trial, synthetic_trials

warnings.warn("fingerfriction.synthetic is deprecated: use fingerfriction.testing", DeprecationWarning,
              stacklevel=2)

__all__ = ["finger_contact_regions", "synthetic_trial", "synthetic_trials", "PAPER_MU"]
