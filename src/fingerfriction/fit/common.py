"""What both model variants share: the trial container, the objectives, the flat segment,
the paper's detrend and median filter, and the flags a fit raises."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from .._check import check_option
from ..flags import Flag
from ..regions import as_regions
from ..surfaces import RaisedCosine, Surface, surface_from_spec

__all__ = [
    "nmse",
    "nmse_eq5",
    "Trial",
    "FitFlag",
    "fit_flag",
    "flat_segment_mask",
    "flat_detrend",
    "median_filter",
]


# ------------------------------------------------------------------------ objectives


def _pair(measured, estimate) -> tuple[np.ndarray, np.ndarray]:
    f = np.asarray(measured, dtype=float)
    g = np.asarray(estimate, dtype=float)
    if f.ndim != 1 or g.ndim != 1:
        raise ValueError(f"measured and estimate must be 1-D, got shapes {f.shape} and {g.shape}")
    if f.shape != g.shape:
        raise ValueError(
            f"measured and estimate must have the same length, got {f.size} and {g.size}"
        )
    for name, v in (("measured", f), ("estimate", g)):
        if not np.all(np.isfinite(v)):
            i = int(np.flatnonzero(~np.isfinite(v))[0])
            raise ValueError(f"{name} has a non-finite value {float(v[i])!r} at index {i}")
    return f, g


def nmse(measured, estimate) -> float:
    """Conventional normalised mean square error (the default fit objective).

    ``||F_hat - F||^2 / ||F - mean(F)||^2``: the residual energy relative to the
    measurement's variance (0 = perfect, 1 = no better than the measurement's mean).

    Parameters
    ----------
    measured : (n,) array_like
        Measured force ``F_T`` in N.
    estimate : (n,) array_like
        Model estimate ``F_hat_T`` in N.

    Returns
    -------
    float
        Dimensionless; ``inf`` if the measurement is constant.

    Notes
    -----
    Why this is the default rather than :func:`nmse_eq5`: the denominator does not depend
    on the parameters, so minimising it is ordinary least squares (consistent, closed form,
    unbiased under additive noise) and every trial is normalised by its own measurement.
    Eq. (5) divides by the *model's* variance instead, which rewards inflating the model
    (see :func:`nmse_eq5`).
    """
    f, g = _pair(measured, estimate)
    den = float(np.sum((f - f.mean()) ** 2))
    num = float(np.sum((g - f) ** 2))
    return num / den if den > 0 else math.inf


def nmse_eq5(measured, estimate) -> float:
    """NMSE exactly as Eq. (5) of Janko et al. 2018 is printed.

    ``eps = ||F_hat - F|| / ||F_hat - mean(F_hat)||``: a ratio of (unsquared) Euclidean
    norms, normalised by the spread of the *model estimate*.

    Parameters
    ----------
    measured : (n,) array_like
        Measured force ``F_T`` in N.
    estimate : (n,) array_like
        Model estimate ``F_hat_T`` in N.

    Returns
    -------
    float
        Dimensionless; ``inf`` when the estimate is constant (denominator 0).

    Notes
    -----
    The squared form ``eps^2 = ||F_hat - F||^2 / ||F_hat - mean(F_hat)||^2`` has the same
    minimiser (``sqrt`` is monotonic), so fits with either agree; only reported values
    differ. Because the denominator is the model's own variance, the minimiser is biased
    towards a *larger* model: for a model ``c G`` with a free scale ``c`` and centred
    signals, Eq. (5) is minimised at ``c = ||F||^2 / <G, F>`` whereas least squares gives
    ``c = <G, F> / ||G||^2``; their ratio is ``1 / r^2`` (``r`` the correlation of ``G``
    and ``F``), so noise in ``F`` inflates Eq. (5)'s parameters (``tests/fit/test_fit.py``
    checks it; its size: ``docs/fit.md``). It is undefined (``inf``) for a flat model, e.g.
    a trial whose contact never reaches the feature after detrending.
    """
    f, g = _pair(measured, estimate)
    den = float(np.sqrt(np.sum((g - g.mean()) ** 2)))
    num = float(np.sqrt(np.sum((g - f) ** 2)))
    return num / den if den > 0 else math.inf


# ------------------------------------------------------------------------ trial container


_SHAPE_LABELS = {"bump": "Bump", "step-up": "Step Up", "step-down": "Step Down"}


def _surface_labels(surface: Surface) -> tuple[str, str]:
    if isinstance(surface, RaisedCosine):
        return _SHAPE_LABELS[surface.shape], f"{surface.width:g} mm"
    return surface.name, ""


def fit_labels(trial: Trial) -> dict:
    """Labels carried by a TrialFit: the trial's, plus surface, shape and scale."""
    return {**trial.labels, "surface": trial.surface.name, "shape": trial.shape, "scale": trial.scale}


