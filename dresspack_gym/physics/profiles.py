"""Physics profiles: the accurate simulation (the station as configured) and a cheaper one for training, allowed
only as far as it ranks paths by wear as the accurate one does (``path_ranking_agreement``)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..fields import check_choice
from ..stations.config import StationConfig

# The cable engines: MuJoCo's dynamic simulation, or the quasi-static rod engine (dresspack_gym.rod).
ENGINES = ("dynamic", "fast")
# The engine that plans and judges motions unless a command is told otherwise (--physics): MuJoCo. The rod engine
# ranks random weld cycles by wear as MuJoCo does (Spearman rho 0.99-1.00 on three stations) at 3.5x the speed, but
# ompl-wear planning on it finds routes whose cable MuJoCo bends past the curvature threshold for a second at a bent
# wrist where the rod engine's does not: judged on MuJoCo they cost 1.11x the plans made on MuJoCo (30 drawn welds),
# while MuJoCo's plans cost the same as its own on the rod engine (docs/rod_engine.md, "Plans made on each engine").
DEFAULT_ENGINE = "dynamic"
ENGINE_TITLES = {"dynamic": "MuJoCo dynamic simulation", "fast": "quasi-static rod engine"}


@dataclass(frozen=True)
class PhysicsProfile:
    """Cable segments of every dresspack and the motion timestep (None keeps the station's own), and the engine
    that simulates the cables (one of ENGINES)."""

    name: str
    segments: int | None = None
    timestep: float | None = None
    engine: str = "dynamic"


PROFILES = {
    "accurate": PhysicsProfile("accurate"),
    # the station's own cable on the rod engine (which steps per motion sample, not by the MuJoCo timestep): ranks
    # 12 fixed weld cycles by ∫C dt as the accurate profile does (Spearman 0.99, each cycle's integral within 6 %)
    # at a quarter of its CPU time (tests/physics/test_physics_profiles.py). 48 segments rank them worse (0.97,
    # integrals up to 2.4x) for no saving; MuJoCo with 16 segments at an 8 ms step ranked them at 0.97 with
    # integrals a third to a half low, and its clamps got crushed (see coarse_step).
    "training": PhysicsProfile("training", engine="fast"),
    # the station's own cable on MuJoCo at an 8 ms step (the stations' default step: for them, the accurate
    # profile), with clamps as long as the accurate ones. A 16-segment cable's clamps hold
    # 1/16 of it rigidly, long enough for the forearm to cut into the tool-side clamp's edge at a bent wrist; both
    # sides of that contact are driven, so its force is unbounded (MN "tensions" in ~8 % of a policy's training
    # episodes, 10-25 N here and in the accurate profile on the same actions; tests/physics/test_physics_profiles.py).
    "coarse_step": PhysicsProfile("coarse_step", timestep=0.008),
}


def make_simulator(station, engine: str = "dynamic"):
    """The station's cable simulator on ``engine`` (one of ENGINES): a CableSimulator (MuJoCo) or a RodSimulator
    (the rod engine); both move robots, settle, measure and save state alike."""
    if check_choice("physics", engine, list(ENGINES)) == "fast":
        from ..rod.simulator import RodSimulator

        return RodSimulator(station)
    from .simulation import CableSimulator

    return CableSimulator(station)


def with_profile(config: StationConfig, profile: str) -> StationConfig:
    """``config`` simulated at ``profile`` (one of PROFILES)."""
    p = PROFILES[check_choice("physics_profile", profile, list(PROFILES))]
    robots = config.robots
    if p.segments is not None:
        robots = tuple(replace(r, dresspack=replace(r.dresspack, segments=p.segments)) for r in robots)
    simulation = config.simulation if p.timestep is None else replace(config.simulation, timestep=p.timestep)
    return replace(config, robots=robots, simulation=simulation)


def spearman(a, b) -> float:
    """Spearman's rank correlation of two samples without ties."""
    ra = np.argsort(np.argsort(np.asarray(a, dtype=float)))
    rb = np.argsort(np.argsort(np.asarray(b, dtype=float)))
    return float(np.corrcoef(ra, rb)[0, 1])


def random_paths(station, robot: int, validity, n: int, seed: int, spread_deg: float = 60.0) -> list:
    """``n`` valid weld cycles Home -> a random via -> one of the robot's named welds -> Home (straight joint
    segments, collision-checked), drawn from ``seed``: a fixed set of paths with a wide range of wear."""
    from ..stations.tasks import select_weld_goals
    from .trajectory import Trajectory

    goals = list(select_weld_goals(station, robot, validity.checker.collides).values())
    home = station.config.robots[robot].home
    rng = np.random.default_rng(seed)
    paths = []
    while len(paths) < n:
        goal = goals[int(rng.integers(len(goals)))]
        via = home + rng.uniform(-1.0, 1.0, 6) * np.radians(spread_deg)
        pts = np.array([home, via, goal, home])
        if all(validity.valid(q) for q in pts) and all(validity.segment_valid(a, b) for a, b in zip(pts, pts[1:])):
            paths.append(Trajectory(pts, (2, 3)))
    return paths
