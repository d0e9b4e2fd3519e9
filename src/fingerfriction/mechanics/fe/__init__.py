"""A layered finite-element fingertip: another model family for the contact of the finger.

A 2-D plane-strain section of the fingertip in the sliding plane (a stiff skin layer over
soft pulp, a rigid bone, a nail), neo-Hookean at large deformation, pressed on the rigid
relief at a prescribed normal load (:mod:`.solver`); its mesh (:mod:`.mesh`), parameters
(:mod:`.params`) and the simulator's contact provider with its on-disk cache
(:mod:`.provider`). Finite elements from scikit-fem. Figures, sources and the choice of
library: ``docs/mechanics-fe.md``.
"""

from .mesh import FingerMesh, build_mesh
from .params import HOMOGENEOUS_FINGER, LITERATURE_FINGER, FEFingerParams, FEMeshParams
from .provider import FE_SUBJECTS, FEProvider, default_cache_dir
from .solver import FEContactSolver, FESolution, FEState

__all__ = [
    "FEFingerParams",
    "FEMeshParams",
    "LITERATURE_FINGER",
    "HOMOGENEOUS_FINGER",
    "FingerMesh",
    "build_mesh",
    "FEContactSolver",
    "FESolution",
    "FEState",
    "FEProvider",
    "FE_SUBJECTS",
    "default_cache_dir",
]
