"""fingerfriction: contact geometry, tactile blind spots and friction of a finger sliding
over relief surfaces (Janko, Wiertlewski & Visell, Sci. Rep. 2018), with a forward
finger-contact model and a virtual experiment.

Stages, in the order a trial flows through them: :mod:`~fingerfriction.surfaces`,
:mod:`~fingerfriction.regions`, :mod:`~fingerfriction.mechanics`, :mod:`~fingerfriction.sim`
(the virtual experiment), :mod:`~fingerfriction.video`, :mod:`~fingerfriction.forces`,
:mod:`~fingerfriction.model`, :mod:`~fingerfriction.fit`, :mod:`~fingerfriction.model.stats`,
:mod:`~fingerfriction.model.blindspots`, :mod:`~fingerfriction.study` (manifest, results store,
one trial, the parallel analysis, the fit), :mod:`~fingerfriction.predict`,
:mod:`~fingerfriction.report`, :mod:`~fingerfriction.demo`; ``docs/`` has one page per
stage with the reasoning and measured figures behind its choices.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("fingerfriction")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

from .model import FrictionModel, FrictionParams, friction_force
from .model.blindspots import blind_spots, occupancy
from .surfaces import SURFACE_NAMES, RaisedCosine, SampledProfile, get_surface, surface_from_spec

__all__ = [
    "__version__",
    "SURFACE_NAMES",
    "RaisedCosine",
    "SampledProfile",
    "get_surface",
    "surface_from_spec",
    "FrictionParams",
    "FrictionModel",
    "friction_force",
    "blind_spots",
    "occupancy",
]
