"""Relief surfaces: height h(x), slope dh/dx and angle alpha(x).

The paper's surfaces (Janko, Wiertlewski & Visell 2018, Methods "Relief surfaces",
Fig. 1D,E) are flat plates with one raised-cosine feature of width ``W`` and height
``H = 0.2 W`` at their centre: a Bump (a full cosine period over ``W``), a Step Up and a
Step Down (half a period over ``W``). Any other relief can be given as a sampled profile.

Conventions
-----------
* Positions ``x`` and heights ``h`` are in millimetres; the feature is centred on
  ``x = 0`` and the finger slides from negative to positive ``x`` (left to right).
* The flat ground to the left of every paper surface is at ``h = 0`` except Step Down,
  which starts at ``h = H`` on the left and ends at ``h = 0`` on the right.
* ``alpha(x) = atan(dh/dx)`` in radians (Fig. 5 of the paper).
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from scipy.interpolate import make_smoothing_spline

from ._check import check_option, positive

__all__ = [
    "Surface",
    "RaisedCosine",
    "SampledProfile",
    "SURFACE_NAMES",
    "get_surface",
    "surface_from_spec",
    "load_profile_csv",
]

Shape = Literal["bump", "step-up", "step-down"]
_SHAPES = ("bump", "step-up", "step-down")

#: Physical ranges of a relief under a fingertip (checked for every surface made, from a
#: spec, a manifest, a CSV profile): a feature 0.05 mm (two pixels of the paper's camera)
#: to 50 mm wide (twice the 26 mm window the forces are analysed on), up to 10 mm high,
#: centred within 50 mm of the origin, slopes below 80 degrees (the finger cannot follow a
#: steeper wall); a sampled profile spans at most 200 mm in at most 1e6 samples, heights
#: within +-20 mm.
WIDTH_RANGE_MM = (0.05, 50.0)
MAX_HEIGHT_MM = 10.0
MAX_CENTER_MM = 50.0
MAX_SLOPE_RAD = math.radians(80.0)
MAX_PROFILE_SPAN_MM = 200.0
MAX_PROFILE_POINTS = 1_000_000
MAX_PROFILE_HEIGHT_MM = 20.0


class Surface:
    """Base class of a relief profile ``h(x)`` in mm.

    Subclasses implement :meth:`h` and :meth:`dhdx`; everything else derives from them.
    """

    name: str = "surface"

    #: ``(x_min, x_max)`` in mm of the region where the relief is not flat.
    feature_extent: tuple[float, float] = (0.0, 0.0)

    def h(self, x):
        """Height in mm at positions ``x`` (mm), any shape."""
        raise NotImplementedError

    def dhdx(self, x):
        """Slope dh/dx (dimensionless) at positions ``x`` (mm), any shape."""
        raise NotImplementedError

    def alpha(self, x):
        """Angle of the surface with the horizontal, ``atan(dh/dx)`` in rad (Fig. 5)."""
        return np.arctan(self.dhdx(x))

    @property
    def max_height(self) -> float:
        """Highest point of the relief in mm."""
        a, b = self.feature_extent
        xs = np.linspace(a - 1.0, b + 1.0, 4001)
        return float(np.max(self.h(xs)))

    def max_slope_angle(self) -> float:
        """Largest ``|alpha|`` over the feature, in rad."""
        a, b = self.feature_extent
        xs = np.linspace(a, b, 20001)
        return float(np.max(np.abs(self.alpha(xs))))


@dataclass(frozen=True)
class RaisedCosine(Surface):
    """A raised-cosine relief feature on a flat plate (Fig. 1D,E of the paper).

    Parameters
    ----------
    shape : {'bump', 'step-up', 'step-down'}
        Bump: ``h = H/2 (1 + cos(2 pi x / W))`` for ``|x| < W/2``. Step Up:
        ``h = H/2 (1 - cos(pi (x + W/2) / W))`` over ``[-W/2, W/2]``, 0 before and ``H``
        after. Step Down is the mirror image of Step Up (``H`` before, 0 after).
    width : float
        Feature width ``W`` in mm.
    height : float, optional
        Feature height ``H`` in mm; ``0.2 * width`` by default, as in the paper.
    center : float, optional
        Position of the feature's centre in mm (default 0).

    Notes
    -----
    Maximum slope: ``pi H / W`` for the bump (0.628 for ``H = 0.2 W``, i.e. 0.56 rad, the
    paper's stated maximum slope angle) and ``pi H / (2 W)`` for the steps.
    """

    shape: Shape
    width: float
    height: float | None = None
    center: float = 0.0
    name: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        check_option("shape", self.shape, _SHAPES)
        w = positive("width", self.width, "mm", what="length")
        h = 0.2 * w if self.height is None else positive("height", self.height, "mm", what="length")
        c = float(self.center)
        if not math.isfinite(c):
            raise ValueError(f"center must be a finite position in mm, got {self.center!r}")
        lo, hi = WIDTH_RANGE_MM
        if not lo <= w <= hi:
            raise ValueError(f"width W = {w:g} mm is outside the physical range [{lo:g}, {hi:g}] mm of a "
                             "relief feature under a fingertip (WIDTH_RANGE_MM)")
        if h > MAX_HEIGHT_MM:
            raise ValueError(f"height H = {h:g} mm is above the {MAX_HEIGHT_MM:g} mm a relief feature under "
                             "a fingertip may have (MAX_HEIGHT_MM)")
        if abs(c) > MAX_CENTER_MM:
            raise ValueError(f"center C = {c:g} mm is more than {MAX_CENTER_MM:g} mm from the origin "
                             "(MAX_CENTER_MM)")
        slope = math.atan((math.pi if self.shape == "bump" else math.pi / 2) * h / w)
        if slope > MAX_SLOPE_RAD:
            raise ValueError(f"a {self.shape} of W = {w:g} mm and H = {h:g} mm rises at "
                             f"{math.degrees(slope):.1f} degrees, steeper than the "
                             f"{math.degrees(MAX_SLOPE_RAD):.0f} degrees a finger can follow (MAX_SLOPE_RAD)")
        object.__setattr__(self, "width", w)
        object.__setattr__(self, "height", h)
        object.__setattr__(self, "center", c)
        if not self.name:
            object.__setattr__(self, "name", f"{self.shape}-{w:g}mm")

    @property
    def feature_extent(self) -> tuple[float, float]:  # type: ignore[override]
        return (self.center - self.width / 2, self.center + self.width / 2)

    @property
    def max_height(self) -> float:  # type: ignore[override]
        return float(self.height)

    def _u(self, x):
        """Normalised position in [0, 1] over the feature (clipped)."""
        x = np.asarray(x, dtype=float)
        return np.clip((x - self.center) / self.width + 0.5, 0.0, 1.0)

    def h(self, x):
        x = np.asarray(x, dtype=float)
        u = self._u(x)
        H = self.height
        if self.shape == "bump":
            return 0.5 * H * (1.0 - np.cos(2.0 * np.pi * u))
        up = 0.5 * H * (1.0 - np.cos(np.pi * u))
        return up if self.shape == "step-up" else H - up

    def dhdx(self, x):
        x = np.asarray(x, dtype=float)
        u = self._u(x)
        inside = (u > 0.0) & (u < 1.0)
        H, W = self.height, self.width
        if self.shape == "bump":
            s = np.pi * H / W * np.sin(2.0 * np.pi * u)
        else:
            s = 0.5 * np.pi * H / W * np.sin(np.pi * u)
            if self.shape == "step-down":
                s = -s
        return np.where(inside, s, 0.0)

    def d2hdx2(self, x):
        """Curvature term d2h/dx2 in 1/mm (used by the contact model's grid checks)."""
        x = np.asarray(x, dtype=float)
        u = self._u(x)
        inside = (u > 0.0) & (u < 1.0)
        H, W = self.height, self.width
        if self.shape == "bump":
            c = 2.0 * np.pi**2 * H / W**2 * np.cos(2.0 * np.pi * u)
        else:
            c = 0.5 * np.pi**2 * H / W**2 * np.cos(np.pi * u)
            if self.shape == "step-down":
                c = -c
        return np.where(inside, c, 0.0)

    def max_slope_angle(self) -> float:
        k = 1.0 if self.shape == "bump" else 0.5
        return float(np.arctan(k * np.pi * self.height / self.width))

    def to_dict(self) -> dict:
        """JSON-serialisable description (``surface_from_spec`` reads it back)."""
        return {
            "kind": "raised-cosine",
            "shape": self.shape,
            "width": self.width,
            "height": self.height,
            "center": self.center,
            "name": self.name,
        }


@dataclass(frozen=True, eq=False)
class SampledProfile(Surface):
    """A relief given as samples ``(x_i, h_i)`` in mm, with robust derivatives.

    The slope comes from a smoothing spline (``scipy.interpolate.make_smoothing_spline``)
    fitted to the samples, so measurement noise in a scanned profile does not blow up in
    dh/dx. Outside the sampled range the profile continues flat at its end heights.

    Parameters
    ----------
    x : (n,) array_like
        Strictly increasing positions in mm, ``n >= 4``.
    h : (n,) array_like
        Heights in mm, finite.
    smoothing : float, optional
        Smoothing parameter ``lam`` of ``make_smoothing_spline`` (default 0: interpolate
        exactly). Increase it for noisy scans.
    name : str, optional
        A label for tables and figures.
    """

    x: np.ndarray
    h_samples: np.ndarray
    smoothing: float = 0.0
    name: str = "profile"

    def __post_init__(self) -> None:
        x = np.asarray(self.x, dtype=float)
        h = np.asarray(self.h_samples, dtype=float)
        if x.ndim != 1 or h.ndim != 1:
            raise ValueError(f"x and h must be 1-D arrays, got shapes {x.shape} and {h.shape}")
        if x.size != h.size:
            raise ValueError(f"x and h must have the same length, got {x.size} and {h.size}")
        if x.size < 4:
            raise ValueError(f"a sampled profile needs at least 4 points, got {x.size}")
        bad = ~np.isfinite(x) | ~np.isfinite(h)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"profile has a non-finite value at sample {i} (x={float(x[i])!r}, h={float(h[i])!r})"
            )
        dx = np.diff(x)
        if np.any(dx <= 0):
            i = int(np.flatnonzero(dx <= 0)[0])
            raise ValueError(
                f"profile x must be strictly increasing; x[{i}]={float(x[i])!r} "
                f"is followed by x[{i + 1}]={float(x[i + 1])!r}"
            )
        if x.size > MAX_PROFILE_POINTS:
            raise ValueError(f"a sampled profile may have at most {MAX_PROFILE_POINTS} points, got {x.size}")
        span, h_max, x_max = x[-1] - x[0], np.abs(h).max(), np.abs(x).max()
        if span > MAX_PROFILE_SPAN_MM or x_max > MAX_PROFILE_SPAN_MM or h_max > MAX_PROFILE_HEIGHT_MM:
            lim, hlim = MAX_PROFILE_SPAN_MM, MAX_PROFILE_HEIGHT_MM
            raise ValueError(f"a profile may span {lim:g} mm within +-{lim:g} mm, heights within +-{hlim:g} "
                             f"mm; got a span of {span:g}, |x| up to {x_max:g}, |h| up to {h_max:g} "
                             "(positions and heights in mm?)")
        lam = float(self.smoothing)
        if not math.isfinite(lam) or lam < 0:
            raise ValueError(f"smoothing must be >= 0, got {self.smoothing!r}")
        if lam == 0.0:
            from scipy.interpolate import make_interp_spline  # only for sampled profiles (import cost)

            spl = make_interp_spline(x, h, k=3)
        else:
            spl = make_smoothing_spline(x, h, lam=lam)
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "h_samples", h)
        object.__setattr__(self, "_spline", spl)
        object.__setattr__(self, "_dspline", spl.derivative())
        object.__setattr__(self, "_d2spline", spl.derivative(2))

    @property
    def feature_extent(self) -> tuple[float, float]:  # type: ignore[override]
        """Span of samples whose height differs from the end levels by more than 0.1 um."""
        h = self.h_samples
        tol = 1e-4
        off = (np.abs(h - h[0]) > tol) & (np.abs(h - h[-1]) > tol)
        if not off.any():
            off = np.abs(np.diff(h, prepend=h[0])) > tol
        if not off.any():
            return (float(self.x[0]), float(self.x[0]))
        idx = np.flatnonzero(off)
        return (float(self.x[max(idx[0] - 1, 0)]), float(self.x[min(idx[-1] + 1, self.x.size - 1)]))

    def h(self, x):
        x = np.asarray(x, dtype=float)
        xc = np.clip(x, self.x[0], self.x[-1])
        return self._spline(xc)

    def dhdx(self, x):
        x = np.asarray(x, dtype=float)
        inside = (x >= self.x[0]) & (x <= self.x[-1])
        return np.where(inside, self._dspline(np.clip(x, self.x[0], self.x[-1])), 0.0)

    def d2hdx2(self, x):
        x = np.asarray(x, dtype=float)
        inside = (x >= self.x[0]) & (x <= self.x[-1])
        return np.where(inside, self._d2spline(np.clip(x, self.x[0], self.x[-1])), 0.0)

    def to_dict(self) -> dict:
        return {
            "kind": "sampled",
            "name": self.name,
            "x": self.x.tolist(),
            "h": self.h_samples.tolist(),
            "smoothing": self.smoothing,
        }


