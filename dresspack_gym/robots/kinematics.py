"""Forward and inverse kinematics of a 6-axis robot: analytic for the spherical-wrist form (thesis eq. 2.3-2.5),
numeric (multi-start damped least squares, several branches) for a general joint chain.

Joint layout (thesis Figure 2.2): j1 about base z, j2/j3 about y (shoulder, elbow), j4 about the
forearm axis (x), j5 about y, j6 about the tool-plate axis (x). The chain, in the base frame, is

    Rz(j1) T(a1,0,d1) Ry(j2) T(0,0,a2) Ry(j3) T(0,0,a3) Rx(j4) T(d4,0,0) Ry(j5) Rx(j6) T(d6,0,0) T_tcp

which is exactly the body tree built in :mod:`dresspack_gym.robots.model`, so MuJoCo and this module
agree by construction (checked in the tests).
"""

from __future__ import annotations

import numpy as np

from ..errors import KinematicsError
from .config import Kinematics, RobotConfig
from .joint_limits import LIMIT_TOL, within_limits


def rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rpy_matrix(rpy) -> np.ndarray:
    """Fixed-axis roll-pitch-yaw (x, then y, then z) rotation matrix."""
    return rot_z(rpy[2]) @ rot_y(rpy[1]) @ rot_x(rpy[0])


def homogeneous(rot: np.ndarray, pos) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = rot
    t[:3, 3] = pos
    return t


