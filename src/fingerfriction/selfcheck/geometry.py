"""Geometry: is the surface the manifest names the one in the calibration frame?

The video stage calibrates the image scale from the feature height the manifest gives
(``mm_per_px = H / h-hat_0``, Fig. 7A of Janko et al. 2018), so a wrong height cannot be
seen in millimetres: every length scales with it. What the calibration frame does say,
whatever the scale, is the feature's *shape* (a bump, a step up, a step down) and its
*aspect*, width over height in pixels. :func:`measure_feature` fits the three
raised-cosine shapes of :class:`~fingerfriction.surfaces.RaisedCosine` to the measured
profile h-hat (free base, height, position and width); :func:`check_geometry` compares
the best shape and its width / height with the manifest's surface.

The scale itself is checked against the one figure that does not depend on it: the
sliding speed measured from x(t) against the manifest's ``speed_mm_s`` (a surface of the
right shape but another size, bump-2mm for bump-4mm, doubles every length).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ..surfaces import RaisedCosine, Surface
from .flags import Check, SelfCheckParams

__all__ = ["FeatureFit", "measure_feature", "check_geometry", "check_speed", "sliding_speed"]

_SHAPES = ("bump", "step-up", "step-down")


@dataclass(frozen=True)
class FeatureFit:
    """The relief feature seen in a calibration frame.

    Attributes
    ----------
    shape : str
        The raised-cosine shape that fits the profile best.
    width_px, height_px : float
        Its width W and height H in pixels.
    centre_px : float
        Column of its centre (crop coordinates).
    rms_px : dict
        RMS residual in px of the best fit of each shape.
    """

    shape: str
    width_px: float
    height_px: float
    centre_px: float
    rms_px: dict

    @property
    def aspect(self) -> float:
        """W / H, independent of the image scale."""
        return self.width_px / self.height_px

    def to_dict(self) -> dict:
        return {
            "shape": self.shape,
            "width_px": round(self.width_px, 3),
            "height_px": round(self.height_px, 3),
            "centre_px": round(self.centre_px, 3),
            "aspect": round(self.aspect, 4),
            "rms_px": {k: round(v, 4) for k, v in self.rms_px.items()},
        }


def _unit(shape: str):
    return RaisedCosine(shape, 1.0, 1.0).h  # heights 0..1 over widths centred at 0


def _fit_shape(rows: np.ndarray, shape: str) -> tuple[float, np.ndarray]:
    """Best ``rows ~ base - A g((c - c0) / w)`` of one shape, ``A > 0``: (rms px, [base, A, c0,
    w]); a coarse grid of ``(c0, w)`` (base and A solved in closed form, all at once), then
    least squares from its best point."""
    g = _unit(shape)
    n = rows.size
    cols = np.arange(n, dtype=float)

    def linear(c0: float, w: float):
        G = g((cols - c0) / w)
        X = np.column_stack([np.ones(n), -G])
        coef, *_ = np.linalg.lstsq(X, rows, rcond=None)
        return coef, rows - X @ coef

    ws = np.geomspace(8.0, 0.9 * n, 16)
    c0s = np.linspace(0.1 * n, 0.9 * n, 25)
    C0, W = np.meshgrid(c0s, ws, indexing="ij")
    sub = cols[::4]
    r = rows[::4]
    G = g((sub[None, None, :] - C0[..., None]) / W[..., None])  # (25, 16, n/4)
    m = sub.size
    sg, sgg = G.sum(-1), (G * G).sum(-1)
    sr, srg = r.sum(), (G * r).sum(-1)
    det = m * sgg - sg * sg
    with np.errstate(invalid="ignore", divide="ignore"):
        base = (sgg * sr - sg * srg) / det
        amp = -(m * srg - sg * sr) / det  # rows = base - amp G
    rss = np.sum((r - (base[..., None] - amp[..., None] * G)) ** 2, axis=-1)
    rss = np.where(np.isfinite(rss) & (amp > 0), rss, np.inf)
    i, j = np.unravel_index(int(np.argmin(rss)), rss.shape)
    if not np.isfinite(rss[i, j]):
        return math.inf, np.array([np.mean(rows), 0.0, n / 2, n / 4])
    sol = least_squares(
        lambda p: linear(p[0], max(p[1], 2.0))[1][::3],
        [C0[i, j], W[i, j]],
        method="lm",
        x_scale=[10.0, 10.0],
        xtol=1e-6,
        max_nfev=60,
    )
    c0, w = float(sol.x[0]), max(float(sol.x[1]), 2.0)
    coef, res = linear(c0, w)
    return float(np.sqrt(np.mean(res**2))), np.array([coef[0], coef[1], c0, w])


def measure_feature(surface_rows, expected: str | None = None) -> FeatureFit:
    """Fit the three raised-cosine shapes to a calibration frame's surface profile.

    Parameters
    ----------
    surface_rows : (width,) array_like
        Sub-pixel row of the surface's top edge in each column (rows grow downwards):
        :attr:`fingerfriction.video.calibrate.Calibration.surface_row`.
    expected : str, optional
        The shape the manifest names: fitted first, and when it fits within 0.5 px (or 3 %
        of its height) RMS the others are not tried (their ``rms_px`` is NaN).

    Returns
    -------
    FeatureFit

    Raises
    ------
    ValueError
        A profile with fewer than 20 finite columns.
    """
    rows = np.asarray(surface_rows, dtype=float)
    ok = np.isfinite(rows)
    if ok.sum() < 20:
        raise ValueError(
            f"the calibration profile has {int(ok.sum())} finite columns; at least 20 are needed"
        )
    cols = np.arange(rows.size, dtype=float)
    rows = np.interp(cols, cols[ok], rows[ok])
    fits = {}
    if expected in _SHAPES:
        fits[expected] = _fit_shape(rows, expected)
        rms0, p0 = fits[expected]
        if p0[1] > 0 and rms0 <= max(0.5, 0.03 * p0[1]):
            return FeatureFit(
                expected,
                float(p0[3]),
                float(p0[1]),
                float(p0[2]),
                {s: (rms0 if s == expected else math.nan) for s in _SHAPES},
            )
    fits.update({s: _fit_shape(rows, s) for s in _SHAPES if s not in fits})
    flat = float(np.std(rows))  # a shape that fits only upside down explains nothing: a flat line
    rms = {s: f[0] if f[1][1] > 0 and math.isfinite(f[0]) else flat for s, f in fits.items()}
    shape = min(rms, key=rms.get)
    _, a, c0, w = fits[shape][1]
    return FeatureFit(shape, float(w), float(a), float(c0), rms)


def _describe(surface: RaisedCosine, height_mm: float) -> str:
    return (
        f"{surface.name}: {surface.shape}, W {surface.width:g} mm, H {height_mm:g} mm, "
        f"W/H {surface.width / height_mm:.3g}"
    )


def check_geometry(
    feature: FeatureFit | None, surface: Surface, height_mm: float, *, params: SelfCheckParams | None = None
) -> list[Check]:
    """``surface-type`` and ``surface-geometry``: the manifest's surface against the feature.

    Parameters
    ----------
    feature : FeatureFit or None
        :func:`measure_feature` of the calibration frame (None: not measured).
    surface : Surface
        The trial's surface from the manifest.
    height_mm : float
        The feature height that calibrates the scale (``calibration.surface_height_mm``,
        else the surface's own).
    params : SelfCheckParams, optional

    Returns
    -------
    list of Check
        An error names both the manifest's surface and what the frame shows.
    """
    P = params or SelfCheckParams()
    if feature is None:
        return [Check("surface-geometry", "info", math.nan, "", "not measured: no calibration profile")]
    if not isinstance(surface, RaisedCosine):
        return [
            Check(
                "surface-geometry",
                "info",
                math.nan,
                "",
                f"not checked: surface {surface.name!r} is a sampled profile, not a raised-cosine feature",
            )
        ]
    out = []
    said = _describe(surface, height_mm)
    seen = (
        f"a {feature.shape}, W/H {feature.aspect:.3g} ({feature.width_px:.0f} x {feature.height_px:.1f} px)"
    )
    r_named, r_best = feature.rms_px[surface.shape], feature.rms_px[feature.shape]
    if feature.shape != surface.shape and r_named > 2.0 * r_best + 0.3:
        out.append(
            Check(
                "surface-type",
                "error",
                r_named,
                "px",
                f"the manifest's surface ({said}) is not the feature in the calibration frame ({seen}; "
                f"a {surface.shape} fits it {r_named:.2f} px RMS, a {feature.shape} {r_best:.2f} px): "
                "check the trial's surface",
                "surface",
            )
        )
        return out
    out.append(
        Check(
            "surface-type",
            "ok",
            r_named,
            "px",
            f"a {surface.shape} fits the calibration frame ({r_named:.2f} px RMS)",
        )
    )
    expected = surface.width / height_mm
    rel = feature.aspect / expected - 1.0
    if abs(rel) > P.aspect_tolerance:
        out.append(
            Check(
                "surface-geometry",
                "error",
                100 * rel,
                "%",
                f"the manifest's surface ({said}) does not match the feature in the calibration frame "
                f"({seen}): width / height {100 * rel:+.0f} % off; check "
                "calibration.surface_height_mm and the surface's W and H",
                "calibration.surface_height_mm",
            )
        )
    else:
        out.append(
            Check(
                "surface-geometry",
                "ok",
                100 * rel,
                "%",
                f"width / height {feature.aspect:.3g} against the manifest's {expected:.3g}",
            )
        )
    return out


def sliding_speed(t_s, x_mm) -> float:
    """Median sliding speed in mm/s over the frames where the finger has moved 3 mm from its
    first tracked position and before the last 3 mm (NaN when it does not slide that far)."""
    t = np.asarray(t_s, float)
    x = np.asarray(x_mm, float)
    ok = np.isfinite(x)
    if ok.sum() < 10:
        return math.nan
    t, x = t[ok], x[ok]
    d = x - x[0]
    span = float(d[-1])
    if abs(span) < 8.0:
        return math.nan
    sel = (np.abs(d) > 3.0) & (np.abs(span - d) > 3.0)
    if sel.sum() < 5:
        return math.nan
    ts, xs = t[sel], x[sel]
    return float(abs(np.polyfit(ts, xs, 1)[0]))


def check_speed(speed_mm_s: float, nominal_mm_s: float, *, params: SelfCheckParams | None = None) -> Check:
    """``speed``: the sliding speed from x(t) against the manifest's nominal one (a warning:
    people do not hold a speed exactly; far off, the image scale or the surface's size is
    wrong, or the frame rate)."""
    P = params or SelfCheckParams()
    if not (math.isfinite(speed_mm_s) and nominal_mm_s and nominal_mm_s > 0):
        return Check("speed", "info", math.nan, "", "not measured: x(t) does not cover a slide of 8 mm")
    ratio = speed_mm_s / nominal_mm_s
    text = f"the finger slid at {speed_mm_s:.3g} mm/s by x(t), the manifest says {nominal_mm_s:g} mm/s"
    if not 1.0 / P.speed_ratio <= ratio <= P.speed_ratio:
        return Check(
            "speed",
            "warning",
            ratio,
            "",
            f"{text} ({ratio:.2f}x): check the surface's size and calibration.surface_height_mm (they "
            "set the image scale), video.fps and speed_mm_s",
            "speed_mm_s",
        )
    return Check("speed", "ok", ratio, "", text)