@dataclass(frozen=True, eq=False)
class Trial:
    """One trial on the position grid (the input of every fit).

    Parameters
    ----------
    x : (n,) ndarray
        Finger positions in mm, strictly increasing (paper: 0.01 mm steps over 26 mm).
    force : (n,) ndarray
        Measured tangential force ``F_T`` in N at each position, drift-corrected.
    regions : (n, n_max, 2) ndarray
        Contact regions ``C_i`` in mm at each position (:mod:`fingerfriction.regions`).
    surface : Surface or str
        The relief (a name such as ``'bump-2mm'``, a spec, or a Surface).
    subject : str
        Subject label (``mu`` is fitted per subject).
    labels : dict of str to str
        Further condition labels (speed, repetition, ...).
    force_abs : (n,) ndarray, optional
        Tangential force ``F_T`` in N on the absolute footing (drift removed on the
        unloaded rests only, flat-ground level ``mu F_N`` kept): what the load-consistent
        model is fitted to. None when the trial has no absolute level.
    normal_abs : (n,) ndarray, optional
        Normal force ``F_N`` in N on the absolute footing; given together with
        ``force_abs``.
    clipped : (n,) bool ndarray, optional
        Positions whose contact the camera's field cut (a region ends at the edge of the
        frame, ``frames.parquet`` ``clipped``): the regions there are shorter than the
        contact that makes the force. None: none known.
    translated : (n,) bool ndarray, optional
        Positions whose regions were translated from the nearest tracked frame (x(t)
        extrapolated there; :func:`~fingerfriction.regions.regions_on_grid`). None: none
        known.

    Raises
    ------
    ValueError
        NaN/inf forces, mismatched lengths, non-increasing positions, invalid regions
        (inverted, half-NaN, ...), a trial with no contact at all, an unknown surface,
        only one of ``force_abs`` and ``normal_abs``.
    """

    x: np.ndarray
    force: np.ndarray
    regions: np.ndarray
    surface: Surface
    subject: str = "S1"
    labels: Mapping[str, str] = field(default_factory=dict)
    force_abs: np.ndarray | None = None
    normal_abs: np.ndarray | None = None
    clipped: np.ndarray | None = None
    translated: np.ndarray | None = None

    def __post_init__(self) -> None:
        x = np.asarray(self.x, dtype=float)
        f = np.asarray(self.force, dtype=float)
        if x.ndim != 1 or x.size < 3:
            raise ValueError(f"Trial.x must be a 1-D array of >= 3 positions (mm), got shape {x.shape}")
        if not np.all(np.isfinite(x)):
            i = int(np.flatnonzero(~np.isfinite(x))[0])
            raise ValueError(f"Trial.x has a non-finite value {float(x[i])!r} at index {i}")
        if np.any(np.diff(x) <= 0):
            i = int(np.flatnonzero(np.diff(x) <= 0)[0])
            raise ValueError(
                f"Trial.x must be strictly increasing; x[{i}]={float(x[i])!r} is followed by "
                f"x[{i + 1}]={float(x[i + 1])!r}"
            )
        if f.shape != x.shape:
            raise ValueError(
                f"Trial.force must have one value per position: got shape {f.shape} for {x.size} positions"
            )
        if not np.all(np.isfinite(f)):
            i = int(np.flatnonzero(~np.isfinite(f))[0])
            raise ValueError(
                f"Trial.force has a non-finite value {float(f[i])!r} at index {i} (x={x[i]:g} mm); "
                "interpolate or drop such samples before fitting"
            )
        r = as_regions(self.regions, name="Trial.regions")
        if r.shape[0] != x.size:
            raise ValueError(
                f"Trial.regions must have one frame per position: got {r.shape[0]} frames "
                f"for {x.size} positions"
            )
        if not np.any(~np.isnan(r[..., 0])):
            raise ValueError("Trial.regions is empty: no frame has any contact region")
        surf = surface_from_spec(self.surface)
        if not isinstance(self.subject, str) or not self.subject:
            raise ValueError(f"Trial.subject must be a non-empty string, got {self.subject!r}")
        if (self.force_abs is None) != (self.normal_abs is None):
            raise ValueError("Trial.force_abs and Trial.normal_abs go together: give both or neither")
        for name in ("force_abs", "normal_abs"):
            v = getattr(self, name)
            if v is None:
                continue
            v = np.asarray(v, dtype=float)
            if v.shape != x.shape:
                raise ValueError(
                    f"Trial.{name} must have one value per position: got shape {v.shape} "
                    f"for {x.size} positions"
                )
            if not np.all(np.isfinite(v)):
                i = int(np.flatnonzero(~np.isfinite(v))[0])
                raise ValueError(
                    f"Trial.{name} has a non-finite value {float(v[i])!r} at index {i} (x={x[i]:g} mm)"
                )
            object.__setattr__(self, name, v)
        for name in ("clipped", "translated"):
            if getattr(self, name) is None:
                continue
            c = np.asarray(getattr(self, name))
            if c.shape != x.shape or c.dtype != bool:
                raise ValueError(f"Trial.{name} must be a bool array with one value per position, got "
                                 f"dtype {c.dtype} and shape {c.shape} for {x.size} positions")
            object.__setattr__(self, name, c)
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "force", f)
        object.__setattr__(self, "regions", r)
        object.__setattr__(self, "surface", surf)
        object.__setattr__(self, "labels", {str(k): str(v) for k, v in dict(self.labels).items()})

    @property
    def n(self) -> int:
        """Number of positions."""
        return int(self.x.size)

    @property
    def has_absolute(self) -> bool:
        """True when the trial carries forces on the absolute footing."""
        return self.force_abs is not None

    @property
    def id(self) -> str:
        """The trial's id (``labels['trial']``), or '' when it has none."""
        return str(self.labels.get("trial", ""))

    @property
    def shape(self) -> str:
        """Feature shape as in Table 1 ('Bump', 'Step Up', 'Step Down') or the profile's name."""
        return _surface_labels(self.surface)[0]

    @property
    def scale(self) -> str:
        """Feature width as a label, e.g. ``'2 mm'`` ('' for sampled profiles)."""
        return _surface_labels(self.surface)[1]


