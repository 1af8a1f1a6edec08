"""What a caller hands the env, checked before anything changes: an action, reset()'s options, a configuration."""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError, DresspackError
from ..stations.validity import MotionValidity

RESET_OPTIONS = ("welds", "goals", "start")


class InvalidActionError(DresspackError, ValueError):
    """A masked or malformed action was taken with ``invalid_action="raise"``."""


def checked_action(action, n_actions: int) -> int:
    """An action of the action space: an integer (Python, numpy, or a one-element integer array) in range;
    bools and floats are refused, as ``Discrete.contains`` does."""
    value = action
    if isinstance(action, np.ndarray) and action.size == 1 and action.ndim <= 1:
        value = action.reshape(()).item() if np.issubdtype(action.dtype, np.integer) else action
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or not 0 <= value < n_actions:
        raise InvalidActionError(f"action must be an integer in [0, {n_actions - 1}], got {action!r}")
    return int(value)


def checked_reset_options(options: dict | None, validity: MotionValidity) -> dict:
    """reset()'s options, each checked (``start`` returned as a configuration array)."""
    if options is not None and not isinstance(options, dict):
        raise ConfigError("options", f"expected a dict with keys from {list(RESET_OPTIONS)} or None, "
                                     f"got {options!r}")
    options = dict(options or {})
    unknown = sorted(set(options) - set(RESET_OPTIONS))
    if unknown:
        raise ConfigError(f"options.{unknown[0]}", f"unknown reset option; allowed: {list(RESET_OPTIONS)}")
    if "welds" in options:
        welds = options["welds"]
        if isinstance(welds, (str, bytes)) or not isinstance(welds, (list, tuple)) \
                or not all(isinstance(w, str) for w in welds):
            raise ConfigError("options.welds", f"expected a list of weld-point names, got {welds!r}")
    if "goals" in options:
        _check_goals(options, validity)
    if "start" in options:
        options["start"] = configuration(options["start"], "options.start", validity)
    return options


def _check_goals(options: dict, validity: MotionValidity) -> None:
    goals = options["goals"]
    if "welds" in options:
        raise ConfigError("options.goals", "give either welds (names) or goals (configurations), not both")
    if not isinstance(goals, dict) or not goals:
        raise ConfigError("options.goals", f"expected a non-empty mapping of weld name -> 6 joint angles [rad], "
                                           f"got {goals!r}")
    for name, q in goals.items():
        configuration(q, f"options.goals.{name}", validity)


def configuration(value, field: str, validity: MotionValidity) -> np.ndarray:
    """``value`` as a valid configuration of the robot (6 joint angles [rad]), or a ConfigError naming ``field``."""
    try:
        q = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        q = None
    if q is None or q.shape != (6,) or not validity.valid(q):
        why = validity.why_invalid(q) if q is not None and q.shape == (6,) else f"got {value!r}"
        raise ConfigError(field, f"must be 6 joint angles [rad] of a valid configuration: {why}")
    return q
