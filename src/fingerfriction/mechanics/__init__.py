"""Forward finger contact model: plane-strain BEM contact of the finger pad on a relief.

Public API
----------
:class:`FingerParams`, :data:`SUBJECTS`, :func:`get_subject` (finger.py);
:func:`solve_contact`, :class:`ContactSolver`, :class:`ContactSolution`,
:data:`GEOMETRIC_TOL` (bem.py); :func:`sweep`, :class:`SweepResult`,
:func:`default_positions`, :func:`outline_table`,
:class:`OutlineTable` (sweep.py); the Hertz reference :func:`hertz_half_width`,
:func:`hertz_pressure` (hertz.py).

Finger position convention: ``x_finger`` is the horizontal position (mm, surface
coordinates) of the finger's centre (the circle's centre, i.e. the lowest point of the
undeformed outline). Choices and measured figures: ``docs/mechanics.md``.
"""

from .bem import GEOMETRIC_TOL, ContactSolution, ContactSolver, solve_contact
from .finger import SUBJECTS, FingerParams, get_subject
from .hertz import hertz_half_width, hertz_peak_pressure, hertz_pressure
from .sweep import OutlineTable, SweepResult, default_positions, outline_table, sweep

__all__ = [
    "GEOMETRIC_TOL",
    "ContactSolution",
    "ContactSolver",
    "solve_contact",
    "FingerParams",
    "SUBJECTS",
    "get_subject",
    "hertz_half_width",
    "hertz_peak_pressure",
    "hertz_pressure",
    "SweepResult",
    "default_positions",
    "sweep",
    "OutlineTable",
    "outline_table",
]
