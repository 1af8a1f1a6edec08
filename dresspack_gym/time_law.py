"""The robots' time law on a straight joint-space segment: a cubic (smoothstep), at rest at both ends."""

from __future__ import annotations

import numpy as np

# The cubic s(t) = 3 t^2 - 2 t^3 peaks at 1.5x its mean speed: a segment lasts 1.5x the time the slowest joint
# needs at its allowed speed, so no joint ever exceeds that speed.
CUBIC_PEAK_FACTOR = 1.5


def segment_durations(dq: np.ndarray, speeds: np.ndarray) -> np.ndarray:
    """Seconds per segment for joint changes ``dq`` (..., n_joints) at peak joint ``speeds`` [rad/s]."""
    return CUBIC_PEAK_FACTOR * np.max(np.abs(dq) / np.asarray(speeds), axis=-1)


def path_duration(waypoints: np.ndarray, speeds: np.ndarray) -> float:
    """Seconds to run a path (K, n_joints) of straight segments, stopping at every waypoint."""
    return float(segment_durations(np.diff(np.asarray(waypoints, dtype=float), axis=0), speeds).sum())


def cubic_position(tau: np.ndarray) -> np.ndarray:
    """Fraction of the segment covered at normalised time ``tau`` in [0, 1]."""
    return 3 * tau ** 2 - 2 * tau ** 3


def cubic_speed(tau: np.ndarray, duration: float) -> np.ndarray:
    """d(fraction)/dt [1/s] at normalised time ``tau`` of a segment lasting ``duration`` seconds."""
    return (6 * tau - 6 * tau ** 2) / duration
