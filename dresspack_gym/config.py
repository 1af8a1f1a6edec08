"""Frozen configuration dataclasses for robots, dresspacks, stations, wear cost and simulation.

Every ``from_dict`` validates strictly (unknown keys, types, units, ranges) and raises
:class:`~dresspack_gym.errors.ConfigError` naming the dotted field. Angles in YAML are degrees
(keys end in ``_deg``); internally they are radians. Lengths are metres, forces newtons.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .errors import ConfigError
from .restrictions import RestrictionSet
from .time_law import JointLimits
from .validation import Section, check_number, check_vector, check_unique

ROBOT_LINKS = ("base", "link1", "link2", "link3", "link4", "link5", "link6")
NODE_BODIES = ROBOT_LINKS + ("world",)
PRIMITIVES = ("box", "capsule", "sphere", "cylinder")
OBSTACLE_TYPES = PRIMITIVES + ("plane", "mesh")
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


@dataclass(frozen=True)
class CableNode:
    """Where the dresspack is held: a point on a robot link (or the world) at an arc length.

    ``direction`` (unit vector in the body frame) makes the node a clamp that fixes the cable
    tangent; without it the node only fixes the position (a ring the cable can swivel in).
    ``arc_length`` is measured from the cable start; None means "start" (first node) or "end".
    """

    name: str
    body: str
    pos: tuple[float, float, float]
    direction: tuple[float, float, float] | None
    arc_length: float


# Largest wear-cost weight: the thesis's weights span 1e-5 (tension, N) to 100 (distance); far beyond this one
# term swamps the others to float64 rounding, which is a unit error rather than a choice.
WEIGHT_MAX = 1e9


DAMAGE_TERMS = ("bend", "bend_moment", "bend_rate", "twist", "twist_torque", "twist_rate", "stretch", "tension",
                "stretch_rate", "contact_normal", "friction")


@dataclass(frozen=True)
class DamageWeights:
    """Weights of the per-segment damage terms (the AGX CableDamage set): damage = sum over terms of weight x
    (the quantity integrated over time, or, for the ``*_rate`` terms, its total variation).

    Units of the integrated quantities: bend [1/m s], bend_moment [N m s], twist [rad/m s], twist_torque
    [N m s], stretch [s] (strain x s), tension [N s], bend_rate [1/m], twist_rate [rad/m], stretch_rate [-],
    contact_normal [N s], friction [J] (friction force x sliding speed). The defaults weigh deformation and
    sliding so that 1 /m of curvature, 1 rad/m of twist, 0.1 % strain, 100 N of contact pressure and 10 W of
    sliding friction each add about one unit per second; forces, moments and rates are off (set them to use).
    """

    bend: float = 1.0
    bend_moment: float = 0.0
    bend_rate: float = 0.0
    twist: float = 1.0
    twist_torque: float = 0.0
    twist_rate: float = 0.0
    stretch: float = 1000.0
    tension: float = 0.0
    stretch_rate: float = 0.0
    contact_normal: float = 0.01
    friction: float = 0.1

    @staticmethod
    def from_dict(data: Mapping[str, Any], path: str) -> "DamageWeights":
        s = Section(data, path)
        d = DamageWeights()
        out = DamageWeights(**{k: s.number(k, getattr(d, k), lo=0.0, hi=WEIGHT_MAX) for k in DAMAGE_TERMS})
        s.done()
        return out


# Strain-life defaults: Manson's universal slopes (Manson 1965, Exp. Mech. 5(7)), total strain range
# 3.5 (S_u/E) N^-0.12 + D^0.6 N^-0.6, written as Coffin-Manson-Basquin eps_a = s'(2N)^b + e'(2N)^c, with handbook
# properties of annealed copper: S_u = 220 MPa, E = 115 GPa, reduction of area 70 % (D = ln(1/0.3)). A model from
# tensile data, not a fatigue test of any dresspack conductor: replace it with test data where you have them.
_SU_OVER_E = 220e6 / 115e9
_DUCTILITY = math.log(1.0 / 0.3)


@dataclass(frozen=True)
class FatigueConfig:
    """Strain-life curve and the radius at which the conductors' strain is taken.

    ``strain_radius`` [m]: distance of the strained fibre from its bending axis. Robot cables use extra-flexible
    conductors (IEC 60228 class 6: strands of about 0.2 mm diameter) whose strands slide on each other, so each
    strand bends about its own axis: the default is a strand's radius, 0.1 mm (the long-life bound). Strands that
    stick together bend about the conductor's axis (a 16 mm^2 conductor: 2.26 mm, lives ~1,000x shorter). Bending
    strain = strain_radius x curvature, shear strain = strain_radius x twist rate (counted as the von Mises
    equivalent gamma / sqrt(3)), axial strain = tension / ``axial_stiffness`` (default: the dresspack's EA, the
    conductors stretching with the bundle; give the conductors' own E A where the bundle's EA is a lumped model
    value, as the thesis's 1400 N is: 38 N of pull is then a 2.7 % strain).
    """

    strain_radius: float = 1.0e-4
    sigma_f_over_e: float = 1.75 * 2 ** 0.12 * _SU_OVER_E  # s' (elastic line at 2N = 1)
    b: float = -0.12  # Basquin exponent
    eps_f: float = 0.5 * 2 ** 0.6 * _DUCTILITY ** 0.6  # e' (plastic line at 2N = 1)
    c: float = -0.6  # Coffin-Manson exponent
    axial_stiffness: float | None = None  # [N] tension per unit conductor strain; None: the dresspack's EA

    @staticmethod
    def from_dict(data: Mapping[str, Any], path: str) -> "FatigueConfig":
        s = Section(data, path)
        d = FatigueConfig()
        out = FatigueConfig(
            strain_radius=s.number("strain_radius", d.strain_radius, lo=0.0, lo_open=True, hi=0.2, unit="m"),
            sigma_f_over_e=s.number("sigma_f_over_e", d.sigma_f_over_e, lo=0.0, lo_open=True, hi=1.0),
            b=s.number("b", d.b, lo=-1.0, hi=0.0, lo_open=True),
            eps_f=s.number("eps_f", d.eps_f, lo=0.0, lo_open=True, hi=10.0),
            c=s.number("c", d.c, lo=-2.0, hi=0.0, lo_open=True),
            axial_stiffness=(s.number("axial_stiffness", lo=0.0, lo_open=True, hi=1e10, unit="N")
                             if s.has("axial_stiffness") else None))
        if out.c >= 0 or out.b >= 0:
            raise ConfigError(path, "the strain-life exponents b and c must be negative")
        s.done()
        return out


@dataclass(frozen=True)
class DresspackConfig:
    """Cable material (thesis Table 3.1 style), discretisation and attachment nodes."""

    name: str
    source: str
    length: float
    radius: float
    linear_density: float
    bending_stiffness: float  # EI, N m^2
    tensile_stiffness: float  # EA, N
    torsional_stiffness: float  # GJ, N m^2
    segments: int
    nodes: tuple[CableNode, ...]
    collide_with_robot: bool = True
    damage: DamageWeights = DamageWeights()
    fatigue: FatigueConfig = FatigueConfig()

    @property
    def second_moment(self) -> float:
        """Area moment of inertia I = pi r^4 / 4 of the circular cross-section [m^4]."""
        return math.pi * self.radius ** 4 / 4.0

    @property
    def polar_moment(self) -> float:
        """Torsion constant J = pi r^4 / 2 of the circular cross-section [m^4]."""
        return math.pi * self.radius ** 4 / 2.0

    @property
    def young_modulus(self) -> float:
        """MuJoCo ``young`` so that E*I equals the configured bending stiffness EI [Pa]."""
        return self.bending_stiffness / self.second_moment

    @property
    def shear_modulus(self) -> float:
        """MuJoCo ``shear`` so that G*J equals the configured torsional stiffness GJ [Pa]."""
        return self.torsional_stiffness / self.polar_moment

    @property
    def segment_length(self) -> float:
        return self.length / self.segments

    def vertex_of(self, node: CableNode) -> int:
        """The cable vertex a node sits on (its arc length rounded to the discretisation)."""
        return int(round(node.arc_length / self.segment_length))

    def is_end_node(self, node: CableNode) -> bool:
        """True for a node on the cable's last vertex (its clamp then holds the last edge, pointing back)."""
        return self.vertex_of(node) == self.segments

    @property
    def free_end(self) -> bool:
        """The cable's far end hangs free (no node on its last vertex)."""
        return not self.is_end_node(self.nodes[-1])

    @staticmethod
    def from_dict(data: Mapping[str, Any], path: str = "dresspack") -> "DresspackConfig":
        s = Section(data, path)
        name = s.string("name")
        source = s.string("source", "")
        length = s.number("length", lo=0.05, hi=20.0, unit="m", hint="cable length is in metres")
        radius = s.number("radius", lo=0.001, hi=0.2, unit="m", hint="cable radius is in metres")
        rho = s.number("linear_density", lo=0.0, lo_open=True, hi=50.0, unit="kg/m")
        ei = s.number("bending_stiffness", lo=0.0, lo_open=True, hi=1e4, unit="N m^2")
        ea = s.number("tensile_stiffness", lo=0.0, lo_open=True, hi=1e9, unit="N")
        gj = s.number("torsional_stiffness", lo=0.0, lo_open=True, hi=1e4, unit="N m^2")
        segments = s.integer("segments", 24, lo=3, hi=400)
        collide = s.boolean("collide_with_robot", True)
        damage = DamageWeights.from_dict(s.raw("damage", {}), f"{path}.damage")
        fatigue = FatigueConfig.from_dict(s.raw("fatigue", {}), f"{path}.fatigue")
        node_sections = s.sections("nodes")
        s.done()
        if not node_sections:
            raise ConfigError(f"{path}.nodes", "at least one attachment node is required")
        nodes = []
        for i, n in enumerate(node_sections):
            nname = n.string("name", f"node{i}")
            body = n.string("body", choices=NODE_BODIES)
            pos = n.vector("pos", 3, lo=-50, hi=50, unit="m")
            direction = None
            if n.has("direction"):
                d = np.asarray(n.vector("direction", 3, lo=-1e3, hi=1e3))
                if np.linalg.norm(d) < 1e-9:
                    raise ConfigError(n.field("direction"), "must be a non-zero vector")
                direction = tuple(d / np.linalg.norm(d))
            at = n.raw("at", "start" if i == 0 else "end")
            if at == "start":
                arc = 0.0
            elif at == "end":
                arc = length
            else:
                arc = check_number(at, n.field("at"), lo=0.0, hi=length, unit="m",
                                   hint="'start', 'end' or an arc length along the cable")
            n.done()
            nodes.append(CableNode(nname, body, pos, direction, arc))
        check_unique([nd.name for nd in nodes], f"{path}.nodes", "node")
        if nodes[0].arc_length != 0.0:
            raise ConfigError(f"{path}.nodes[0].at", "the first node must be at the cable start ('start' or 0)")
        arcs = [n.arc_length for n in nodes]
        if any(b <= a for a, b in zip(arcs, arcs[1:])):
            raise ConfigError(f"{path}.nodes", f"node arc lengths must increase along the cable, got {arcs}")
        h = length / segments
        vidx = [round(a / h) for a in arcs]
        for i in range(1, len(vidx)):
            gap = 2 if (nodes[i].direction is not None or nodes[i - 1].direction is not None) else 1
            if vidx[i] - vidx[i - 1] < gap + 1:
                raise ConfigError(f"{path}.nodes[{i}].at",
                                  f"nodes are closer than the cable discretisation allows ({segments} segments "
                                  f"of {h:.3f} m); increase 'segments' or separate the nodes")
        return DresspackConfig(name, source, length, radius, rho, ei, ea, gj, segments, tuple(nodes), collide, damage,
                               fatigue)


@dataclass(frozen=True)
class WearCostConfig:
    """Weights and thresholds of the wear cost (thesis eq. 4.10) and its normalised variant."""

    w_curvature: float = 1.0
    curvature_threshold: float = 8.0  # kappa_0 [1/m]
    w_tension: float = 1e-5
    w_distance: float = 100.0
    clearance: float = 1.0  # c [m]
    # Optional twist term (not in the thesis's 4.10, which has no torsion): w_t max(0, tau - tau_0)^2 on the
    # largest twist rate. Robot-cable data sheets commonly rate torsion at +-180 deg/m, hence tau_0 = pi.
    w_twist: float = 0.0
    twist_threshold: float = math.pi  # tau_0 [rad/m]
    # Reference scales of the normalised variant: each term is 1 when its measure is one scale
    # beyond its threshold, so equal weights penalise the three causes of wear about equally.
    curvature_scale: float = 8.0  # 1/m
    tension_scale: float = 100.0  # N
    clearance_scale: float = 0.1  # m
    twist_scale: float = math.pi  # rad/m
    normalized_weights: tuple[float, float, float] = (1.0, 1.0, 1.0)  # curvature, tension, distance
    normalized_twist_weight: float = 0.0  # the normalised variant's twist term (optional, like w_twist)

    @staticmethod
    def from_dict(data: Mapping[str, Any], path: str = "wear_cost") -> "WearCostConfig":
        s = Section(data, path)
        d = WearCostConfig()
        out = WearCostConfig(
            w_curvature=s.number("w_curvature", d.w_curvature, lo=0.0, hi=WEIGHT_MAX),
            curvature_threshold=s.number("curvature_threshold", d.curvature_threshold, lo=0.0, hi=1e3, unit="1/m"),
            w_tension=s.number("w_tension", d.w_tension, lo=0.0, hi=WEIGHT_MAX),
            w_distance=s.number("w_distance", d.w_distance, lo=0.0, hi=WEIGHT_MAX),
            clearance=s.number("clearance", d.clearance, lo=0.0, hi=100.0, unit="m"),
            w_twist=s.number("w_twist", d.w_twist, lo=0.0, hi=WEIGHT_MAX),
            twist_threshold=s.number("twist_threshold", d.twist_threshold, lo=0.0, hi=1e3, unit="rad/m"),
            curvature_scale=s.number("curvature_scale", d.curvature_scale, lo=0.0, lo_open=True, hi=1e3, unit="1/m"),
            tension_scale=s.number("tension_scale", d.tension_scale, lo=0.0, lo_open=True, hi=1e7, unit="N"),
            clearance_scale=s.number("clearance_scale", d.clearance_scale, lo=0.0, lo_open=True, hi=100.0, unit="m"),
            twist_scale=s.number("twist_scale", d.twist_scale, lo=0.0, lo_open=True, hi=1e3, unit="rad/m"),
            normalized_weights=s.vector("normalized_weights", 3, d.normalized_weights, lo=0.0),
            normalized_twist_weight=s.number("normalized_twist_weight", d.normalized_twist_weight, lo=0.0, hi=WEIGHT_MAX),
        )
        s.done()
        return out


@dataclass(frozen=True)
class SimulationConfig:
    """Physics and quasi-static motion settings.

    The defaults were chosen from the convergence study in ``tests/test_physics_validation.py``
    and ``dresspack bench physics`` (see README): 2 ms steps with the implicit ``discrete``
    integrator are stable for the Table 3.1 cable at 24 segments.
    """

    timestep: float = 0.002
    speed_fraction: float = 0.5  # fraction of the robot's rated joint speeds used for motions
    cable_damping: float = 5.0  # viscous damping rate of the cable's motion [1/s] (air/contact losses)
    bending_damping: float = 0.02  # Rayleigh damping time of the rod elasticity [s]
    settle_time: float = 5.0  # max seconds of simulated settling; a settle that needs more is flagged unconverged
    settle_timestep: float = 0.008  # relaxation step with the robots still [s]
    # Static equilibrium: the largest net force on a free vertex below this fraction of its weight (and the
    # net twist torque below this fraction of rho h g r) ...
    equilibrium_tolerance: float = 0.02
    equilibrium_speed: float = 0.002  # ... and the cable's kinetic energy below 1/2 M v^2 at this speed [m/s]
    gravity: float = 9.81

    @staticmethod
    def from_dict(data: Mapping[str, Any], path: str = "simulation") -> "SimulationConfig":
        s = Section(data, path)
        d = SimulationConfig()
        out = SimulationConfig(
            timestep=s.number("timestep", d.timestep, lo=1e-5, hi=0.02, unit="s"),
            speed_fraction=s.number("speed_fraction", d.speed_fraction, lo=0.0, lo_open=True, hi=1.0),
            cable_damping=s.number("cable_damping", d.cable_damping, lo=0.0, hi=200.0, unit="1/s"),
            bending_damping=s.number("bending_damping", d.bending_damping, lo=0.0, hi=10.0, unit="s"),
            settle_time=s.number("settle_time", d.settle_time, lo=0.0, hi=60.0, unit="s"),
            settle_timestep=s.number("settle_timestep", d.settle_timestep, lo=1e-5, hi=0.05, unit="s"),
            equilibrium_tolerance=s.number("equilibrium_tolerance", d.equilibrium_tolerance, lo=0.0, lo_open=True,
                                           hi=1.0, hint="fraction of a vertex's weight"),
            equilibrium_speed=s.number("equilibrium_speed", d.equilibrium_speed, lo=0.0, lo_open=True, hi=1.0,
                                       unit="m/s"),
            gravity=s.number("gravity", d.gravity, lo=0.0, hi=100.0, unit="m/s^2"),
        )
        s.done()
        return out


@dataclass(frozen=True)
class Obstacle:
    """Static geometry in the station (world frame)."""

    name: str
    type: str
    pos: tuple[float, float, float]
    rpy: tuple[float, float, float]
    size: tuple[float, ...]
    fromto: tuple[float, ...] | None = None
    mesh_file: str | None = None
    mesh_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    rgba: tuple[float, float, float, float] = (0.55, 0.6, 0.68, 1.0)
    part: bool = False  # a workpiece: weld points may be drawn on its faces (weld_sampling.py)


@dataclass(frozen=True)
class WeldPoint:
    """A tool pose to reach: TCP position and approach direction (TCP z axis), world frame."""

    name: str
    robot: str
    pos: tuple[float, float, float]
    approach: tuple[float, float, float]
    spin: tuple[float, ...]  # candidate rotations about the approach axis, radians


@dataclass(frozen=True)
class RobotPlacement:
    """One robot in the station with its dresspack, base pose and Home configuration."""

    name: str
    robot: RobotConfig
    dresspack: DresspackConfig
    base_pos: tuple[float, float, float]
    base_yaw: float
    home_rad: tuple[float, ...]  # 6 joint angles (a tuple, so configs compare with ==; read ``home``)
    restrictions: RestrictionSet = field(default_factory=RestrictionSet)  # thesis 4.7, AND of all rules
    robustness_map: Any = None  # a robustness.query.RobustnessMap: weld configurations must be robust (4.2)

    @property
    def home(self) -> np.ndarray:
        """(6,) radians, a fresh array."""
        return np.array(self.home_rad, dtype=float)


@dataclass(frozen=True)
class StationConfig:
    """A whole station: robots with dresspacks, obstacles, weld points, cost and physics settings."""

    name: str
    description: str
    robots: tuple[RobotPlacement, ...]
    obstacles: tuple[Obstacle, ...]
    weld_points: tuple[WeldPoint, ...]
    wear_cost: WearCostConfig = field(default_factory=WearCostConfig)
    simulation: SimulationConfig = field(default_factory=SimulationConfig)
    floor: bool = True

    def robot_index(self, name: str) -> int:
        names = [r.name for r in self.robots]
        if name not in names:
            raise ConfigError("robot", f"unknown robot {name!r}; this station has {names}")
        return names.index(name)


def obstacle_from_section(o: Section) -> Obstacle:
    name = o.string("name")
    kind = o.string("type", choices=OBSTACLE_TYPES)
    pos = o.vector("pos", 3, (0, 0, 0), lo=-500, hi=500, unit="m")
    rpy = tuple(np.radians(o.vector("rpy_deg", 3, (0, 0, 0), lo=-360, hi=360, unit="deg")))
    rgba = o.vector("rgba", 4, (0.55, 0.6, 0.68, 1.0), lo=0.0, hi=1.0)
    part = o.boolean("part", False)
    if part and kind != "box":
        raise ConfigError(o.field("part"), f"weld points are drawn on the faces of box parts; {name!r} is a {kind}")
    fromto, mesh_file, scale = None, None, (1.0, 1.0, 1.0)
    if kind == "box":
        size = o.vector("half_size", 3, lo=1e-4, hi=500.0, unit="m")
    elif kind == "sphere":
        size = (o.number("radius", lo=0.0, lo_open=True, hi=100.0, unit="m"),)
    elif kind in ("capsule", "cylinder"):
        radius = o.number("radius", lo=0.0, lo_open=True, hi=100.0, unit="m")
        if o.has("fromto"):
            fromto = o.vector("fromto", 6, lo=-500, hi=500, unit="m")
            size = (radius,)
        else:
            size = (radius, o.number("half_length", lo=0.0, lo_open=True, hi=500.0, unit="m"))
    elif kind == "plane":
        size = o.vector("half_size", 2, (10.0, 10.0), lo=0.01, hi=1e4, unit="m") + (0.1,)
    else:  # mesh
        mesh_file = o.string("file")
        scale = o.vector("scale", 3, (1, 1, 1), lo=1e-6, hi=1e6)
        size = ()
    o.done()
    return Obstacle(name, kind, pos, rpy, size, fromto, mesh_file, scale, rgba, part)


def weld_point_from_section(w: Section, robot_names: list[str]) -> WeldPoint:
    name = w.string("name")
    robot = w.string("robot", robot_names[0], choices=robot_names)
    pos = w.vector("pos", 3, lo=-500, hi=500, unit="m")
    approach = np.asarray(w.vector("approach", 3, lo=-1e3, hi=1e3))
    if np.linalg.norm(approach) < 1e-9:
        raise ConfigError(w.field("approach"), "must be a non-zero direction vector")
    approach = tuple(approach / np.linalg.norm(approach))
    spin_raw = w.raw("spin_deg", None)
    if spin_raw is None:
        spin = tuple(np.radians(np.arange(0.0, 360.0, 30.0)))  # a symmetric stud gun: any spin
    else:
        if not isinstance(spin_raw, list) or not spin_raw:
            raise ConfigError(w.field("spin_deg"), "expected a non-empty list of angles in degrees")
        spin = tuple(math.radians(check_number(v, f"{w.field('spin_deg')}[{i}]", lo=-360, hi=360, unit="deg"))
                     for i, v in enumerate(spin_raw))
    w.done()
    return WeldPoint(name, robot, pos, approach, spin)