def load_profile_csv(path: str | os.PathLike, *, smoothing: float = 0.0) -> SampledProfile:
    """Read a two-column CSV of ``x, h`` in mm (an optional header line is skipped).

    Raises
    ------
    ValueError
        Naming the file and the offending line when a row is not two numbers, or when
        ``x`` is not strictly increasing.
    """
    path = os.fspath(path)
    xs: list[float] = []
    hs: list[float] = []
    try:
        fh = open(path, newline="")
    except OSError as exc:
        raise ValueError(f"{path}: cannot open profile CSV ({exc.strerror})") from None
    with fh:
        for lineno, row in enumerate(csv.reader(fh), start=1):
            cells = [c.strip() for c in row if c.strip() != ""]
            if not cells or cells[0].startswith("#"):
                continue
            if len(cells) != 2:
                raise ValueError(
                    f"{path}, line {lineno}: expected two columns (x, h in mm), got {len(cells)}"
                )
            try:
                xv, hv = float(cells[0]), float(cells[1])
            except ValueError:
                if not xs:  # a header line
                    continue
                raise ValueError(
                    f"{path}, line {lineno}: x and h must be numbers, got {cells!r}"
                ) from None
            xs.append(xv)
            hs.append(hv)
    name = os.path.splitext(os.path.basename(path))[0]
    try:
        return SampledProfile(np.array(xs), np.array(hs), smoothing=smoothing, name=name)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


