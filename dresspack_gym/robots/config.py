"""Frozen configuration of a robot: kinematics, joint chain, limits, speeds and collision primitives.
Every ``from_dict`` validates strictly (unknown keys, types, units, ranges) and raises
:class:`~dresspack_gym.errors.ConfigError` naming the dotted field. Angles in YAML are degrees
(keys end in ``_deg``); internally they are radians. Lengths are metres, forces newtons.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..errors import ConfigError
from ..fields import Section, check_vector
from ..robots.time_law import JointLimits

ROBOT_LINKS = ("base", "link1", "link2", "link3", "link4", "link5", "link6")
PRIMITIVES = ("box", "capsule", "sphere", "cylinder")
# [s] Makers publish rated joint speeds but no accelerations or jerks. A robot YAML without them gets joints that
# reach their rated speed in ACCELERATION_TIME from rest and their full acceleration in JERK_TIME: large spot-welding
# robots ramp to full axis speed in roughly a quarter second. State the controller's values where they are known.
ACCELERATION_TIME = 0.25
JERK_TIME = 0.1


@dataclass(frozen=True)
class Kinematics:
    """Link dimensions of a 6-axis robot with spherical wrist (ABB-style naming), metres.

    Shoulder (j2) at (a1, 0, d1) from the base, upper arm a2 along z, forearm offset a3 (z)
    and length d4 (x) to the wrist centre, flange d6 beyond the wrist centre.
    """

    a1: float
    d1: float
    a2: float
    a3: float
    d4: float
    d6: float

    def joint_chain(self) -> "JointChain":
        """The same arm as a general joint chain (link6 at the wrist centre, the flange d6 along its x): the body
        chain the MuJoCo model is built from and the URDF/MJCF writers start from."""
        zero = (0.0, 0.0, 0.0)
        return JointChain(origins=(zero, (self.a1, 0.0, self.d1), (0.0, 0.0, self.a2), (0.0, 0.0, self.a3),
                                   (self.d4, 0.0, 0.0), zero),
                          rpys=(zero,) * 6, axes=((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0),
                                                  (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)),
                          flange_pos=(self.d6, 0.0, 0.0))


@dataclass(frozen=True)
class JointChain:
    """A general serial 6R arm (no analytic IK; solved numerically): per joint the fixed transform from the
    previous link's frame (origin [m], roll-pitch-yaw [rad]) and the turning axis in the new link's frame, at
    joint value 0; then the flange in link6's frame."""

    origins: tuple[tuple[float, float, float], ...]
    rpys: tuple[tuple[float, float, float], ...]
    axes: tuple[tuple[float, float, float], ...]
    flange_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    flange_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @staticmethod
    def from_section(c: "Section") -> "JointChain":
        def rows(key, unit, lo, hi):
            raw = c.raw(key)
            if not isinstance(raw, list) or len(raw) != 6:
                raise ConfigError(c.field(key), "expected 6 rows [x, y, z], one per joint")
            return tuple(check_vector(r, f"{c.field(key)}[{i}]", 3, lo=lo, hi=hi, unit=unit) for i, r in enumerate(raw))

        origins = rows("origins", "m", -5.0, 5.0)
        rpys = tuple(tuple(math.radians(v) for v in r) for r in rows("rpys_deg", "deg", -360.0, 360.0))
        axes = rows("axes", "", -1.0, 1.0)
        for i, a in enumerate(axes):
            if abs(math.hypot(*a) - 1.0) > 1e-6:
                raise ConfigError(f"{c.field('axes')}[{i}]", f"a joint axis is a unit vector, got length {math.hypot(*a):.6g}")
        flange_pos = c.vector("flange_pos", 3, (0.0, 0.0, 0.0), lo=-5.0, hi=5.0, unit="m")
        flange_rpy = tuple(math.radians(v) for v in c.vector("flange_rpy_deg", 3, (0.0, 0.0, 0.0), lo=-360.0,
                                                              hi=360.0, unit="deg"))
        c.done()
        return JointChain(origins, rpys, axes, flange_pos, flange_rpy)

    def as_yaml(self) -> dict:
        return {"origins": [list(o) for o in self.origins],
                "rpys_deg": [[math.degrees(v) for v in r] for r in self.rpys],
                "axes": [list(a) for a in self.axes], "flange_pos": list(self.flange_pos),
                "flange_rpy_deg": [math.degrees(v) for v in self.flange_rpy]}


