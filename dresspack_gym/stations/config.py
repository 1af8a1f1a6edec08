"""Frozen configuration of a station: obstacles, weld points, robot placements, wear cost and simulation.
Every ``from_dict`` validates strictly (unknown keys, types, units, ranges) and raises
:class:`~dresspack_gym.errors.ConfigError` naming the dotted field. Angles in YAML are degrees
(keys end in ``_deg``); internally they are radians. Lengths are metres, forces newtons.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..cable.config import (
    WEIGHT_MAX,
    DresspackConfig,
)
from ..errors import ConfigError
from ..fields import Section, check_number
from ..robots.config import (
    PRIMITIVES,
    RobotConfig,
)
from ..robots.restrictions import RestrictionSet

OBSTACLE_TYPES = PRIMITIVES + ("plane", "mesh")
FRICTION_CONES = ("elliptic", "pyramidal")  # MuJoCo's option cone


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
    # The life variant: C = w_life x the worst segment's fatigue damage of one excursion to the state (fatigue.py
    # excursion_damage). 1e4: a state whose one excursion uses 1/10,000 of the cable's life costs as much per second
    # as a second of cycle time.
    w_life: float = 1e4

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
            w_life=s.number("w_life", d.w_life, lo=0.0, hi=WEIGHT_MAX),
        )
        s.done()
        return out


@dataclass(frozen=True)
class SimulationConfig:
    """Physics and quasi-static motion settings.

    The discrete integrator is implicit in position for the rod's elasticity, so motions run at the relaxation
    step: 8 ms ranks fixed weld cycles by wear exactly as 2 ms does, 3x faster
    (scripts/studies/physics_speed_accuracy.py).
    """

    timestep: float = 0.008
    speed_fraction: float = 0.5  # fraction of the robot's rated joint speeds used for motions
    cable_damping: float = 5.0  # viscous damping rate of the cable's motion [1/s] (air/contact losses)
    bending_damping: float = 0.02  # Rayleigh damping time of the rod elasticity [s]
    settle_time: float = 10.0  # max seconds of simulated settling; a settle that needs more is flagged unconverged
    settle_timestep: float = 0.008  # relaxation step with the robots still [s]
    # Static equilibrium: the largest net force on a free vertex below this fraction of its weight (and the
    # net twist torque below this fraction of rho h g r) ... At 0.02 settled cables still relaxed by several mm
    # and 70 % of their twist in the next 20 s (scripts/studies/rest_table.py).
    equilibrium_tolerance: float = 0.005
    equilibrium_speed: float = 0.002  # ... and the cable's kinetic energy below 1/2 M v^2 at this speed [m/s]
    gravity: float = 9.81
    # Contact friction (MuJoCo's option cone and impratio). Soft contacts let a cable resting under tangential load
    # creep (MuJoCo's "slow slippage"): on the default station's floor_pan_inner weld it slides along the roof rail
    # and the settle is flagged unconverged. Elliptic cones with impratio 100 hold it there (drift 136 -> 1.4 mm in
    # 20 s) but make a cable resting on the robot's wrist creep instead (scripts/studies/rest_table.py), so the default
    # stays pyramidal; MuJoCo's NoSlip pass is not available for elastic flexes under the discrete integrator.
    friction_cone: str = "pyramidal"
    impratio: float = 1.0

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
            friction_cone=s.string("friction_cone", d.friction_cone, choices=FRICTION_CONES),
            impratio=s.number("impratio", d.impratio, lo=1.0, hi=1000.0,
                              hint="frictional-to-normal contact impedance (elliptic cones)"),
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
    part: bool = False  # a workpiece: weld points may be drawn on its faces (stations/weld_sampling.py)


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