#: The six surfaces of the study, by name.
SURFACE_NAMES: tuple[str, ...] = (
    "bump-2mm",
    "step-up-2mm",
    "step-down-2mm",
    "bump-4mm",
    "step-up-4mm",
    "step-down-4mm",
)


def get_surface(name: str) -> RaisedCosine:
    """One of the paper's six surfaces by name, e.g. ``'bump-2mm'``, ``'step-up-4mm'``.

    Raises
    ------
    ValueError
        For an unknown name, listing the known ones.
    """
    if not isinstance(name, str) or name not in SURFACE_NAMES:
        raise ValueError(
            f"unknown surface {name!r}; known surfaces: {', '.join(SURFACE_NAMES)}"
        )
    shape, _, width = name.rpartition("-")
    return RaisedCosine(shape, float(width.removesuffix("mm")), name=name)  # type: ignore[arg-type]


def surface_from_spec(spec, *, files: bool = True) -> Surface:
    """A surface from a name, a parametric spec string, a CSV path, or a dict.

    Accepted forms: a paper surface name (``'bump-4mm'``); a parametric raised-cosine
    feature ``'bump:W=3,H=0.5'`` (shape, width and optional height in mm); a path to a
    two-column CSV profile; a dict as written by ``Surface.to_dict``. Every surface is
    checked against the physical ranges above (:data:`WIDTH_RANGE_MM`...).

    ``files=False``: a string is a name or a spec, never a file (a study's manifest
    names no file outside the study through a surface).
    """
    if isinstance(spec, Surface):
        return spec
    if isinstance(spec, dict):
        kind = spec.get("kind")
        if kind == "raised-cosine":
            return RaisedCosine(
                spec["shape"], spec["width"], spec.get("height"), spec.get("center", 0.0),
                name=spec.get("name", ""),
            )
        if kind == "sampled":
            return SampledProfile(
                np.asarray(spec["x"]), np.asarray(spec["h"]), spec.get("smoothing", 0.0),
                name=spec.get("name", "profile"),
            )
        raise ValueError(f"surface dict has unknown kind {kind!r}; allowed: raised-cosine, sampled")
    if not isinstance(spec, (str, os.PathLike)):
        raise TypeError(f"surface spec must be a name, spec string or path, got {spec!r}")
    s = os.fspath(spec)
    if s in SURFACE_NAMES:
        return get_surface(s)
    if ":" in s and not (files and os.path.exists(s)):
        shape, _, params = s.partition(":")
        kv: dict[str, float] = {}
        for part in params.split(","):
            k, eq, v = part.partition("=")
            if not eq or k.strip().upper() not in ("W", "H", "C"):
                raise ValueError(
                    f"surface spec {s!r}: expected 'shape:W=<mm>[,H=<mm>][,C=<mm>]', "
                    f"got part {part!r}"
                )
            try:
                kv[k.strip().upper()] = float(v)
            except ValueError:
                raise ValueError(f"surface spec {s!r}: {k}={v!r} is not a number") from None
        if "W" not in kv:
            raise ValueError(f"surface spec {s!r} needs a width W=<mm>")
        return RaisedCosine(shape.strip(), kv["W"], kv.get("H"), kv.get("C", 0.0))  # type: ignore[arg-type]
    if files and (s.lower().endswith(".csv") or os.path.exists(s)):
        return load_profile_csv(s)
    raise ValueError(
        f"unknown surface {s!r}; give one of {', '.join(SURFACE_NAMES)}, "
        "a spec like 'bump:W=3,H=0.5', or a CSV file of x,h in mm"
    )
