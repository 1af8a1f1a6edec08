"""Checks every robot model must pass, as numbers: forward/inverse kinematics round trips over random poses and
the inverse kinematics branches found (``dresspack robots`` prints them as a table)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import RobotConfig
from .kinematics import RobotKinematics

WRIST_SINGULAR = 1e-3  # |sin j5| below this: the wrist is singular, j4 and j6 are not separately defined
SHOULDER_SINGULAR = 1e-3  # [m] wrist centre this near the j1 axis: j1 is free
# A general chain has no closed-form singularity list: a pose whose flange Jacobian's smallest singular value is
# below this [m or 1 per rad] is near-singular (its IK branches merge), and is skipped like the ones above.
CHAIN_SINGULAR = 1e-3


@dataclass(frozen=True)
class IkRoundTrip:
    """FK(q) = T for random q within the limits; every IK solution of T must reproduce T, and q must be among them."""

    robot: str
    poses: int  # non-singular poses checked
    max_pose_error: float  # [m, rad of the rotation matrix entries] over every solution of every pose
    max_joint_error: float  # [rad] of the solution nearest the sampled q
    mean_branches: float  # solutions within the limits per pose (turns of j4/j6 included)
    max_raw_branches: int  # analytic branches before limits (8 = front/back x elbow x wrist flip)
    found_q: bool  # the sampled q was among the solutions every time

    def row(self) -> dict:
        return {"robot": self.robot, "poses": self.poses, "max_pose_error": self.max_pose_error,
                "max_joint_error": self.max_joint_error, "mean_branches": round(self.mean_branches, 2),
                "max_raw_branches": self.max_raw_branches, "found_q": self.found_q}


def _singular(kin: RobotKinematics, q: np.ndarray, base_pos) -> bool:
    if kin.chain is not None:
        _, jac = kin.flange_jacobian(q[None])
        return bool(np.linalg.svd(jac[0], compute_uv=False).min() < CHAIN_SINGULAR)
    wrist = kin.link_frames(q)[5][:3, 3] - np.asarray(base_pos)
    return abs(np.sin(q[4])) < WRIST_SINGULAR or np.hypot(wrist[0], wrist[1]) < SHOULDER_SINGULAR


def ik_round_trip(robot: RobotConfig, poses: int = 1000, seed: int = 0, base_pos=(0.0, 0.0, 0.0),
                  base_yaw: float = 0.0, progress=None) -> IkRoundTrip:
    """The round trip over ``poses`` random configurations; ``progress``, a tqdm-like bar, counts them."""
    kin = RobotKinematics(robot, base_pos, base_yaw)
    rng = np.random.default_rng(seed)
    lim = kin.limits
    pose_err, joint_err, branches, raw_max, found, checked = 0.0, 0.0, [], 0, True, 0
    for q in rng.uniform(lim[:, 0], lim[:, 1], size=(poses, 6)):
        if progress is not None:
            progress.update(1)
        if _singular(kin, q, base_pos):
            continue
        target = kin.tcp_pose(q)
        sols = kin.ik(target)
        raw_max = max(raw_max, len(kin.ik(target, within_limits=False)))
        branches.append(len(sols))
        if len(sols) == 0:
            found = False
            continue
        pose_err = max(pose_err, max(float(np.abs(kin.tcp_pose(s) - target).max()) for s in sols))
        nearest = float(np.min(np.max(np.abs(sols - q), axis=1)))
        joint_err = max(joint_err, nearest)
        found = found and nearest < 1e-6
        checked += 1
    return IkRoundTrip(robot.name, checked, pose_err, joint_err, float(np.mean(branches)) if branches else 0.0,
                       raw_max, found)
