"""Robots in and out of URDF/MJCF: derive the spherical-wrist (OPW, b = 0) parameters, axis signs and zeros of a
6R arm from its model file, and write a parametric robot as URDF or MJCF.

MuJoCo reads both formats. The importer takes the model's six hinge joints in chain order at the model's zero pose
and reads off, in the frame of the chain's root body: the shoulder offset a1 and height d1 (j2's anchor), the upper
arm a2, the forearm offset a3 and length d4 (to the wrist centre, where j4, j5 and j6 meet), the flange distance
d6, and how each model joint relates to ours (``controller_axes``: the model's joint = sign * ours + offset). Our
zero is the upper arm vertical and the forearm horizontal, joints about +z, +y, +y, +x, +y, +x; a model drawn with
the arm horizontal at zero (KUKA) gets a -90 deg offset on j2 and +90 deg on j3. An arm that is not of this form
(no spherical wrist, a sideways offset b, axes not parallel/orthogonal) becomes a general joint chain, solved by
numeric IK (``kinematics.RobotKinematics``); an arm that is not a serial 6R chain is refused with the reason.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np

from ..errors import ConfigError
from .config import JointChain, Kinematics, RobotConfig
from .kinematics import RobotKinematics, homogeneous, rpy_matrix

# Published URDFs round pi/2 to 5 decimals (1.57076: 3.7e-5 rad off), so "parallel" and "meet" are judged to
# 1e-4 (rad, m); the derived lengths keep the file's own values.
AXIS_TOL = 1e-4  # |cos| / |sin| of an angle between axes that must be parallel or orthogonal
POINT_TOL = 1e-4  # [m] axes that must meet, offsets that must vanish


def read_xml(path: str | Path, field: str = "model_file") -> ET.Element:
    """The root element of a URDF or MJCF file, refused with what is wrong with its XML: a robot model declares
    no document type or entities (an entity declaration can expand without bound, and MuJoCo would not expand
    them as this parser does), and parses."""
    path = Path(path)
    data = path.read_bytes()
    head = data[:65536].upper()
    if b"<!DOCTYPE" in head or b"<!ENTITY" in data.upper():
        raise ConfigError(field, f"{path.name}: the XML declares a document type or entities (<!DOCTYPE ...>, "
                                 f"<!ENTITY ...>), which a URDF or MJCF robot model does not use: refused (remove "
                                 f"the declaration and write the values out)")
    try:
        return ET.fromstring(data)
    except ET.ParseError as exc:
        raise ConfigError(field, f"{path.name} is not well-formed XML: {exc}") from None


def _check_urdf_limits(root: ET.Element, path: Path, field: str) -> None:
    """A revolute joint's ``<limit lower upper>`` must be numbers with lower <= upper (MuJoCo would otherwise
    drop the limit and leave the joint free a full turn either way)."""
    if root.tag != "robot":
        return  # MJCF: MuJoCo refuses a reversed range itself
    for joint in root.iter("joint"):
        limit = joint.find("limit")
        if joint.get("type") != "revolute" or limit is None:
            continue
        name = joint.get("name", "?")
        values = {}
        for key in ("lower", "upper"):
            text = limit.get(key, "0")
            try:
                values[key] = float(text)
            except ValueError:
                raise ConfigError(field, f"{path.name}: joint {name!r} has {key}={text!r}, not a number") from None
            if not math.isfinite(values[key]):
                raise ConfigError(field, f"{path.name}: joint {name!r} has {key}={text!r}, not a finite number")
        if values["lower"] > values["upper"]:
            raise ConfigError(field, f"{path.name}: joint {name!r} has lower limit {values['lower']:g} > upper "
                                     f"limit {values['upper']:g} rad: swapped limits are refused, not reordered")


def load_model(path: str | Path) -> mujoco.MjModel:
    """Compile a URDF or MJCF file; its meshes are not needed (visual and collision geometry is dropped)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError("model_file", f"file not found: {path}")
    _check_urdf_limits(read_xml(path), path, "model_file")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as exc:
        raise ConfigError("model_file", f"{path.name} is not a URDF or MJCF file MuJoCo can read: {exc}") from None
    for mesh in list(spec.meshes):  # geometry is ours to choose; the kinematics is all we take
        spec.delete(mesh)
    for geom in list(spec.geoms):
        spec.delete(geom)
    for body in spec.bodies[1:]:  # the kinematics does not depend on inertia; published values are not always valid
        body.mass, body.inertia, body.explicitinertial = 1.0, [0.1, 0.1, 0.1], True
        body.fullinertia = [math.nan] * 6
        body.ipos, body.iquat = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]
    try:
        return spec.compile()
    except Exception as exc:
        raise ConfigError("model_file", f"{path.name} does not compile: {exc}") from None


