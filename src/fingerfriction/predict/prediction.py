"""Predict friction on any relief: the forward model's contact regions along a sweep into
Eq. (4) of Janko et al. 2018 (:func:`predict`), with the contact occupancy and the tactile
blind spots (:class:`Prediction`, written as CSV, JSON and PNG files).
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field

import numpy as np
import pandas as pd

from .._atomic import atomic_write
from .._style import figure_style
from ..fit.variants import variant_of_params
from ..mechanics import FingerParams
from ..mechanics.fe import FEFingerParams
from ..model import FrictionModel, FrictionParams, LoadParams
from ..model.blindspots import BlindSpots, Occupancy, blind_spots, occupancy
from ..regions import as_regions, n_regions, region_lengths
from ..surfaces import SURFACE_NAMES, Surface, surface_from_spec
from .defaults import resolve_params
from .forward import (
    DEFAULT_LOAD_N,
    FORWARD_STEP_MM,
    GEOM_TOL_MM,
    MAX_SLOPE_ANGLE,
    check_profile,
    forward_regions,
    resolve_finger,
    sweep_window,
)

__all__ = ["Prediction", "predict", "predict_from_regions", "known_surface_names"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Prediction:
    """A predicted sweep of a finger over a relief.

    Attributes
    ----------
    surface : Surface
    subject : int or str
        Subject label.
    params : LoadParams or FrictionParams
        Eq. (4) parameters used: the load-consistent model's (``LoadParams``, the pressure
        from the normal force ``load``) or the paper's (``FrictionParams``, a constant
        ``p0``).
    params_source : str
        Where they came from.
    load : float
        Normal force in N.
    contact : str
        'geometric' (70 um, default) or 'mechanical'.
    positions : (n,) ndarray
        Finger-centre positions in mm.
    regions : (n, n_max, 2) ndarray
        Contact regions in mm at each position.
    F_T, F_int, F_def : (n,) ndarray
        Eq. (4), (2), (3) in N.
    occupancy : Occupancy
        Contact occupancy over the sweep (Fig. 3).
    blind_spots : BlindSpots
        Never-contacted intervals.
    """

    surface: Surface
    subject: object
    params: LoadParams | FrictionParams
    params_source: str
    load: float
    contact: str
    positions: np.ndarray
    regions: np.ndarray
    F_T: np.ndarray
    F_int: np.ndarray
    F_def: np.ndarray
    occupancy: Occupancy = field(repr=False)
    blind_spots: BlindSpots = field(repr=False)
    finger: object = field(default=None, repr=False)

    @property
    def model(self) -> str:
        """The model variant of the parameters (:func:`fingerfriction.fit.variants.variant_of_params`:
        ``'load'``, ``'interlock'`` or, for a constant pressure, ``'paper'``)."""
        return variant_of_params(self.params).name

    @property
    def params_text(self) -> str:
        """The parameters in one line with their units."""
        p = self.params
        if isinstance(p, LoadParams):
            push = f", slope push {p.push_up:.3g} up, {p.push_down:.3g} down" if p.split_push else ""
            return (f"mu={p.mu:.3g}, p1={p.p1:.3g} N/mm{push}, inset={p.inset:.3g} mm, "
                    f"kappa={p.kappa:.3g}/mm "
                    f"(load-consistent, F_N={self.load:g} N)")
        return f"mu={p.mu:.3g}, p0={p.p0:.3g} N/mm, p1={p.p1:.3g} N/mm (paper's Eq. 4)"

    def display_p0(self, normal_force: float, flat_length: float) -> float:
        """The ``p0`` (N/mm) of a flat friction display for this prediction: the paper's
        constant pressure, or for the load-consistent model the pressure that carries
        ``normal_force`` on the finger's flat contact ``flat_length`` (mm), so that the
        display's lateral force per unit command is the normal force (Amontons)."""
        if isinstance(self.params, LoadParams):
            return float(normal_force) / float(flat_length)
        return self.params.p0

    @property
    def max_contacts(self) -> int:
        """Largest number of simultaneous contact regions over the sweep."""
        return int(n_regions(self.regions).max(initial=0))

    @property
    def flat_level(self) -> float:
        """F_T (N) at the first position (finger on flat ground before the feature)."""
        return float(self.F_T[0])

    def summary(self) -> dict:
        """JSON-serialisable summary: parameters, blind spots, force extremes."""
        return {
            "surface": self.surface.name,
            "surface_spec": _surface_dict(self.surface),
            "subject": str(self.subject),
            "model": self.model,
            "params": {k: v for k, v in asdict(self.params).items() if v is not None},
            "params_source": self.params_source,
            "load_N": self.load,
            "contact": self.contact,
            "geom_tol_mm": GEOM_TOL_MM if self.contact == "geometric" else None,
            "n_positions": int(self.positions.size),
            "step_mm": float(np.median(np.diff(self.positions))) if self.positions.size > 1 else None,
            "max_slope_angle_rad": self.surface.max_slope_angle(),
            "max_contacts": self.max_contacts,
            "blind_spots": self.blind_spots.as_table(),
            "F_T_flat_N": self.flat_level,
            "F_T_max_N": float(np.max(self.F_T)),
            "F_T_min_N": float(np.min(self.F_T)),
        }

    def table(self):
        """Per-position table (pandas DataFrame): x_mm, F_T_N, F_int_N, F_def_N, n_contacts,
        contact_length_mm."""
        return pd.DataFrame(
            {
                "x_mm": self.positions,
                "F_T_N": self.F_T,
                "F_int_N": self.F_int,
                "F_def_N": self.F_def,
                "n_contacts": n_regions(self.regions),
                "contact_length_mm": np.nansum(region_lengths(self.regions), axis=1),
            }
        )

    def write(self, out_dir: str | os.PathLike, *, figures: bool = True) -> dict[str, str]:
        """Write CSV tables, a JSON summary and (optionally) PNG figures into ``out_dir``.

        Files: ``forces.csv`` (per position), ``regions.csv`` (one row per region:
        x_mm, a_mm, b_mm), ``occupancy.csv`` (bin centre, fraction, normalised),
        ``blind_spots.csv``, ``prediction.json``; figures ``forces.png``,
        ``occupancy.png``. Every write is atomic.

        Returns
        -------
        dict
            File kind -> path.
        """
        out = os.fspath(out_dir)
        os.makedirs(out, exist_ok=True)
        paths: dict[str, str] = {}

        def put(kind: str, name: str, writer: Callable[[str], None]) -> None:
            p = os.path.join(out, name)
            atomic_write(p, writer)
            paths[kind] = p

        put("forces", "forces.csv", lambda tmp: self.table().to_csv(tmp, index=False, float_format="%.9g"))
        valid = ~np.isnan(self.regions[..., 0])
        t_idx, _ = np.nonzero(valid)
        reg = pd.DataFrame(
            {
                "x_mm": self.positions[t_idx],
                "a_mm": self.regions[..., 0][valid],
                "b_mm": self.regions[..., 1][valid],
            }
        )
        put("regions", "regions.csv", lambda tmp: reg.to_csv(tmp, index=False, float_format="%.6f"))
        occ = pd.DataFrame(
            {
                "x_mm": self.occupancy.centers,
                "fraction": self.occupancy.fraction,
                "normalized": self.occupancy.normalized,
            }
        )
        put("occupancy", "occupancy.csv", lambda tmp: occ.to_csv(tmp, index=False, float_format="%.6g"))
        bs = pd.DataFrame(self.blind_spots.as_table(), columns=["start_mm", "end_mm", "width_mm"])
        put("blind_spots", "blind_spots.csv", lambda tmp: bs.to_csv(tmp, index=False, float_format="%.4f"))

        def wjson(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8") as fh:
                json.dump(self.summary(), fh, indent=2)

        put("summary", "prediction.json", wjson)
        if figures:
            put("forces_png", "forces.png", self._plot_forces)
            put("occupancy_png", "occupancy.png", self._plot_occupancy)
        return paths

    @figure_style()
    def _plot_forces(self, path: str) -> None:
        import matplotlib  # heavy, and only needed for the figures

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt  # heavy, and only needed for the figures

        fig, (ax0, ax1) = plt.subplots(2, 1, figsize=(7, 5), sharex=True, height_ratios=[3, 1])
        x = self.positions
        ax0.plot(x, 1e3 * self.F_T, "k", lw=1.5, label="$F_T$ (Eq. 4)")
        ax0.plot(x, 1e3 * self.F_int, "C0", lw=1, label="$F_{int}$ (Eq. 2)")
        ax0.plot(x, 1e3 * self.F_def, "C3", lw=1, label="$F_{def}$ (Eq. 3)")
        ax0.set_ylabel("force (mN)")
        ax0.legend(loc="upper right", fontsize=8)
        ax0.set_title(f"{self.surface.name}, subject {self.subject}: {self.params_text}", fontsize=9)
        xs = np.linspace(x[0], x[-1], 2000)
        ax1.fill_between(xs, 0, self.surface.h(xs), color="0.6")
        for a, b in self.blind_spots.intervals:
            ax1.axvspan(a, b, color="k", alpha=0.8, lw=0)
        ax1.set_xlabel("finger position x (mm)  /  surface position (mm)")
        ax1.set_ylabel("h (mm)")
        fig.tight_layout()
        fig.savefig(path, format="png", dpi=120)
        plt.close(fig)

    @figure_style()
    def _plot_occupancy(self, path: str) -> None:
        import matplotlib  # heavy, and only needed for the figures

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt  # heavy, and only needed for the figures

        occ = self.occupancy
        fig, ax = plt.subplots(figsize=(7, 2.8))
        xs = occ.centers
        h = self.surface.h(xs)
        ax.fill_between(xs, h.min() - 0.2, h, color="0.85")
        sc = ax.scatter(xs, h, c=occ.normalized, cmap="gray", s=4, vmin=0, vmax=1)
        for a, b in self.blind_spots.intervals:
            ax.axvspan(a, b, color="r", alpha=0.15, lw=0)
        fig.colorbar(sc, ax=ax, label="normalised contact time")
        ax.set_xlabel("surface position (mm)")
        ax.set_ylabel("h (mm)")
        widths = ", ".join(f"{w:.2f}" for w in self.blind_spots.widths) or "none"
        ax.set_title(f"{self.surface.name}, subject {self.subject}: blind spots (mm): {widths}", fontsize=9)
        fig.tight_layout()
        fig.savefig(path, format="png", dpi=120)
        plt.close(fig)


def _surface_dict(surface: Surface):
    to_dict = getattr(surface, "to_dict", None)
    return to_dict() if callable(to_dict) else {"name": surface.name}


def predict_from_regions(surface: Surface, positions, regions, params: FrictionParams, *,
                         subject="?", params_source: str = "given", load: float = DEFAULT_LOAD_N,
                         contact: str = "geometric", finger=None) -> Prediction:
    """Eq. (4) and the blind spots for given contact regions along a sweep.

    Parameters
    ----------
    surface : Surface
    positions : (n,) array_like
        Finger positions in mm.
    regions : (n, n_max, 2) array_like
        Contact regions in mm at each position.
    params : LoadParams or FrictionParams
        The load-consistent model's (the pressure from ``load``) or the paper's.
    load : float
        Normal force in N (the load-consistent model's pressure carries it).
    """
    if not isinstance(params, (LoadParams, FrictionParams)):
        raise TypeError(f"params must be LoadParams or FrictionParams, got {type(params).__name__}")
    x = np.asarray(positions, dtype=float)
    reg = as_regions(regions)
    if x.ndim != 1 or x.size != reg.shape[0]:
        raise ValueError(
            f"positions must be 1-D with one entry per frame of regions; got {x.shape} "
            f"and {reg.shape[0]} frames"
        )
    if not np.all(np.isfinite(x)):
        raise ValueError("positions must be finite (mm)")
    if isinstance(params, LoadParams):  # the pressure carries the normal force ``load``
        f = FrictionModel(surface).load_forces(reg, float(load), params)
    else:
        f = FrictionModel(surface).forces(reg, params)
    occ = occupancy(reg)
    bs = blind_spots(reg)
    return Prediction(
        surface=surface, subject=subject, params=params, params_source=params_source, load=float(load),
        contact=contact, positions=x, regions=reg, F_T=f.total, F_int=f.interfacial, F_def=f.deformation,
        occupancy=occ, blind_spots=bs, finger=finger,
    )


def predict(surface_spec, subject, params=None, *, load: float = DEFAULT_LOAD_N,
            step: float = FORWARD_STEP_MM, contact: str = "geometric", window: Sequence[float] | None = None,
            max_slope_angle: float = MAX_SLOPE_ANGLE, model: str | None = None,
            finger=None) -> Prediction:
    """Predict F_T(x), F_int, F_def, occupancy and blind spots on any relief.

    The forward contact model (:mod:`fingerfriction.mechanics`) is swept over the surface
    at ``step`` mm; its contact regions (geometric, 70 um, by default: ``docs/predict.md``)
    go into Eq. (4) of Janko et al. 2018 with ``params``.

    Parameters
    ----------
    surface_spec : str, path or Surface
        A paper surface name (``'bump-4mm'``), a parametric spec (``'bump:W=3,H=0.5'``),
        a CSV profile of x, h in mm, or a Surface (:func:`surface_from_spec`).
    subject : int or FingerParams
        Subject 1 or 2 (the calibrated fingers of :mod:`fingerfriction.mechanics`), or a
        custom finger (then ``params`` is required).
    params : None, LoadParams, FrictionParams or path, optional
        Eq. (4) parameters; ``None`` uses :func:`default_params`; a path is read by
        :func:`load_params` (a fit's results: its default model, or ``model``).
    model : {'load', 'paper'}, optional
        The model variant when ``params`` is None (default ``'load'``, the load-consistent
        Eq. 4 with the pressure from ``load``) or a fit's results folder.
    load : float, optional
        Normal force in N (default 0.3, the paper's).
    step : float, optional
        Finger step in mm (default 0.01, the paper's spatial resolution).
    contact : {'geometric', 'mechanical'}, optional
    window : (float, float), optional
        First and last finger positions in mm (default :func:`sweep_window`).
    max_slope_angle : float, optional
        Slope limit in rad (:func:`check_profile`).
    finger : FingerParams or FEFingerParams, optional
        The subject's own finger (``calibrate-finger``'s, read with
        :func:`fingerfriction.mechanics.finger_file.read_finger_file`) instead of its
        default one; default parameters then keep the subject's paper ``mu``. An FE finger
        (the layered finite-element finger, with its own sliding friction) is solved every
        :data:`~fingerfriction.predict.forward.FE_FORWARD_STEP` mm through its disk cache
        (``docs/mechanics-fe.md``).

    Returns
    -------
    Prediction

    Raises
    ------
    ValueError
        Unknown surface, malformed CSV, unknown subject, bad parameters file;
        :class:`ProfileTooSteepError` for a relief beyond the slope limit.
    RuntimeError
        If the contact solver fails at some position.
    """
    surface = surface_from_spec(surface_spec)
    check_profile(surface, max_slope_angle=max_slope_angle)
    if not (isinstance(step, (int, float)) and math.isfinite(step) and 1e-3 <= step <= 1.0):
        # 1 um: below it the sweep's positions (and memory) grow without physical gain
        raise ValueError(f"step must be a finger step in mm in [0.001, 1], got {step!r}")
    if not (isinstance(load, (int, float)) and math.isfinite(load) and load > 0):
        raise ValueError(f"load must be a positive normal force in N, got {load!r}")
    label, default_finger = resolve_finger(subject)
    if finger is None:
        finger = default_finger
    elif not isinstance(finger, (FingerParams, FEFingerParams)):
        raise TypeError(f"finger must be a FingerParams or an FEFingerParams, got {type(finger).__name__}")
    p, source = resolve_params(params, label, float(load), model, finger=finger)
    lo, hi = sweep_window(surface) if window is None else (float(window[0]), float(window[1]))
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(
            f"window must be (first, last) finger positions in mm with first < last, got {window!r}"
        )
    x = lo + step * np.arange(int(math.floor((hi - lo) / step + 1e-9)) + 1)
    log.info("predict: %s, subject %s, %d positions, %s contact", surface.name, label, x.size, contact)
    reg = forward_regions(surface, finger, x, load=load, contact=contact)
    return predict_from_regions(surface, x, reg, p, subject=label, params_source=source, load=load,
                                contact=contact, finger=finger)


def known_surface_names() -> tuple[str, ...]:
    """The paper's surface names (for error messages and the CLI)."""
    return SURFACE_NAMES