def axis_rotations(axis, a: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations by angles ``a`` (n,) about one unit ``axis`` (Rodrigues)."""
    x, y, z = axis
    c, s = np.cos(a), np.sin(a)
    v = 1 - c
    return np.stack([np.stack([c + x * x * v, x * y * v - z * s, x * z * v + y * s], -1),
                     np.stack([y * x * v + z * s, c + y * y * v, y * z * v - x * s], -1),
                     np.stack([z * x * v - y * s, z * y * v + x * s, c + z * z * v], -1)], -2)


# Numeric IK of a general chain: starts spread over the joint limits (fixed, so results are reproducible), damped
# least squares until the flange pose is met to IK_TOL; distinct solutions are the branches.
IK_STARTS = 128
IK_ITERATIONS = 60
IK_TOL = 1e-10  # [m] and [rad]
IK_DAMPING = 1e-3


def wrap_angle(a):
    """Wrap to (-pi, pi]."""
    return -((-np.asarray(a) + np.pi) % (2 * np.pi) - np.pi)


class RobotKinematics:
    """FK/IK for one robot placed in the world at ``base_pos`` rotated by ``base_yaw`` about z."""

    def __init__(self, robot: RobotConfig, base_pos=(0.0, 0.0, 0.0), base_yaw: float = 0.0):
        self.robot = robot
        self.k: Kinematics = robot.kinematics
        self.base = homogeneous(rot_z(base_yaw), base_pos)
        self.base_inv = np.linalg.inv(self.base)
        self.tcp = homogeneous(rpy_matrix(robot.tcp_rpy), robot.tcp_pos)
        self.tcp_inv = np.linalg.inv(self.tcp)
        self.limits = robot.joint_limits
        self.chain = robot.chain
        if self.chain is not None:
            self._fixed = [homogeneous(rpy_matrix(r), o) for o, r in zip(self.chain.origins, self.chain.rpys)]
            self._axes = [np.asarray(a, dtype=float) for a in self.chain.axes]
            self._flange = homogeneous(rpy_matrix(self.chain.flange_rpy), self.chain.flange_pos)
            self._starts = np.random.default_rng(0).uniform(self.limits[:, 0], self.limits[:, 1], (IK_STARTS, 6))

    # ----------------------------------------------------------------------------- forward
    def link_frames(self, q) -> list[np.ndarray]:
        """World frames of base, link1..link6 (link6 = wrist centre, rotated by j6) and the flange."""
        q = np.asarray(q, dtype=float)
        if self.chain is not None:
            frames = [self.base]
            t = self.base
            for fixed, axis, a in zip(self._fixed, self._axes, q):
                t = t @ fixed @ homogeneous(axis_rotations(axis, np.array([a]))[0], (0, 0, 0))
                frames.append(t)
            frames.append(t @ self._flange)
            return frames
        k = self.k
        frames = [self.base]
        t = self.base @ homogeneous(rot_z(q[0]), (0, 0, 0))
        frames.append(t)
        t = t @ homogeneous(rot_y(q[1]), (k.a1, 0, k.d1))
        frames.append(t)
        t = t @ homogeneous(rot_y(q[2]), (0, 0, k.a2))
        frames.append(t)
        t = t @ homogeneous(rot_x(q[3]), (0, 0, k.a3))
        frames.append(t)
        t = t @ homogeneous(rot_y(q[4]), (k.d4, 0, 0))
        frames.append(t)
        t = t @ homogeneous(rot_x(q[5]), (0, 0, 0))
        frames.append(t)
        frames.append(t @ homogeneous(np.eye(3), (k.d6, 0, 0)))
        return frames

    def flange(self, q) -> np.ndarray:
        return self.link_frames(q)[-1]

    def tcp_pose(self, q) -> np.ndarray:
        """World pose (4x4) of the tool centre point; its z axis is the tool approach direction."""
        return self.flange(q) @ self.tcp

    # ----------------------------------------------------------------------------- inverse
    def ik_flange(self, target: np.ndarray, *, within_limits: bool = True) -> np.ndarray:
        """All (up to 8) joint solutions placing the flange at ``target`` (4x4, world frame).

        Branches: front/back (j1 and j1+pi), elbow up/down, wrist flip (j5 sign). j4 and j6 are
        returned in (-pi, pi]; :meth:`expand_turns` adds the +-2pi equivalents a wide-range wrist allows.
        A general chain is solved numerically (:meth:`_numeric_ik`): the branches its starts converge to.
        """
        if self.chain is not None:
            sols = self._numeric_ik(np.asarray(target, dtype=float))
            return self.expand_turns(sols) if within_limits and len(sols) else sols
        k = self.k
        t = self.base_inv @ np.asarray(target, dtype=float)
        r, p = t[:3, :3], t[:3, 3]
        w = p - r[:, 0] * k.d6  # wrist centre: flange is d6 along the flange x axis
        l3 = np.hypot(k.d4, k.a3)
        phi = np.arctan2(k.a3, k.d4)
        sols = []
        rho = np.hypot(w[0], w[1])
        for front in (True, False):
            if rho < 1e-9:
                j1 = 0.0 if front else np.pi  # on the j1 axis: j1 is free, pick a representative
            else:
                j1 = np.arctan2(w[1], w[0]) + (0.0 if front else np.pi)
            x = (rho if front else -rho) - k.a1
            z = w[2] - k.d1
            dsq = x * x + z * z
            s = (dsq - k.a2 ** 2 - l3 ** 2) / (2 * k.a2 * l3)
            if s > 1 + 1e-12 or s < -1 - 1e-12:
                continue
            s = float(np.clip(s, -1.0, 1.0))
            for elbow in (np.arcsin(s), np.pi - np.arcsin(s)):
                j3 = phi - elbow
                beta = j3 - phi
                a = k.a2 - l3 * np.sin(beta)
                b = l3 * np.cos(beta)
                j2 = np.arctan2(a * x - b * z, a * z + b * x)
                r03 = rot_z(j1) @ rot_y(j2 + j3)
                m = r03.T @ r  # = Rx(j4) Ry(j5) Rx(j6)
                c5 = float(np.clip(m[0, 0], -1.0, 1.0))
                j5a = np.arccos(c5)
                if np.sin(j5a) < 1e-9:  # wrist singular: only j4 + j6 (or j4 - j6) is defined
                    j4 = 0.0
                    j6 = np.arctan2(m[2, 1], m[1, 1]) if c5 > 0 else np.arctan2(-m[2, 1], m[1, 1])
                    wrists = [(j4, j5a, j6), (np.pi, -j5a, wrap_angle(j6 + np.pi))]
                else:
                    j4 = np.arctan2(m[1, 0], -m[2, 0])
                    j6 = np.arctan2(m[0, 1], m[0, 2])
                    wrists = [(j4, j5a, j6), (wrap_angle(j4 + np.pi), -j5a, wrap_angle(j6 + np.pi))]
                for j4_, j5_, j6_ in wrists:
                    sols.append(wrap_angle(np.array([j1, j2, j3, j4_, j5_, j6_])))
        sols = np.array(sols).reshape(-1, 6)
        if within_limits and len(sols):
            sols = self.expand_turns(sols)
        return sols

    def flange_jacobian(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A general chain's flange poses (n, 4, 4) and geometric Jacobians (n, 6, 6) (rows: linear then angular
        velocity of the flange; columns: joints) at configurations (n, 6)."""
        pose, axes, anchors = self._batch_flange(qs)
        jac = np.concatenate([np.cross(axes, pose[:, None, :3, 3] - anchors), axes], axis=2)  # (n, joints, 6)
        return pose, np.transpose(jac, (0, 2, 1))

    def _batch_flange(self, qs: np.ndarray):
        """Flange poses (n, 4, 4) and the joints' world axes and anchors (n, 6, 3) of configurations (n, 6)."""
        n = len(qs)
        t = np.repeat(self.base[None], n, axis=0)
        axes, anchors = np.zeros((n, 6, 3)), np.zeros((n, 6, 3))
        for i, (fixed, axis) in enumerate(zip(self._fixed, self._axes)):
            t = t @ fixed
            axes[:, i] = t[:, :3, :3] @ axis
            anchors[:, i] = t[:, :3, 3]
            rot = np.zeros((n, 4, 4))
            rot[:, :3, :3] = axis_rotations(axis, qs[:, i])
            rot[:, 3, 3] = 1.0
            t = t @ rot
        return t @ self._flange, axes, anchors

    def _numeric_ik(self, target: np.ndarray) -> np.ndarray:
        q = self._starts.copy()
        for _ in range(IK_ITERATIONS):
            pose, jac = self.flange_jacobian(q)
            dp = target[:3, 3] - pose[:, :3, 3]
            r = target[:3, :3] @ np.transpose(pose[:, :3, :3], (0, 2, 1))  # remaining rotation, world frame
            dw = 0.5 * np.stack([r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]], -1)
            err = np.concatenate([dp, dw], axis=1)
            if np.all(np.abs(err).max(axis=1) < IK_TOL):
                break
            jjt = jac @ np.transpose(jac, (0, 2, 1)) + IK_DAMPING ** 2 * np.eye(6)
            step = np.einsum("nji,nj->ni", jac, np.linalg.solve(jjt, err[..., None])[..., 0])
            q = q + np.clip(step, -0.5, 0.5)
        pose, _, _ = self._batch_flange(q)
        ok = (np.abs(pose[:, :3, 3] - target[:3, 3]).max(axis=1) < 1e-9) & \
             (np.abs(pose[:, :3, :3] - target[:3, :3]).max(axis=(1, 2)) < 1e-9)
        kept: list[np.ndarray] = []
        for sol in wrap_angle(q[ok]):  # starts that met the same branch agree to ~1e-10 rad
            d = [np.abs(wrap_angle(sol - k)).max() for k in kept]
            if not d or min(d) > 1e-6:
                kept.append(sol)
        return np.array(kept).reshape(-1, 6)

    def ik(self, tcp_target: np.ndarray, *, within_limits: bool = True) -> np.ndarray:
        """All joint solutions placing the TCP at ``tcp_target`` (4x4 world pose)."""
        return self.ik_flange(np.asarray(tcp_target) @ self.tcp_inv, within_limits=within_limits)

    def expand_turns(self, sols: np.ndarray) -> np.ndarray:
        """Keep solutions inside the joint limits, adding +-2pi variants of every joint that allows them."""
        out = []
        lim = self.limits
        for q in sols:
            options = []
            for j in range(6):
                cands = [q[j] + 2 * np.pi * n for n in (-1, 0, 1)]
                options.append([c for c in cands if lim[j, 0] - LIMIT_TOL <= c <= lim[j, 1] + LIMIT_TOL])
            if any(len(o) == 0 for o in options):
                continue
            grids = np.meshgrid(*options, indexing="ij")
            out.extend(np.stack([g.ravel() for g in grids], axis=1))
        if not out:
            return np.zeros((0, 6))
        out = np.array(out)
        _, idx = np.unique(np.round(out, 9), axis=0, return_index=True)
        return out[np.sort(idx)]

    def within_limits(self, q) -> np.ndarray:
        return within_limits(q, self.limits)


def weld_pose(pos, approach, spin: float) -> np.ndarray:
    """TCP pose whose z axis is ``approach`` (the gun moves along it into the part), spun about it."""
    z = np.asarray(approach, dtype=float)
    z = z / np.linalg.norm(z)
    ref = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(ref, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    rot = np.stack([x, y, z], axis=1) @ rot_z(spin)
    return homogeneous(rot, pos)


def weld_configurations(kin: RobotKinematics, weld) -> np.ndarray:
    """All joint configurations within limits that reach a weld point, over its spin candidates."""
    sols = [kin.ik(weld_pose(weld.pos, weld.approach, s)) for s in weld.spin]
    sols = [s for s in sols if len(s)]
    if not sols:
        raise KinematicsError(f"weld point {weld.name!r} at {tuple(round(v, 3) for v in weld.pos)} is not "
                              f"reachable by robot {weld.robot!r} within its joint limits")
    return np.concatenate(sols, axis=0)
