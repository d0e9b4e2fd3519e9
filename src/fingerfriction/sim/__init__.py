"""The virtual experiment: simulated recordings of the paper's study with known truth.

Modules, in the order a simulated trial is produced:

* :mod:`~fingerfriction.sim.contact` -- contact tables (deformed finger outline and
  pressure per finger position and load) from a contact provider;
* :mod:`~fingerfriction.sim.kinematics` -- x(t), F_N(t) of a human-like slide;
* :mod:`~fingerfriction.sim.physics` -- the true tangential force law;
* :mod:`~fingerfriction.sim.sensor` -- the two-channel piezo force sensor;
* :mod:`~fingerfriction.sim.camera` -- silhouette frames of the high-speed camera;
* :mod:`~fingerfriction.sim.writer` -- the study directory (``docs/study-format.md``).
"""

from .camera import Camera, CameraParams
from .contact import SIM_SUBJECTS, ContactTable, SimFinger, build_table
from .kinematics import KinematicsParams, simulate_kinematics
from .physics import SUBJECT_FORCE_LAWS, ForceLaw, RealismParams, true_forces
from .sensor import SensorParams, apply_sensor, from_channels, to_channels
from .writer import SimOptions, StudyFolderError, plan_trial, simulate_study, simulate_trial

__all__ = [
    "Camera",
    "CameraParams",
    "ContactTable",
    "ForceLaw",
    "KinematicsParams",
    "RealismParams",
    "SIM_SUBJECTS",
    "SUBJECT_FORCE_LAWS",
    "SensorParams",
    "SimFinger",
    "SimOptions",
    "StudyFolderError",
    "apply_sensor",
    "build_table",
    "from_channels",
    "plan_trial",
    "simulate_kinematics",
    "simulate_study",
    "simulate_trial",
    "to_channels",
    "true_forces",
]
