"""How smoothly a trajectory runs under the time law, measured alike for every method: joint direction reversals
per second of motion and the peak joint acceleration."""

from __future__ import annotations

import numpy as np

from .time_law import JointLimits, PathMotion
from .trajectory import Trajectory

# [rad] joint changes below this do not count as a direction (numerical noise of a planner's waypoints)
STILL_JOINT = 1e-6


def smoothness(traj: Trajectory, limits: JointLimits) -> dict[str, float]:
    """``{"reversals_per_s", "peak_joint_acceleration"}``: the number of times any joint turns back (its moving
    direction flips from one moving segment of it to its next) per second of motion, and the largest joint
    acceleration [rad/s^2] of the timed motion."""
    motion = PathMotion(traj.waypoints, limits)
    duration = motion.duration
    return {"reversals_per_s": _reversals(traj.waypoints) / duration if duration > 0 else 0.0,
            "peak_joint_acceleration": motion.peak_acceleration()}


def _reversals(waypoints: np.ndarray) -> int:
    """How often any joint turns back: its moving direction flips from one moving segment of it to its next."""
    dq = np.diff(waypoints, axis=0)
    reversals = 0
    for j in range(dq.shape[1]):
        signs = np.sign(dq[np.abs(dq[:, j]) > STILL_JOINT, j])
        reversals += int(np.count_nonzero(signs[1:] != signs[:-1]))
    return reversals


def schedule_smoothness(schedule) -> dict[str, float]:
    """:func:`smoothness` of one robot's station program (a ``RobotSchedule``), measured alike: reversals over the
    waypoints of all its legs per second of motion, and the largest joint acceleration of its legs' timed motions
    (each as it runs, flying by its via points or stopping at each). For legs that stop at each via point this is
    :func:`smoothness` of the same waypoints as one trajectory."""
    duration = float(np.sum(schedule.leg_durations()))
    peak = max((m.peak_acceleration() for m in schedule.motions() if m.duration > 0), default=0.0)
    return {"reversals_per_s": _reversals(np.vstack(schedule.legs)) / duration if duration > 0 else 0.0,
            "peak_joint_acceleration": float(peak)}