def by_subject(trials) -> dict[str, list[Trial]]:
    """The trials grouped by subject (in their order); raises for an empty sequence or an
    item that is not a :class:`Trial`."""
    trials = list(trials)
    if not trials:
        raise ValueError("trials is empty")
    by: dict[str, list[Trial]] = {}
    for i, t in enumerate(trials):
        if not isinstance(t, Trial):
            raise TypeError(f"trials[{i}] must be a Trial, got {type(t).__name__}")
        by.setdefault(t.subject, []).append(t)
    return by


def one_subject(trials, *, caller: str, purpose: str, group: str) -> tuple[list[Trial], str]:
    """The trials of one subject as a list, and that subject; the messages name the fitting
    function (``caller``), what it fits (``purpose``) and its every-subject form (``group``)."""
    trials = list(trials)
    if not trials:
        raise ValueError(f"trials is empty: need at least one Trial to {purpose}")
    for i, t in enumerate(trials):
        if not isinstance(t, Trial):
            raise TypeError(f"trials[{i}] must be a Trial, got {type(t).__name__}")
    subjects = sorted({t.subject for t in trials})
    if len(subjects) != 1:
        raise ValueError(f"{caller} needs trials of one subject, got subjects {subjects}; use {group}")
    return trials, subjects[0]