@dataclass(frozen=True)
class CollisionPrimitive:
    """A capsule, box, sphere, cylinder or mesh (its convex hull; an STL/OBJ file) rigidly attached to one robot
    link (link frame)."""

    link: str
    type: str
    size: tuple[float, ...]
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    fromto: tuple[float, ...] | None = None
    mesh_file: str | None = None
    mesh_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class RobotConfig:
    """A 6-axis industrial robot: kinematics, limits, speeds, tool and collision geometry.

    Limits and speeds are stored as tuples (so configs compare with ``==``) and read as fresh arrays."""

    name: str
    source: str
    kinematics: Kinematics | None  # the spherical-wrist (OPW) form, solved analytically; None for a general chain
    joint_limits_rad: tuple[tuple[float, float], ...]  # 6 x (lower, upper)
    joint_speed_rad_s: tuple[float, ...]  # 6 rated joint speeds
    tcp_pos: tuple[float, float, float]
    tcp_rpy: tuple[float, float, float]
    collision: tuple[CollisionPrimitive, ...]
    # The controller's axis values of model joints q: sign * q + offset (the model's j2 = 0 is the upper arm
    # vertical and its joints turn about +z, +y, +y, +x, +y, +x; makers count some axes the other way or from
    # another zero, e.g. KUKA's A2 = -90 deg is the upper arm vertical). Identity for a robot that counts as we do.
    controller_sign: tuple[float, ...] = (1.0,) * 6
    controller_offset_rad: tuple[float, ...] = (0.0,) * 6
    chain: JointChain | None = None  # a general 6R arm (kinematics is None), e.g. from a URDF of another form
    # Joint acceleration [rad/s^2] and jerk [rad/s^3] limits of the time law. Makers publish neither; a YAML may
    # state them (joint_acceleration_deg_s2, joint_jerk_deg_s3), else ACCELERATION_TIME / JERK_TIME set them.
    joint_acceleration_rad_s2: tuple[float, ...] | None = None
    joint_jerk_rad_s3: tuple[float, ...] | None = None

    def to_controller(self, q) -> np.ndarray:
        """Controller axis values [rad] of model joints ``q`` (..., 6)."""
        return np.asarray(q, dtype=float) * np.array(self.controller_sign) + np.array(self.controller_offset_rad)

    def from_controller(self, axes) -> np.ndarray:
        """Model joints [rad] of controller axis values ``axes`` (..., 6)."""
        return (np.asarray(axes, dtype=float) - np.array(self.controller_offset_rad)) * np.array(self.controller_sign)

    @property
    def joint_limits(self) -> np.ndarray:
        """(6, 2) radians."""
        return np.array(self.joint_limits_rad, dtype=float)

    @property
    def joint_speed(self) -> np.ndarray:
        """(6,) rad/s."""
        return np.array(self.joint_speed_rad_s, dtype=float)

    @property
    def joint_acceleration(self) -> np.ndarray:
        """(6,) rad/s^2: stated, or rated speed reached in ACCELERATION_TIME."""
        if self.joint_acceleration_rad_s2 is not None:
            return np.array(self.joint_acceleration_rad_s2, dtype=float)
        return self.joint_speed / ACCELERATION_TIME

    @property
    def joint_jerk(self) -> np.ndarray:
        """(6,) rad/s^3: stated, or full acceleration reached in JERK_TIME."""
        if self.joint_jerk_rad_s3 is not None:
            return np.array(self.joint_jerk_rad_s3, dtype=float)
        return self.joint_acceleration / JERK_TIME

    @property
    def joint_motion_limits(self) -> JointLimits:
        """The time law's velocity, acceleration and jerk limits at full program speed."""
        return JointLimits(self.joint_speed, self.joint_acceleration, self.joint_jerk)

    @staticmethod
    def from_dict(data: Mapping[str, Any], path: str = "robot") -> "RobotConfig":
        s = Section(data, path)
        name = s.string("name")
        source = s.string("source")
        chain, kin = None, None
        if s.has("chain"):
            if s.has("kinematics"):
                raise ConfigError(s.field("kinematics"), "give either kinematics (spherical wrist) or chain, not both")
            chain = JointChain.from_section(s.section("chain"))
        else:
            k = s.section("kinematics")
            kin = Kinematics(*(k.number(key, lo=-5.0, hi=5.0, unit="m",
                                        hint="kinematic lengths are metres, not millimetres")
                               for key in ("a1", "d1", "a2", "a3", "d4", "d6")))
            k.done()
            if kin.a2 <= 0 or kin.d4 <= 0:
                raise ConfigError(f"{path}.kinematics", "a2 and d4 must be positive link lengths")
        limits_raw = s.raw("joint_limits_deg")
        if not isinstance(limits_raw, list) or len(limits_raw) != 6:
            raise ConfigError(s.field("joint_limits_deg"), "expected 6 pairs [lower, upper] in degrees")
        limits = np.zeros((6, 2))
        for i, pair in enumerate(limits_raw):
            f = f"{s.field('joint_limits_deg')}[{i}]"
            lo, hi = check_vector(pair, f, 2, lo=-720.0, hi=720.0, unit="deg")
            if lo >= hi:
                raise ConfigError(f, f"lower limit {lo} must be below upper limit {hi}")
            limits[i] = np.radians([lo, hi])
        speed = np.radians(s.vector("joint_speed_deg_s", 6, lo=1e-3, hi=2000.0, unit="deg/s"))
        accel = jerk = None
        if s.has("joint_acceleration_deg_s2"):
            accel = tuple(np.radians(s.vector("joint_acceleration_deg_s2", 6, lo=1e-3, hi=1e5, unit="deg/s^2")))
        if s.has("joint_jerk_deg_s3"):
            jerk = tuple(np.radians(s.vector("joint_jerk_deg_s3", 6, lo=1e-3, hi=1e7, unit="deg/s^3")))
        tool = s.section("tool")
        tcp_pos = tool.vector("tcp_pos", 3, lo=-3.0, hi=3.0, unit="m")
        tcp_rpy = tuple(np.radians(tool.vector("tcp_rpy_deg", 3, (0, 0, 0), lo=-360, hi=360, unit="deg")))
        tool.done()
        prims = tuple(_primitive(p, ROBOT_LINKS) for p in s.sections("collision", []))
        sign, offset = (1.0,) * 6, (0.0,) * 6
        if s.has("controller_axes"):
            c = s.section("controller_axes")
            sign = c.vector("sign", 6, sign)
            for i, v in enumerate(sign):
                if v not in (1.0, -1.0):
                    raise ConfigError(f"{c.field('sign')}[{i}]", f"each sign is 1 or -1, got {v:g}")
            offset = tuple(np.radians(c.vector("offset_deg", 6, offset, lo=-360.0, hi=360.0, unit="deg")).tolist())
            c.done()
        s.done()
        return RobotConfig(name, source, kin, tuple(map(tuple, limits.tolist())), tuple(speed.tolist()), tcp_pos,
                           tcp_rpy, prims, tuple(map(float, sign)), offset, chain,
                           None if accel is None else tuple(map(float, accel)),
                           None if jerk is None else tuple(map(float, jerk)))