class NotSphericalWrist(ConfigError):
    """The arm is a serial 6R chain, but not of the spherical-wrist form the analytic IK solves."""


def _hinges(m: mujoco.MjModel, field: str) -> list[int]:
    joints = [j for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    if len(joints) != 6 or any(m.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE for j in range(m.njnt)):
        raise ConfigError(field, f"expected an arm of exactly 6 revolute joints and no other joint, found "
                                 f"{len(joints)} revolute of {m.njnt}")
    bodies = [int(m.jnt_bodyid[j]) for j in joints]
    for parent, child in zip(bodies, bodies[1:]):
        b = child
        while b not in (parent, 0):
            b = int(m.body_parentid[b])
        if b != parent:
            raise ConfigError(field, "the 6 revolute joints are not one serial chain")
    return joints


def derive(m: mujoco.MjModel, field: str = "model_file") -> tuple[Kinematics, np.ndarray, np.ndarray, np.ndarray]:
    """(kinematics, sign (6,), offset (6,) [rad], joint limits in our convention (6, 2) [rad]) of a 6R arm."""
    joints = _hinges(m, field)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    root = int(m.body_parentid[m.jnt_bodyid[joints[0]]])
    r0, p0 = d.xmat[root].reshape(3, 3), d.xpos[root]
    anchor = [(d.xanchor[j] - p0) @ r0 for j in joints]  # in the root body's frame
    axis = [r0.T @ d.xaxis[j] for j in joints]
    x, y, z = np.eye(3)

    def need(ok: bool, what: str) -> None:
        if not ok:
            raise NotSphericalWrist(field, f"not a spherical-wrist arm of the supported form at its zero pose: {what}")

    need(abs(abs(axis[0] @ z) - 1) < AXIS_TOL, "j1 is not vertical")
    need(abs(anchor[0][0]) < POINT_TOL and abs(anchor[0][1]) < POINT_TOL, "j1 does not pass through the base origin")
    for k in (1, 2):
        need(abs(abs(axis[k] @ y) - 1) < AXIS_TOL, f"j{k + 1} is not along the base y axis (arm drawn in x-z)")
    p2, p3 = anchor[1], anchor[2]
    need(abs(p2[1]) < POINT_TOL and abs(p3[1] - p2[1]) < POINT_TOL, "a sideways offset (OPW b) is not supported")
    # the wrist centre: j5's axis line meets j4's and j6's
    c = _meet(anchor[3], axis[3], anchor[4], axis[4])
    need(c is not None, "j4 and j5 do not meet")
    need(_distance_to_line(c, anchor[5], axis[5]) < POINT_TOL, "j6 does not pass through the wrist centre")
    sign = np.array([np.sign(axis[0] @ z), np.sign(axis[1] @ y), np.sign(axis[2] @ y), 1.0, 0.0, 0.0])
    upper = p3 - p2
    theta2 = math.atan2(upper[0], upper[2])  # our j2 at the model's zero: the upper arm's tilt from vertical
    u = axis[3] / np.linalg.norm(axis[3])
    v = c - p3
    if v @ u < 0:  # our j4 axis points from the elbow to the wrist
        u, sign[3] = -u, -1.0
    need(abs(u[1]) < AXIS_TOL, "j4 is not in the arm's plane")
    phi = math.atan2(-u[2], u[0])  # j2 + j3 (ours) at the model's zero
    forearm_up = np.array([math.sin(phi), 0.0, math.cos(phi)])
    need(abs(abs(axis[4] @ y) - 1) < AXIS_TOL, "j5 is not along y (j4 not at its zero)")
    need(abs(abs(axis[5] @ u) - 1) < AXIS_TOL, "j6 is not along the forearm (j5 not at its zero)")
    sign[4], sign[5] = np.sign(axis[4] @ y), np.sign(axis[5] @ u)
    flange = d.xpos[m.jnt_bodyid[joints[5]]]
    flange = (flange - p0) @ r0
    kin = Kinematics(a1=float(p2[0]), d1=float(p2[2]), a2=float(np.linalg.norm(upper)), a3=float(v @ forearm_up),
                     d4=float(v @ u), d6=float((flange - c) @ u))
    need(abs((flange - c) @ forearm_up) < POINT_TOL and abs(flange[1] - c[1]) < POINT_TOL,
         "the flange is off the j6 axis")
    ours_at_zero = np.array([0.0, theta2, phi - theta2, 0.0, 0.0, 0.0])
    offset = -sign * ours_at_zero  # model = sign * ours + offset, and the model's zero is ours_at_zero
    limits = np.zeros((6, 2))
    for k, j in enumerate(joints):
        lo, hi = (m.jnt_range[j] if m.jnt_limited[j] else (-2 * np.pi, 2 * np.pi))
        ends = sign[k] * (np.array([lo, hi]) - offset[k])
        limits[k] = np.sort(ends)
    return kin, sign, offset, limits


def _meet(p, a, q, b):
    """The point where lines p + s a and q + t b meet, or None."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    n = np.cross(a, b)
    if np.linalg.norm(n) < AXIS_TOL or abs((q - p) @ n) / np.linalg.norm(n) > POINT_TOL:
        return None
    s, t = np.linalg.lstsq(np.stack([a, -b], axis=1), q - p, rcond=None)[0]
    return p + s * a


def _distance_to_line(c, p, a) -> float:
    a = a / np.linalg.norm(a)
    w = c - p
    return float(np.linalg.norm(w - (w @ a) * a))


def urdf_velocities(path: str | Path) -> np.ndarray | None:
    """The six revolute joints' velocity limits [rad/s] from a URDF, in joint order; None if not all are given."""
    root = read_xml(path)
    vel = [j.find("limit").get("velocity") if j.find("limit") is not None else None
           for j in root.iter("joint") if j.get("type") in ("revolute", "continuous")]
    if len(vel) != 6 or any(v is None for v in vel):
        return None
    out = []
    for j, v in enumerate(vel, start=1):
        try:
            out.append(float(v))
        except ValueError:
            raise ConfigError("model_file", f"{Path(path).name}: revolute joint {j}'s velocity limit {v!r} is not a "
                                            f"number") from None
    return np.array(out)


def chain_from_model(m: mujoco.MjModel, field: str = "model_file") -> tuple[JointChain, np.ndarray]:
    """(the general joint chain, joint limits (6, 2) [rad]) of a serial 6R arm, in the model's own convention:
    each link frame sits on its joint's anchor, turned as the model's body; the flange is the last body's origin."""
    joints = _hinges(m, field)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)

    def frame(b, p=np.zeros(3)):
        rot = d.xmat[b].reshape(3, 3)
        return homogeneous(rot, d.xpos[b] + rot @ p)

    prev = frame(int(m.body_parentid[m.jnt_bodyid[joints[0]]]))
    origins, rpys, axes = [], [], []
    for j in joints:
        link = frame(int(m.jnt_bodyid[j]), m.jnt_pos[j])
        rel = np.linalg.inv(prev) @ link
        origins.append(tuple(float(v) for v in rel[:3, 3]))
        rpys.append(rpy_from_matrix(rel[:3, :3]))
        axis = m.jnt_axis[j] / np.linalg.norm(m.jnt_axis[j])
        axes.append(tuple(float(v) for v in axis))
        prev = link
    flange = np.linalg.inv(prev) @ frame(int(m.jnt_bodyid[joints[-1]]))
    limits = np.array([m.jnt_range[j] if m.jnt_limited[j] else (-2 * np.pi, 2 * np.pi) for j in joints], float)
    return JointChain(tuple(origins), tuple(rpys), tuple(axes), tuple(float(v) for v in flange[:3, 3]),
                      rpy_from_matrix(flange[:3, :3])), limits