# ------------------------------------------------------------------------ preprocessing


def flat_segment_mask(regions, surface: Surface, *, margin: float = 0.0) -> np.ndarray:
    """Positions where the finger touches only the flat ground before the feature.

    Parameters
    ----------
    regions : (n, n_max, 2) array_like
        Contact regions in mm.
    surface : Surface
        The relief; its ``feature_extent[0]`` is where the feature starts (mm).
    margin : float
        Extra clearance in mm: every region must end at or before
        ``feature_start - margin``.

    Returns
    -------
    (n,) bool ndarray
        True where the frame has contact and every region lies left of the feature.
    """
    r = as_regions(regions)
    if not (math.isfinite(margin) and margin >= 0):
        raise ValueError(f"margin must be >= 0 mm, got {margin!r}")
    start = float(surface.feature_extent[0]) - float(margin)
    valid = ~np.isnan(r[..., 0])
    right = np.where(valid, r[..., 1], -np.inf).max(axis=1)
    return valid.any(axis=1) & (right <= start)


def flat_detrend(x, y, mask) -> np.ndarray:
    """Subtract the best line (least squares over ``x[mask]``) from ``y`` everywhere.

    This is the paper's drift correction ("Force data processing"); it is linear in
    ``y``. ``y`` may be ``(n,)`` or ``(n, m)`` (each column detrended).

    Raises
    ------
    ValueError
        If fewer than 2 distinct positions are selected by ``mask``.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    m = np.asarray(mask, dtype=bool)
    if m.shape != x.shape or y.shape[0] != x.size:
        raise ValueError(f"x {x.shape}, y {y.shape} and mask {m.shape} must have matching length")
    if np.count_nonzero(m) < 2:
        raise ValueError(
            f"the flat segment has {int(np.count_nonzero(m))} positions; at least 2 are needed "
            "for the linear detrend (does the contact start on flat ground before the feature?)"
        )
    A = np.column_stack([np.ones(int(m.sum())), x[m] - x[m].mean()])
    coef, *_ = np.linalg.lstsq(A, y[m], rcond=None)
    full = np.column_stack([np.ones(x.size), x - x[m].mean()])
    return y - full @ coef


def median_filter(y, kernel: int) -> np.ndarray:
    """Running median along axis 0 with an odd window of ``kernel`` samples.

    Uses ``scipy.ndimage.median_filter`` with ``mode='nearest'`` (ends padded with the end
    values, so the ends are not pulled towards zero as with ``scipy.signal.medfilt``'s
    zero padding). ``kernel=1`` returns a copy.
    """
    k = check_kernel(kernel)
    y = np.asarray(y, dtype=float)
    if k == 1:
        return y.copy()
    size = (k,) + (1,) * (y.ndim - 1)
    return ndimage.median_filter(y, size=size, mode="nearest")


def check_kernel(kernel) -> int:
    """The median filter's kernel as an int, checked odd and positive (samples); raises otherwise."""
    if isinstance(kernel, bool) or not isinstance(kernel, (int, np.integer)) or kernel < 1 or kernel % 2 == 0:
        raise ValueError(f"median kernel must be an odd positive integer (samples), got {kernel!r}")
    return int(kernel)


# ------------------------------------------------------------------------ flags


#: Levels of a fit's flags: ``'error'`` (the result must not be used: a failed or
#: unphysical fit), ``'warning'`` (usable, with a caveat) and ``'info'`` (what the fit did
#: that a reader should know, e.g. a parameter held at its physical limit).
FLAG_LEVELS = ("error", "warning", "info")

#: The fit's flags are the package's one flag type (:class:`fingerfriction.flags.Flag`).
FitFlag = Flag


def fit_flag(level: str, code: str, subject, trial: str, model: str, message: str) -> Flag:
    """A :class:`~fingerfriction.flags.Flag` raised by a fit, about a trial (``trial`` its
    id) or a whole subject (``trial=''``), for the model variant ``model``."""
    check_option("a fit's flag level", level, FLAG_LEVELS)
    return Flag(level, code, message, trial=trial, subject=str(subject), model=model)
