"""Builds a 6-axis robot into a ``mujoco.MjSpec`` with the exact body chain of :mod:`kinematics`."""

from __future__ import annotations

import mujoco
import numpy as np

from .config import RobotConfig
from .kinematics import rpy_matrix

# Contact bits shared by all builders: obstacles and robot links are hit by cables only;
# robot-obstacle collisions are queried explicitly (the robot is kinematic, contacts cannot stop it).
# Each robot's links and each robot's cable have a bit of their own, so a cable can touch the other robots and
# their cables while its own pieces never touch each other (and its own robot only if asked).
OBSTACLE_BITS = 1
MAX_ROBOTS = 8  # 1 + 2 x 8 contact bits


def robot_bits(index: int) -> int:
    """Contact bit of robot ``index``'s links."""
    return 1 << (1 + index)


def cable_bits(index: int) -> int:
    """Contact bit of robot ``index``'s cable."""
    return 1 << (1 + MAX_ROBOTS + index)


def cable_affinity(index: int, n_robots: int, own_robot: bool) -> int:
    """What robot ``index``'s cable touches: obstacles, the other robots and their cables, and (``own_robot``)
    the links of its own robot."""
    bits = OBSTACLE_BITS | (robot_bits(index) if own_robot else 0)
    for j in range(n_robots):
        if j != index:
            bits |= robot_bits(j) | cable_bits(j)
    return bits
# A kinematic robot: huge joint inertia so cable reactions cannot move it within a step, and its
# joint positions/velocities are overwritten every substep anyway.
ROBOT_ARMATURE = 1e6

ROBOT_RGBA = (0.93, 0.45, 0.1, 1.0)


def mat_to_quat(m: np.ndarray) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.asarray(m, dtype=float).ravel())
    return q


def body_name(robot: str, link: str) -> str:
    return f"{robot}/{link}"


def joint_name(robot: str, j: int) -> str:
    return f"{robot}/j{j + 1}"


def add_robot(spec: mujoco.MjSpec, name: str, robot: RobotConfig, base_pos, base_yaw: float, index: int = 0) -> None:
    """Add base, link1..link6, flange and TCP sites of robot number ``index`` (named ``name``, its base at
    ``base_pos`` turned by ``base_yaw`` about z) to ``spec``."""
    lim = robot.joint_limits
    base = spec.worldbody.add_body(name=body_name(name, "base"), pos=list(base_pos),
                                   quat=list(mat_to_quat(_rz(base_yaw))))
    c = robot.chain if robot.chain is not None else robot.kinematics.joint_chain()
    links = [(o, rpy_matrix(r), a) for o, r, a in zip(c.origins, c.rpys, c.axes)]  # (parent offset, rotation, axis)
    flange = np.eye(4)
    flange[:3, :3], flange[:3, 3] = rpy_matrix(c.flange_rpy), c.flange_pos
    bodies = {"base": base}
    parent = base
    for j, (offset, rot, axis) in enumerate(links):
        link = f"link{j + 1}"
        b = parent.add_body(name=body_name(name, link), pos=list(offset), quat=list(mat_to_quat(rot)))
        b.gravcomp = 1.0
        b.mass = 1.0
        b.inertia = [0.1, 0.1, 0.1]
        b.explicitinertial = True
        b.add_joint(name=joint_name(name, j), type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(axis),
                    armature=ROBOT_ARMATURE, range=list(lim[j]), limited=mujoco.mjtLimited.mjLIMITED_FALSE)
        bodies[link] = b
        parent = b
    bodies["link6"].add_site(name=f"{name}/flange", pos=list(flange[:3, 3]), quat=list(mat_to_quat(flange[:3, :3])),
                             size=[0.02, 0, 0])
    tcp = flange[:3, :3] @ rpy_matrix(robot.tcp_rpy)
    tcp_pos = flange[:3, 3] + flange[:3, :3] @ np.asarray(robot.tcp_pos)
    bodies["link6"].add_site(name=f"{name}/tcp", pos=list(tcp_pos), quat=list(mat_to_quat(tcp)),
                             size=[0.015, 0, 0], rgba=[1, 0, 0, 1])
    for i, prim in enumerate(robot.collision):
        g = bodies[prim.link].add_geom(name=f"{name}/{prim.link}_geom{i}", rgba=list(ROBOT_RGBA))
        g.contype = robot_bits(index)
        g.conaffinity = 0
        if prim.type == "mesh":  # the convex hull of the maker's collision mesh (MuJoCo collides hulls)
            spec.add_mesh(name=f"{name}/mesh{i}", file=prim.mesh_file, scale=list(prim.mesh_scale))
            g.type, g.meshname = mujoco.mjtGeom.mjGEOM_MESH, f"{name}/mesh{i}"
            g.pos, g.quat = list(prim.pos), list(mat_to_quat(rpy_matrix(prim.rpy)))
            continue
        _set_primitive(g, prim.type, prim.size, prim.pos, prim.rpy, prim.fromto)


def _rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _set_primitive(g, kind: str, size, pos, rpy, fromto) -> None:
    """Fill a geom spec from a primitive description (shared by robot links and obstacles)."""
    types = {"box": mujoco.mjtGeom.mjGEOM_BOX, "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
             "sphere": mujoco.mjtGeom.mjGEOM_SPHERE, "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
             "plane": mujoco.mjtGeom.mjGEOM_PLANE}
    g.type = types[kind]
    if fromto is not None:
        a, b = np.asarray(fromto[:3], float), np.asarray(fromto[3:], float)
        axis = b - a
        half = np.linalg.norm(axis) / 2
        z = axis / max(np.linalg.norm(axis), 1e-12)
        g.pos = list((a + b) / 2)
        g.quat = list(_quat_z_to(z))
        g.size = [size[0], half, 0]
        return
    padded = list(size) + [0.0] * (3 - len(size))
    g.size = padded
    g.pos = list(pos)
    g.quat = list(mat_to_quat(rpy_matrix(rpy)))


def _quat_z_to(z: np.ndarray) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_quatZ2Vec(q, np.asarray(z, dtype=float))
    return q