def rpy_from_matrix(r: np.ndarray) -> tuple[float, float, float]:
    """Fixed-axis roll, pitch, yaw of ``r`` = Rz(yaw) Ry(pitch) Rx(roll) (the inverse of kinematics.rpy_matrix)."""
    pitch = math.asin(-max(-1.0, min(1.0, float(r[2, 0]))))
    if abs(math.cos(pitch)) < 1e-9:  # gimbal lock: roll and yaw share one angle; put it in yaw
        return 0.0, pitch, math.atan2(-float(r[0, 1]), float(r[1, 1]))
    return math.atan2(float(r[2, 1]), float(r[2, 2])), pitch, math.atan2(float(r[1, 0]), float(r[0, 0]))


def robot_from_model(base: RobotConfig, path: str | Path, field: str = "model_file") -> RobotConfig:
    """``base`` (name, tool, collision, speeds) with kinematics, limits and controller axes from a model file, or
    a general joint chain (numeric IK) if the arm is not of the spherical-wrist form; speeds from the URDF's
    velocity limits where it gives them."""
    m = load_model(path)
    speeds = urdf_velocities(path)
    speeds = tuple(speeds.tolist()) if speeds is not None else base.joint_speed_rad_s
    try:
        kin, sign, offset, limits = derive(m, field)
    except NotSphericalWrist:
        chain, limits = chain_from_model(m, field)
        return replace(base, kinematics=None, chain=chain, joint_limits_rad=tuple(map(tuple, limits.tolist())),
                       joint_speed_rad_s=speeds, controller_sign=(1.0,) * 6, controller_offset_rad=(0.0,) * 6)
    return replace(base, kinematics=kin, chain=None, joint_limits_rad=tuple(map(tuple, limits.tolist())),
                   joint_speed_rad_s=speeds, controller_sign=tuple(sign.tolist()),
                   controller_offset_rad=tuple(offset.tolist()))


