"""Finger parameters for the forward contact model, and the two calibrated subjects.

Geometry convention (used by the solver, the simulator and the video analysis)
----------------------------------------------------------------------------------
The finger is a 2-D (plane-strain) body seen from the side, as in the paper's
fronto-parallel video. Its undeformed lower outline, relative to its *centre*, is
``y = y_low + s(x - x_finger)`` where ``s >= 0`` with ``s(0) = 0``:

* ``x_finger`` (mm, surface coordinates) is the horizontal position of the finger's
  centre: the circle's (or ellipse's) centre, i.e. the abscissa of the lowest point of
  the undeformed outline. A user-given profile is placed so its own ``x = 0`` sits at
  ``x_finger``.
* circle: ``s(u) = R - sqrt(R^2 - u^2)``, defined for ``|u| < R``; with a
  ``flat_length`` ``L > 0`` the two halves of the circle are moved apart by ``L`` and
  joined by a flat bottom (a "stadium": ``s(u) = 0`` for ``|u| <= L/2``, the circle of
  ``|u| - L/2`` beyond), the shape of a finger pad flattened by the load; ``x_finger`` is
  then the middle of the flat;
* ellipse: horizontal semi-axis ``R`` and vertical semi-axis ``b``:
  ``s(u) = b (1 - sqrt(1 - u^2 / R^2))``; curvature radius at the bottom ``R^2 / b``;
* profile: samples ``(u_i, s_i)`` in mm, linearly interpolated.

The normal load per unit width is ``P' = F_N / D`` (N/mm), ``D`` being the effective
finger width across the sliding direction (the paper's ``D``, Eq. 4).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np

from .._check import check_option

__all__ = ["FingerParams", "SUBJECTS", "get_subject"]

Shape = Literal["circle", "ellipse", "profile"]
_SHAPES = ("circle", "ellipse", "profile")


def _num(name: str, value, unit: str, *, positive: bool = True, allow_none: bool = False):
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"FingerParams.{name} must be a number in {unit}, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or (positive and v <= 0):
        raise ValueError(
            f"FingerParams.{name} must be a finite {'positive ' if positive else ''}number in {unit}, "
            f"got {value!r}"
        )
    return v


@dataclass(frozen=True)
class FingerParams:
    """Mechanical and geometric parameters of the finger pad (plane strain).

    Parameters
    ----------
    radius : float
        Radius ``R`` of the undeformed outline in mm (circle), or the horizontal
        semi-axis (ellipse). Ignored for ``shape='profile'`` except as the default
        reference length of the half-space displacement.
    modulus : float
        Effective plane-strain modulus ``E* = E / (1 - nu^2)`` of the finger pad in MPa
        (N/mm^2), against a rigid surface.
    width : float
        Effective finger width ``D`` in mm across the sliding direction: the load per unit
        width is ``F_N / D`` (N/mm).
    shape : {'circle', 'ellipse', 'profile'}, optional
        Undeformed outline (default circle).
    semi_height : float, optional
        Ellipse only: vertical semi-axis ``b`` in mm.
    flat_length : float, optional
        Circle only: length in mm of a flat bottom inserted between the two halves of the
        circle (default 0: a plain circle).
    profile : (2, m) sequence, optional
        Profile only: ``(u, s)`` samples in mm, ``u`` strictly increasing and spanning 0,
        ``s`` finite, ``s(0) = 0`` after interpolation is not required (the minimum is
        subtracted).
    layer_thickness : float, optional
        Thickness in mm of the soft tissue layer bonded to a rigid bone. ``None``
        (default): an elastic half-space.
    poisson : float, optional
        Poisson ratio of the tissue, used only with a layer (default 0.5: incompressible,
        as the paper assumes for its finger tracking). In ``[0, 0.5]``.
    skin_modulus, skin_thickness : float, optional
        A stiff skin sheet (stratum corneum, epidermis, dermis) of plane-strain modulus
        ``E_s`` (MPa) and thickness ``h_s`` (mm) lying on the soft pulp (``modulus``):
        a plate of bending stiffness ``B = E_s h_s^3 / 12`` (N mm) on the elastic
        half-space (Biot 1937), whose response turns into that of a half-space of modulus
        ``E* + E_s`` at wavelengths shorter than the sheet (see
        :mod:`~fingerfriction.mechanics.bem`). Both or neither; not combinable with
        ``layer_thickness``.
    name : str, optional
        A label.

    Raises
    ------
    ValueError, TypeError
        For a non-positive or non-finite modulus, radius, width or thickness, a bad shape,
        a profile with NaN or non-increasing ``u``, naming the field and the value.
    """

    radius: float
    modulus: float
    width: float
    shape: Shape = "circle"
    semi_height: float | None = None
    flat_length: float = 0.0
    profile: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    layer_thickness: float | None = None
    poisson: float = 0.5
    skin_modulus: float | None = None
    skin_thickness: float | None = None
    name: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _num("radius", self.radius, "mm"))
        object.__setattr__(self, "modulus", _num("modulus", self.modulus, "MPa"))
        object.__setattr__(self, "width", _num("width", self.width, "mm"))
        check_option("FingerParams.shape", self.shape, _SHAPES)
        object.__setattr__(
            self, "layer_thickness", _num("layer_thickness", self.layer_thickness, "mm", allow_none=True)
        )
        object.__setattr__(
            self, "skin_modulus", _num("skin_modulus", self.skin_modulus, "MPa", allow_none=True)
        )
        object.__setattr__(
            self, "skin_thickness", _num("skin_thickness", self.skin_thickness, "mm", allow_none=True)
        )
        if (self.skin_modulus is None) != (self.skin_thickness is None):
            raise ValueError(
                "FingerParams: give both skin_modulus (MPa) and skin_thickness (mm) or neither; "
                f"got skin_modulus={self.skin_modulus!r}, skin_thickness={self.skin_thickness!r}"
            )
        if self.has_skin and self.layer_thickness is not None:
            raise ValueError(
                "FingerParams: a skin sheet and layer_thickness cannot be combined; "
                f"got skin_thickness={self.skin_thickness!r}, layer_thickness={self.layer_thickness!r}"
            )
        nu = _num("poisson", self.poisson, "(dimensionless)", positive=False)
        if not 0.0 <= nu <= 0.5:
            raise ValueError(f"FingerParams.poisson must be in [0, 0.5], got {self.poisson!r}")
        object.__setattr__(self, "poisson", nu)
        fl = _num("flat_length", self.flat_length, "mm", positive=False)
        if fl < 0:
            raise ValueError(f"FingerParams.flat_length must be >= 0 mm, got {self.flat_length!r}")
        if fl > 0 and self.shape != "circle":
            raise ValueError(
                f"FingerParams.flat_length is only used with shape='circle', got shape={self.shape!r}"
            )
        object.__setattr__(self, "flat_length", fl)
        if self.shape == "ellipse":
            if self.semi_height is None:
                raise ValueError("FingerParams.semi_height (mm) is required for shape='ellipse'")
            object.__setattr__(self, "semi_height", _num("semi_height", self.semi_height, "mm"))
        elif self.semi_height is not None:
            raise ValueError(
                f"FingerParams.semi_height is only used with shape='ellipse', got {self.semi_height!r} "
                f"with shape={self.shape!r}"
            )
        if self.shape == "profile":
            if self.profile is None:
                raise ValueError(
                    "FingerParams.profile ((u, s) samples in mm) is required for shape='profile'"
                )
            try:
                u = np.asarray(self.profile[0], dtype=float)
                s = np.asarray(self.profile[1], dtype=float)
            except (TypeError, ValueError, IndexError):
                raise ValueError(
                    "FingerParams.profile must be a pair of equal-length number sequences (u, s) in mm"
                ) from None
            if u.ndim != 1 or s.shape != u.shape or u.size < 3:
                raise ValueError(
                    f"FingerParams.profile must be two 1-D sequences of the same length >= 3, "
                    f"got shapes {u.shape} and {s.shape}"
                )
            bad = ~(np.isfinite(u) & np.isfinite(s))
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise ValueError(
                    f"FingerParams.profile has a non-finite value at sample {i}: u={u[i]!r}, s={s[i]!r}"
                )
            if np.any(np.diff(u) <= 0):
                raise ValueError("FingerParams.profile u must be strictly increasing")
            if not (u[0] < 0 < u[-1]):
                raise ValueError(
                    f"FingerParams.profile u must span 0 (the finger centre), got [{u[0]}, {u[-1]}]"
                )
            object.__setattr__(self, "profile", (tuple(u.tolist()), tuple((s - s.min()).tolist())))
        elif self.profile is not None:
            raise ValueError(
                f"FingerParams.profile is only used with shape='profile', got shape={self.shape!r}"
            )

    @property
    def has_skin(self) -> bool:
        """True when the finger has a stiff skin sheet over the pulp."""
        return self.skin_modulus is not None

    @property
    def skin_bending(self) -> float:
        """Bending stiffness per unit width of the skin sheet, ``E_s h_s^3 / 12`` (N mm); 0 without."""
        if not self.has_skin:
            return 0.0
        return float(self.skin_modulus) * float(self.skin_thickness) ** 3 / 12.0  # type: ignore[arg-type]

    # ------------------------------------------------------------------ geometry
    @property
    def half_extent(self) -> float:
        """Largest ``|u|`` (mm) where the undeformed outline is defined."""
        if self.shape == "profile":
            u = self.profile[0]  # type: ignore[index]
            return float(min(-u[0], u[-1]))
        return self.radius + 0.5 * self.flat_length

    @property
    def tip_radius(self) -> float:
        """Radius of curvature (mm) of the outline at its lowest point (profile: fitted)."""
        if self.shape == "circle":
            return self.radius if self.flat_length == 0 else math.inf
        if self.shape == "ellipse":
            return self.radius**2 / float(self.semi_height)  # type: ignore[arg-type]
        u = np.linspace(-0.5, 0.5, 21) * min(self.half_extent, 2.0)
        c = np.polyfit(u, self.outline(u), 2)[0]
        return float(1.0 / (2.0 * c)) if c > 0 else math.inf

    def default_half_width(self, clearance: float = 2.5) -> float:
        """Default grid half-width (mm): where the outline has risen ``clearance`` mm.

        Capped at ``0.98 * half_extent``. The finger's free surface beyond that offset is
        too high above any of the paper's reliefs (at most 0.8 mm) to touch them; a contact
        that nevertheless reaches the grid's edge is reported by the solver
        (``success=False``).
        """
        hi = 0.98 * self.half_extent
        u = np.linspace(0.0, hi, 4001)
        s = self.outline(u)
        above = np.flatnonzero(s >= clearance)
        return float(u[above[0]]) if above.size else float(hi)

    def outline(self, u):
        """Undeformed outline height ``s(u) >= 0`` in mm above its lowest point.

        Parameters
        ----------
        u : array_like
            Offsets from the finger centre in mm; must satisfy ``|u| <= half_extent``.

        Returns
        -------
        ndarray
            Same shape as ``u``.
        """
        u = np.asarray(u, dtype=float)
        if np.any(np.abs(u) > self.half_extent * (1 + 1e-12)):
            raise ValueError(
                f"finger outline evaluated at |u| = {np.abs(u).max():.4g} mm beyond its half extent "
                f"{self.half_extent:.4g} mm; use a smaller grid half_width"
            )
        if self.shape == "circle":
            R = self.radius
            v = np.clip(np.abs(u) - 0.5 * self.flat_length, 0.0, None)
            return R - np.sqrt(np.clip(R * R - v * v, 0.0, None))
        if self.shape == "ellipse":
            a, b = self.radius, float(self.semi_height)  # type: ignore[arg-type]
            return b * (1.0 - np.sqrt(np.clip(1.0 - (u / a) ** 2, 0.0, None)))
        pu, ps = self.profile  # type: ignore[misc]
        return np.interp(u, pu, ps)

    def load_per_width(self, load: float) -> float:
        """Normal load per unit width ``P' = F_N / D`` in N/mm for a load ``F_N`` in N."""
        F = float(load)
        if not math.isfinite(F) or F <= 0:
            raise ValueError(f"load must be a finite positive normal force in N, got {load!r}")
        return F / self.width

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict:
        """JSON-serialisable dict (:meth:`from_dict` reads it back)."""
        d = asdict(self)
        if self.profile is not None:
            d["profile"] = [list(self.profile[0]), list(self.profile[1])]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> FingerParams:
        d = dict(d)
        if d.get("profile") is not None:
            d["profile"] = (tuple(d["profile"][0]), tuple(d["profile"][1]))
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"FingerParams: unknown field(s) {sorted(unknown)}")
        return cls(**d)

    def to_json(self) -> str:
        return json.dumps(self.to_dict())

    @classmethod
    def from_json(cls, text: str) -> FingerParams:
        return cls.from_dict(json.loads(text))


