"""The per-surface figures of a finger calibration
(:func:`~fingerfriction.mechanics.calibrate.calibrate_finger`): end-point residuals, hinge
violations, and the measured and predicted blind spots paired by overlap."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._calibration_problem import CalibrationProblem, model_regions, union_blind_spots

__all__ = ["SurfaceFit", "surface_fits"]


@dataclass
class SurfaceFit:
    """Per-surface figures of a calibration.

    Attributes
    ----------
    surface : str
    n_trials, n_frames : int
    rms_end_mm : float
        Root mean square of the end-point residuals at the optimum (mm).
    median_end_mm : float
        Median absolute end-point residual (mm).
    hinge_violations : float
        Fraction of measured interiors / gaps where the model's contact disagrees.
    measured_blind_spots, predicted_blind_spots : (k, 2) ndarray
        Blind spots (mm) of the union of the measured regions, and of the calibrated
        model's regions at the same frames (positions and loads).
    """

    surface: str
    n_trials: int
    n_frames: int
    rms_end_mm: float
    median_end_mm: float
    hinge_violations: float
    measured_blind_spots: np.ndarray
    predicted_blind_spots: np.ndarray

    def blind_spot_pairs(self) -> list[tuple[float, float]]:
        """``(measured width, predicted width)`` in mm, paired by overlap (NaN: no partner)."""
        return _pair_spots(self.measured_blind_spots, self.predicted_blind_spots)

    def to_dict(self) -> dict:
        return {
            "surface": self.surface, "n_trials": self.n_trials, "n_frames": self.n_frames,
            "rms_end_mm": self.rms_end_mm, "median_end_mm": self.median_end_mm,
            "hinge_violations": self.hinge_violations,
            "measured_blind_spots_mm": self.measured_blind_spots.tolist(),
            "predicted_blind_spots_mm": self.predicted_blind_spots.tolist(),
        }


def _pair_spots(meas: np.ndarray, pred: np.ndarray) -> list[tuple[float, float]]:
    """Pair blind spots by largest overlap (else nearest centre); unpaired get NaN."""
    out = []
    used = set()
    for a, b in meas:
        best, score = None, -math.inf
        for j, (c, d) in enumerate(pred):
            if j in used:
                continue
            ov = min(b, d) - max(a, c)
            s = ov if ov > 0 else -abs(0.5 * (a + b) - 0.5 * (c + d))
            if s > score:
                best, score = j, s
        if best is not None and score > -1.0:
            used.add(best)
            out.append((float(b - a), float(pred[best][1] - pred[best][0])))
        else:
            out.append((float(b - a), math.nan))
    for j, (c, d) in enumerate(pred):
        if j not in used:
            out.append((math.nan, float(d - c)))
    return out


def surface_fits(pb: CalibrationProblem, tabs: dict, r0: np.ndarray, offset: float = 0.0) -> list[SurfaceFit]:
    """The per-surface figures of a calibration at its optimum.

    Parameters
    ----------
    pb : CalibrationProblem
        The problem (its surfaces and the fine pass's residual structure).
    tabs : dict
        Surface name -> ``(positions, Y)``: the model's sweep tables at the optimum
        (:meth:`CalibrationProblem.tables`).
    r0 : (m,) ndarray
        The fine pass's residuals at the optimum, surface after surface (end points, then
        hinges), in mm.
    offset : float
        The model finger's position offset at the optimum (mm; :meth:`CalibrationProblem.offset`).
    """
    out = []
    off = 0
    for sd in pb.surfaces:
        st = pb.structure("fine", sd)
        ne, nh = st.fe.size, st.kinds.size
        re = r0[off: off + ne]
        rh = r0[off + ne: off + ne + nh]
        off += ne + nh
        pos, Y = tabs[sd.name]
        d = pb.distances(sd, st.idx, pos, Y, offset)
        model = model_regions(d, sd.X[st.idx], sd.tol[st.idx], sd.min_gap[st.idx], sd.min_region[st.idx])
        meas = [sd.regions[i] for i in st.idx]
        out.append(SurfaceFit(
            surface=sd.name, n_trials=int(np.unique(sd.trial).size), n_frames=int(st.idx.size),
            rms_end_mm=float(np.sqrt(np.mean(re**2))) if re.size else math.nan,
            median_end_mm=float(np.median(np.abs(re))) if re.size else math.nan,
            hinge_violations=float(np.mean(rh > 0.05)) if rh.size else 0.0,
            measured_blind_spots=union_blind_spots(meas),
            predicted_blind_spots=union_blind_spots(model),
        ))
    return out
