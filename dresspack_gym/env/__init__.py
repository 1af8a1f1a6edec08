"""The Gymnasium environment: a robot carrying a simulated dresspack through a weld cycle, with masked actions."""

from .config import EnvConfig
from .dresspack_env import DresspackEnv

__all__ = ["DresspackEnv", "EnvConfig"]
