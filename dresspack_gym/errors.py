"""Error types: one base class so callers can catch everything dresspack-gym raises on purpose."""


class DresspackError(Exception):
    """Base class of all errors raised deliberately by dresspack-gym."""


class ConfigError(DresspackError, ValueError):
    """A configuration value is missing, unknown, of the wrong type or out of range.

    The message always starts with the dotted path of the offending field
    (e.g. ``dresspack.length``) so that a user can find it in the YAML file.
    """

    def __init__(self, field: str, message: str):
        self.field = field
        super().__init__(f"{field}: {message}")


class KinematicsError(DresspackError):
    """A pose cannot be reached or a kinematic query is ill-posed."""


class SimulationError(DresspackError):
    """The physics produced an invalid state (NaN, diverged constraint, ...)."""


class EnvUsageError(DresspackError, RuntimeError):
    """The environment's API was used out of order: a step before ``reset`` or after the episode ended."""