def _primitive(p: Section, links: tuple[str, ...]) -> CollisionPrimitive:
    link = p.string("link", choices=links)
    kind = p.string("type", choices=PRIMITIVES + ("mesh",))
    fromto, mesh, scale = None, None, (1.0, 1.0, 1.0)
    if kind == "mesh":  # the loader has made the path absolute (relative paths are relative to the robot YAML)
        mesh = p.string("file")
        if not Path(mesh).is_file():
            raise ConfigError(p.field("file"), f"mesh file not found: {mesh}")
        scale = p.vector("scale", 3, scale, lo=1e-6, hi=1e3)
        size = (0.0,)
    elif kind == "capsule" and p.has("fromto"):
        fromto = p.vector("fromto", 6, lo=-10, hi=10, unit="m")
        size = (p.number("radius", lo=0.0, lo_open=True, hi=2.0, unit="m"),)
    elif kind == "box":
        size = p.vector("half_size", 3, lo=1e-4, hi=50.0, unit="m")
    elif kind == "sphere":
        size = (p.number("radius", lo=0.0, lo_open=True, hi=10.0, unit="m"),)
    else:  # capsule/cylinder by pos+half_length along local z
        size = (p.number("radius", lo=0.0, lo_open=True, hi=10.0, unit="m"),
                p.number("half_length", lo=0.0, lo_open=True, hi=50.0, unit="m"))
    pos = p.vector("pos", 3, (0, 0, 0), lo=-50, hi=50, unit="m")
    rpy = tuple(np.radians(p.vector("rpy_deg", 3, (0, 0, 0), lo=-360, hi=360, unit="deg")))
    p.done()
    return CollisionPrimitive(link, kind, size, pos, rpy, fromto, mesh, scale)