def model_collision(path: str | Path, m: mujoco.MjModel, robot: RobotConfig, field: str = "collision") -> list[dict]:
    """The URDF's collision meshes as collision entries of ``robot`` (YAML form, in our link frames): each mesh
    on the link its URDF link moves with, its pose carried from the URDF link frame into ours (the two differ by
    a constant transform: compared at the model's zero pose). ``m`` is the file as :func:`load_model` compiled it."""
    path = Path(path)
    root = read_xml(path, field)
    if root.tag != "robot":
        raise ConfigError(field, f"collision: from_model needs a URDF, {path.name} is not one")
    joints = _hinges(m, field)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    bodies = [int(m.body_parentid[m.jnt_bodyid[joints[0]]])] + [int(m.jnt_bodyid[j]) for j in joints]
    kin = RobotKinematics(robot)
    q0 = robot.from_controller(np.zeros(6)) if robot.chain is None else np.zeros(6)
    ours = kin.link_frames(q0)[:7]
    out = []
    first = next((j for j in root.iter("joint") if j.get("type") in ("revolute", "continuous")), None)
    base_name = first.find("parent").get("link") if first is not None else None
    for k, b in enumerate(bodies):  # MuJoCo may fuse the URDF's fixed base link into the world (body 0)
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) if b else base_name
        link = root.find(f"./link[@name='{name}']") if name else None
        if link is None:
            continue
        theirs = homogeneous(d.xmat[b].reshape(3, 3), d.xpos[b])
        to_ours = np.linalg.inv(ours[k]) @ theirs
        for col in link.findall("collision"):
            mesh = col.find("geometry/mesh")
            if mesh is None:
                continue
            org = col.find("origin")
            xyz = [float(v) for v in (org.get("xyz", "0 0 0").split() if org is not None else [0, 0, 0])]
            rpy = [float(v) for v in (org.get("rpy", "0 0 0").split() if org is not None else [0, 0, 0])]
            pose = to_ours @ homogeneous(rpy_matrix(rpy), xyz)
            scale = [float(v) for v in mesh.get("scale", "1 1 1").split()]
            out.append({"link": "base" if k == 0 else f"link{k}", "type": "mesh",
                        "file": str(_mesh_path(mesh.get("filename"), path, field)),
                        "pos": pose[:3, 3].tolist(), "rpy_deg": np.degrees(rpy_from_matrix(pose[:3, :3])).tolist(),
                        "scale": scale})
    if not out:
        raise ConfigError(field, f"collision: from_model, but {path.name} has no collision meshes")
    return out


def _mesh_path(ref: str, urdf: Path, field: str) -> Path:
    """A URDF mesh reference: ``package://PKG/rest`` looked up in the folders above the URDF (a ROS package folder
    named PKG), or a path relative to the URDF."""
    if ref.startswith("package://"):
        pkg, _, rest = ref[len("package://"):].partition("/")
        for folder in urdf.parents:
            for cand in (folder / pkg / rest, folder / rest if folder.name == pkg else None):
                if cand is not None and cand.is_file():
                    return cand
        raise ConfigError(field, f"mesh {ref!r}: no folder {pkg!r} holding {rest!r} above {urdf}")
    cand = Path(ref.removeprefix("file://"))
    cand = cand if cand.is_absolute() else urdf.parent / cand
    if not cand.is_file():
        raise ConfigError(field, f"mesh file not found: {cand}")
    return cand


