"""Parameters of the layered finite-element finger and of its mesh.

Geometry (a transverse, plane-strain section of the fingertip in the sliding plane, the
classic 2-D fingertip of Srinivasan & Dandekar 1996; figures and their sources in
``docs/mechanics-fe.md``)::

          nail (stiff arc over the top)
        .-~~~~~~~~~-.
      /   .-------.   \\        outer outline: an ellipse, half-width R, half-height b
     |   (  bone   )   |       bone: a rigid ellipse, half-axes (a_b, b_b), its lowest
     |    '-------'    |             point ``pulp_thickness`` above the finger's bottom
      \\    pulp        /       pulp: soft tissue (modulus E_t) under a skin layer of
        '-.._____..-'               thickness h_s and modulus E_s (E_s ~ 10 E_t)
          ^ finger centre, lowest point of the undeformed outline

Units: mm, MPa (N/mm^2), N.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, fields

import numpy as np

from ..._check import in_range, integer, positive, validate_type

__all__ = ["FEFingerParams", "FEMeshParams", "LITERATURE_FINGER", "HOMOGENEOUS_FINGER"]


def _pos(owner: str, name: str, value, unit: str) -> float:
    """A positive number field (TypeError for anything but a number, bool included)."""
    validate_type(f"{owner}.{name}", value, (int, float), f"a number in {unit}")
    return positive(f"{owner}.{name}", value, unit)


@dataclass(frozen=True)
class FEFingerParams:
    """A layered plane-strain fingertip (see the module notes for the geometry).

    Parameters
    ----------
    radius : float
        Half-width ``R`` of the outer outline in mm (horizontal semi-axis).
    semi_height : float
        Half-height ``b`` of the outer outline in mm (vertical semi-axis); the curvature
        radius at the bottom is ``R^2 / b``.
    width : float
        Effective finger width ``D`` in mm across the sliding plane (load per unit width
        ``F_N / D``).
    tissue_modulus : float
        Young's modulus ``E_t`` of the subcutaneous pulp in MPa.
    skin_modulus : float
        Young's modulus ``E_s`` of the skin layer (epidermis and dermis) in MPa; equal to
        ``tissue_modulus`` for a homogeneous finger.
    skin_thickness : float
        Thickness ``h_s`` of the skin layer in mm.
    poisson : float
        Poisson's ratio of skin and pulp (small-strain), in ``(0, 0.499]``.
    bone_half_width, bone_half_height : float
        Semi-axes of the rigid bone's elliptical section in mm.
    pulp_thickness : float
        Distance in mm from the finger's lowest point up to the bone's lowest point (skin
        included); must leave room for the skin and keep the bone inside the outline.
    nail_modulus : float
        Young's modulus of the nail in MPa: the skin layer over the top of the section
        (``|angle - 90 deg| < nail_half_angle``) is nail.
    nail_half_angle : float
        Half-angle in degrees of the nail's arc, seen from the finger's centre.
    friction : float
        Coefficient ``mu`` of the sliding Coulomb traction ``mu p`` the contact carries
        against the finger's motion towards ``+x`` (default 0: frictionless), in ``[0, 5]``.
        It shifts the contact patch against the motion (``docs/mechanics-fe.md``): a
        finger calibrated on frictional recordings keeps the coefficient it was
        calibrated with, and the forward model applies it.
    name : str
        A label.

    Raises
    ------
    ValueError, TypeError
        Naming the field and the value, for a non-positive or non-finite number or an
        inconsistent geometry (bone outside the outline, skin thicker than the pulp).
    """

    radius: float = 11.0
    semi_height: float = 6.5
    width: float = 10.0
    tissue_modulus: float = 0.02
    skin_modulus: float = 0.2
    skin_thickness: float = 1.0
    poisson: float = 0.45
    bone_half_width: float = 6.5
    bone_half_height: float = 1.75
    pulp_thickness: float = 4.5
    nail_modulus: float = 170.0
    nail_half_angle: float = 50.0
    friction: float = 0.0
    name: str = ""

    def __post_init__(self) -> None:
        own = "FEFingerParams"
        for f in fields(self):
            if f.name in ("name", "friction"):
                continue
            unit = {"poisson": "(dimensionless)", "nail_half_angle": "degrees"}.get(
                f.name, "MPa" if "modulus" in f.name else "mm")
            object.__setattr__(self, f.name, _pos(own, f.name, getattr(self, f.name), unit))
        object.__setattr__(self, "friction", in_range(f"{own}.friction", self.friction, 0.0, 5.0,
                                                      what="friction coefficient"))
        validate_type(f"{own}.name", self.name, str, "text")
        in_range(f"{own}.poisson", self.poisson, 0.0, 0.499, unit="(a compressible solid)", open_lo=True)
        in_range(f"{own}.nail_half_angle", self.nail_half_angle, 0.0, 90.0, unit="degrees", open_lo=True,
                 open_hi=True)
        if self.skin_thickness >= self.pulp_thickness:
            raise ValueError(f"{own}.skin_thickness ({self.skin_thickness:g} mm) must be below "
                             f"pulp_thickness ({self.pulp_thickness:g} mm)")
        top = self.pulp_thickness + 2 * self.bone_half_height
        if top >= 2 * self.semi_height - self.skin_thickness:
            raise ValueError(f"{own}: the bone ({self.bone_half_height:g} mm half-height, "
                             f"{self.pulp_thickness:g} mm above the bottom) does not fit under the top "
                             f"of the outline ({2 * self.semi_height:g} mm high) and its skin")
        if self.bone_half_width >= self.radius - self.skin_thickness:
            raise ValueError(f"{own}.bone_half_width ({self.bone_half_width:g} mm) must be below "
                             f"radius - skin_thickness ({self.radius - self.skin_thickness:g} mm)")

    @property
    def bone_centre_height(self) -> float:
        """Height in mm of the bone's centre above the finger's lowest point."""
        return self.pulp_thickness + self.bone_half_height

    @property
    def tip_radius(self) -> float:
        """Curvature radius of the outline at its lowest point, ``R^2 / b`` (mm)."""
        return self.radius**2 / self.semi_height

    @property
    def homogeneous(self) -> bool:
        """True when skin and pulp have the same modulus."""
        return self.skin_modulus == self.tissue_modulus

    def plane_strain_modulus(self, which: str = "tissue") -> float:
        """``E / (1 - nu^2)`` of the pulp (``'tissue'``) or the skin (``'skin'``), MPa."""
        E = self.tissue_modulus if which == "tissue" else self.skin_modulus
        return E / (1.0 - self.poisson**2)

    def outline(self, u):
        """Undeformed lower outline height (mm) above the lowest point at offsets ``u`` (mm)."""
        u = np.asarray(u, float)
        return self.semi_height * (1.0 - np.sqrt(np.clip(1.0 - (u / self.radius) ** 2, 0.0, None)))

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> FEFingerParams:
        unknown = set(d) - {f.name for f in fields(cls)}
        if unknown:
            raise ValueError(f"FEFingerParams: unknown field(s) {sorted(unknown)}")
        return cls(**d)


@dataclass(frozen=True)
class FEMeshParams:
    """Resolution of the finger's structured (O-grid) mesh of 9-node quadrilaterals.

    Parameters
    ----------
    surface_cell : float
        Element size in mm along the outline over the contact arc (nodes every half of it).
    contact_half_width : float
        Half-width in mm (horizontal) of the finely meshed contact arc around the bottom.
    skin_layers : int
        Elements across the skin layer.
    tissue_layers : int
        Elements across the pulp between the skin and the bone (graded, finest at the skin).
    top_cells : int
        Elements along the rest of the outline (coarse, the top never touches).
    penalty : float
        Contact penalty stiffness in N/mm^3 (pressure per mm of penetration); the
        penetration is ``p / penalty`` (1e-4 mm at 0.1 MPa for the default).
    """

    surface_cell: float = 0.1
    contact_half_width: float = 8.0
    skin_layers: int = 3
    tissue_layers: int = 8
    top_cells: int = 24
    penalty: float = 1000.0

    def __post_init__(self) -> None:
        own = "FEMeshParams"
        for name, unit in (("surface_cell", "mm"), ("contact_half_width", "mm"), ("penalty", "N/mm^3")):
            object.__setattr__(self, name, _pos(own, name, getattr(self, name), unit))
        for name in ("skin_layers", "tissue_layers", "top_cells"):
            object.__setattr__(self, name, integer(f"{own}.{name}", getattr(self, name), 1))

    def to_dict(self) -> dict:
        return asdict(self)

    def refined(self, factor: float) -> FEMeshParams:
        """The same mesh with every element count times ``factor`` (sizes divided by it)."""
        return FEMeshParams(
            surface_cell=self.surface_cell / factor, contact_half_width=self.contact_half_width,
            skin_layers=max(1, round(self.skin_layers * factor)),
            tissue_layers=max(1, round(self.tissue_layers * factor)),
            top_cells=max(1, round(self.top_cells * factor)), penalty=self.penalty)


def params_key(*parts) -> str:
    """A stable hex digest of JSON-serialisable parts (the cache key of a table)."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


#: A layered fingertip of literature values (docs/mechanics-fe.md: the sources and the ranges).
LITERATURE_FINGER = FEFingerParams(name="layered fingertip (literature values)")

#: The same outline, homogeneous (skin as soft as the pulp): the verification finger.
HOMOGENEOUS_FINGER = FEFingerParams(skin_modulus=0.02, name="homogeneous fingertip")
