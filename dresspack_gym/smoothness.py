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
    dq = np.diff(traj.waypoints, axis=0)
    motion = PathMotion(traj.waypoints, limits)
    duration = motion.duration
    reversals = 0
    for j in range(dq.shape[1]):
        signs = np.sign(dq[np.abs(dq[:, j]) > STILL_JOINT, j])
        reversals += int(np.count_nonzero(signs[1:] != signs[:-1]))
    return {"reversals_per_s": reversals / duration if duration > 0 else 0.0,
            "peak_joint_acceleration": motion.peak_acceleration()}
