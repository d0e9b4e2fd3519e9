"""The paper's model and the analyses made with it, which both the fit
(:mod:`fingerfriction.fit`, Eq. 5) and the prediction (:mod:`fingerfriction.predict`) use:

* :mod:`.friction`: the friction model, Eq. 1-4 of Janko et al. 2018 (re-exported here:
  ``from fingerfriction.model import FrictionModel``);
* :mod:`.blindspots`: the contact occupancy map and the tactile blind spots (Fig. 3);
* :mod:`.stats`: the detrended correlations of friction with the blind spots (Table 1).
"""

from .friction import *  # noqa: F403 - the friction model's public names, listed once in its __all__
from .friction import __all__  # noqa: F401
