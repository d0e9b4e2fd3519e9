"""The virtual experiment: simulated recordings of the paper's study with known truth.

Modules, in the order a simulated trial is produced:

* :mod:`~fingerfriction.sim.contact` -- contact tables (deformed finger outline and
  pressure per finger position and load) from a contact provider;
* :mod:`~fingerfriction.sim.kinematics` -- x(t), F_N(t) of a human-like slide;
* :mod:`~fingerfriction.sim.worlds` -- the true physics (``load-sharing``,
  ``constant-pressure``, ``interlocking``; the first is :mod:`~fingerfriction.sim.physics`'s
  force law);
* :mod:`~fingerfriction.sim.chain` -- the measurement chain (``ideal``, ``realistic``:
  the participant's normal force, the sensor's unknown response);
* :mod:`~fingerfriction.sim.sensor` -- the two-channel piezo force sensor;
* :mod:`~fingerfriction.sim.camera` -- silhouette frames of the high-speed camera;
* :mod:`~fingerfriction.sim.options` -- what to simulate (:class:`SimOptions`), the trials' streams;
* :mod:`~fingerfriction.sim.writer` -- the study directory (``docs/study-format.md``).
"""

from .camera import Camera, CameraParams
from .chain import CHAIN_NAMES, RealisticChain
from .contact import SIM_SUBJECTS, ContactTable, SimFinger, build_table
from .kinematics import KinematicsParams, simulate_kinematics
from .physics import SUBJECT_FORCE_LAWS, ForceLaw, RealismParams, true_forces
from .sensor import SensorParams, apply_sensor, from_channels, to_channels
from .worlds import WORLD_NAMES, ConstantPressure, Interlocking, LoadSharing, get_world
from .writer import SimOptions, StudyFolderError, plan_trial, simulate_study, simulate_trial

__all__ = [
    "CHAIN_NAMES",
    "Camera",
    "CameraParams",
    "ConstantPressure",
    "ContactTable",
    "ForceLaw",
    "Interlocking",
    "KinematicsParams",
    "LoadSharing",
    "RealismParams",
    "RealisticChain",
    "SIM_SUBJECTS",
    "SUBJECT_FORCE_LAWS",
    "SensorParams",
    "SimFinger",
    "SimOptions",
    "StudyFolderError",
    "WORLD_NAMES",
    "apply_sensor",
    "build_table",
    "from_channels",
    "get_world",
    "plan_trial",
    "simulate_kinematics",
    "simulate_study",
    "simulate_trial",
    "to_channels",
    "true_forces",
]