#: Calibrated default fingers of the paper's two subjects (benchmarks/calibrate_fingers.py).
#:
#: Flat-bottomed ("stadium") pads on a soft elastic half-space, D = 10 mm. For a fixed flat
#: length (subject 1: 6 mm, subject 2: 7 mm: the paper reports only modest differences
#: between subjects), the end radius and E* were fitted so that the Step Up 2 mm blind spot
#: is 0.47 mm with the paper's 70 um criterion and the flat-ground contact at 0.3 N is 10 mm
#: long (p > 0; 12.4 mm within 70 um). Measured with them at 0.01 mm steps: Bump 4 mm blind
#: spots 2.62 / 2.54 mm (paper: 2.6 in the text, 1.71 for the right bump in Fig. 3), three
#: contacts at most on Bump 2 mm, two on the other surfaces. A half-space circle, a tissue
#: layer over bone and a flat ellipse could not give any 70 um blind spot on Step Up 2 mm
#: with a 10 mm flat contact (step 1 of the calibration script).
SUBJECTS: dict[int, FingerParams] = {
    1: FingerParams(radius=26.206, modulus=0.1404, width=10.0, flat_length=6.0, name="subject 1"),
    2: FingerParams(radius=21.729, modulus=0.1759, width=10.0, flat_length=7.0, name="subject 2"),
}


def get_subject(subject: int = 1) -> FingerParams:
    """The calibrated finger of subject 1 or 2 (:data:`SUBJECTS`; subject 1 by default)."""
    if subject not in SUBJECTS:
        raise ValueError(f"unknown subject {subject!r}; known subjects: {sorted(SUBJECTS)}")
    return SUBJECTS[subject]
