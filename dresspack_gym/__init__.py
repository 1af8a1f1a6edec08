"""dresspack-gym: wear-aware motion planning for industrial robots with simulated cable dresspacks."""

from .errors import ConfigError, DresspackError, KinematicsError, SimulationError

__version__ = "0.1.0"

__all__ = ["ConfigError", "DresspackError", "KinematicsError", "SimulationError", "__version__"]