# ------------------------------------------------------------------------------------------------ writing out
def _maker_chain(robot: RobotConfig):
    """(origin xyz, origin rpy, axis) of the six joints in the robot's controller convention: the model's zero
    pose is ours at from_controller(0), baked into the joint origins, and each axis turned by its sign."""
    if robot.chain is not None:
        return _flange_folded(robot.chain)
    q0 = robot.from_controller(np.zeros(6))
    out = []
    for (origin, _, axis), a, sg in zip(_flange_folded(robot.kinematics.joint_chain()), q0, robot.controller_sign):
        rpy = tuple(float(a) * c for c in axis)  # a coordinate axis: rpy is that angle
        out.append((origin, rpy, tuple(sg * c for c in axis)))
    return out


def _flange_folded(c: JointChain):
    """A chain's joints with its flange folded into joint 6 (link6's origin is the flange in the files we write):
    exact when the flange lies on j6's axis, as in every URDF we read; otherwise it cannot be written."""
    out = [(o, r, a) for o, r, a in zip(c.origins[:5], c.rpys[:5], c.axes[:5])]
    r6 = rpy_matrix(c.rpys[5])
    fr = rpy_matrix(c.flange_rpy)
    t, axis = np.asarray(c.flange_pos, float), np.asarray(c.axes[5], float)
    if np.linalg.norm(t - (t @ axis) * axis) > POINT_TOL:
        raise ConfigError("chain.flange_pos", "the flange is off j6's axis: this chain cannot be written as URDF/MJCF")
    origin = tuple(float(v) for v in np.asarray(c.origins[5]) + r6 @ t)
    out.append((origin, rpy_from_matrix(r6 @ fr), tuple(float(v) for v in fr.T @ axis)))
    return out


def to_urdf(robot: RobotConfig) -> str:
    """The robot's kinematic chain as URDF in its controller's joint convention (signs, zero pose, limits and
    velocity limits; link6's origin is the flange; no geometry). Reading it back gives the same robot."""
    lines = [f'<robot name="{robot.name}">', '  <link name="base_link"/>']
    inertial = ('<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
                '</inertial>')
    parent = "base_link"
    for i, ((origin, rpy, axis), (lo, hi), v) in enumerate(zip(_maker_chain(robot), _controller_limits(robot),
                                                               robot.joint_speed), start=1):
        lines.append(f'  <link name="link{i}">{inertial}</link>')
        lines.append(f'  <joint name="j{i}" type="revolute"><parent link="{parent}"/><child link="link{i}"/>'
                     f'<origin xyz="{_xyz(origin)}" rpy="{_xyz(rpy)}"/><axis xyz="{_xyz(axis)}"/>'
                     f'<limit lower="{float(lo)!r}" upper="{float(hi)!r}" effort="0" velocity="{float(v)!r}"/></joint>')
        parent = f"link{i}"
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def to_mjcf(robot: RobotConfig) -> str:
    """The robot's kinematic chain as MJCF in its controller's joint convention, like :func:`to_urdf` (MJCF holds
    no velocity limits)."""
    spec = mujoco.MjSpec()
    spec.modelname = robot.name
    spec.compiler.degree = False
    parent = spec.worldbody.add_body(name="base_link")
    for i, ((origin, rpy, axis), (lo, hi)) in enumerate(zip(_maker_chain(robot), _controller_limits(robot)), start=1):
        quat = np.zeros(4)
        mujoco.mju_euler2Quat(quat, np.asarray(rpy, float), "XYZ")
        body = parent.add_body(name=f"link{i}", pos=list(origin), quat=list(quat), mass=1.0,
                               inertia=[0.1, 0.1, 0.1], explicitinertial=True)
        body.add_joint(name=f"j{i}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(axis), range=[lo, hi],
                       limited=mujoco.mjtLimited.mjLIMITED_TRUE)
        parent = body
    spec.compile()
    return spec.to_xml()


def _controller_limits(robot: RobotConfig) -> np.ndarray:  # a general chain's controller axes are the identity
    return np.sort(robot.to_controller(robot.joint_limits.T).T, axis=1)


def _xyz(v) -> str:
    return " ".join(repr(float(x)) for x in v)
