"""Joint trajectories (straight segments, stop at each waypoint) and their replay in the cable simulator.

Every method (planners, policies) is judged by replaying its trajectory here, so all are measured alike.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..robots import time_law
from ..robots.time_law import JointLimits, PathMotion
from .damage import SegmentDamage, accumulate
from .fatigue import FatigueLife, fatigue_life
from .simulation import CableSimulator
from .wear_cost import cost_function

MEASURES = ("curvature", "tension", "clearance", "twist_rate")


@dataclass(frozen=True)
class Trajectory:
    """Waypoints (K, 6) [rad] joined by straight joint-space segments under the simulator's time law
    (at rest at each waypoint, joint speeds up to ``speed_fraction`` x rated); ``stops`` are the
    waypoint indices of the task's welds and final Home, where the robot stands still and the cable settles."""

    waypoints: np.ndarray
    stops: tuple[int, ...]

    def __post_init__(self):
        w = np.asarray(self.waypoints, dtype=float)
        if w.ndim != 2 or w.shape[1] != 6 or len(w) < 2:
            raise ConfigError("trajectory.waypoints", f"expected (K >= 2, 6) joint angles, got shape {w.shape}")
        if not np.isfinite(w).all():
            raise ConfigError("trajectory.waypoints", "waypoints must be finite")
        if any(not 0 < s < len(w) for s in self.stops) or list(self.stops) != sorted(set(self.stops)):
            raise ConfigError("trajectory.stops", f"must be increasing waypoint indices in [1, {len(w) - 1}]")
        object.__setattr__(self, "waypoints", w)

    def segment_durations(self, limits: time_law.JointLimits) -> np.ndarray:
        """Seconds per segment under the time law with the robot's joint ``limits`` (at the programmed speed)."""
        return time_law.segment_durations(np.diff(self.waypoints, axis=0), limits)

    def legs(self) -> list[np.ndarray]:
        """The waypoints of each leg (between consecutive stops, both ends included)."""
        bounds = [0, *self.stops]
        return [self.waypoints[a:b + 1] for a, b in zip(bounds[:-1], bounds[1:])]

    @staticmethod
    def from_legs(legs: list[np.ndarray]) -> "Trajectory":
        """Join legs (each starting where the previous ended) into one trajectory with a stop after each."""
        pts, stops = [np.asarray(legs[0][0], dtype=float)], []
        for leg in legs:
            pts.extend(np.asarray(leg[1:], dtype=float))
            stops.append(len(pts) - 1)
        return Trajectory(np.array(pts), tuple(stops))


# Fields that say nothing about where the robot and the obstacles are or how the robot moves: a plan stays valid
# when a file is moved (source, mesh paths are compared by file name), re-described, its wear weights retuned or
# its cable's life model given a torsion radius.
_NOT_FINGERPRINTED = ("source", "description", "wear_cost", "simulation", "robustness_map", "torsion_radius")


def _canonical(x):
    """A JSON-able form of a config made of frozen dataclasses, tuples, arrays and numbers (the same for the same
    config in every process: no object identities, no truncated array reprs)."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        out = {"@": type(x).__name__}
        for f in dataclasses.fields(x):
            if f.name not in _NOT_FINGERPRINTED:
                v = getattr(x, f.name)
                out[f.name] = Path(v).name if f.name == "mesh_file" and v else _canonical(v)
        return out
    if isinstance(x, np.ndarray):
        return _canonical(x.tolist())
    if isinstance(x, (list, tuple)):
        return [_canonical(v) for v in x]
    if isinstance(x, dict):
        return {str(k): _canonical(v) for k, v in sorted(x.items(), key=lambda kv: str(kv[0]))}
    if isinstance(x, (bool, str)) or x is None:
        return x
    if isinstance(x, (int, float, np.integer, np.floating)):
        return repr(float(x))
    raise TypeError(f"cannot fingerprint a {type(x).__name__}")


def _digest(x) -> str:
    return hashlib.sha256(json.dumps(_canonical(x), sort_keys=True).encode()).hexdigest()[:16]


def plan_fingerprint(config, robot: int) -> dict[str, str]:
    """``{"station", "robot", "station_name", "robot_name"}`` of station ``config`` (a StationConfig) and its robot
    index ``robot``: the robot hash covers its kinematics, joint limits, speeds, controller axes, tool and base
    pose; the station hash every robot, dresspack, obstacle, weld point and the floor (not its wear weights or
    simulation settings). A plan stores it; exporting it for another robot or station is refused."""
    p = config.robots[robot]
    return {"station": _digest(config), "robot": _digest((p.name, p.robot, p.base_pos, p.base_yaw)),
            "station_name": config.name, "robot_name": p.name}


def save_trajectory(path, traj: Trajectory, **meta) -> None:
    """``traj`` as ``.npz`` (waypoints [rad], stops) with ``meta`` (station, robot, speed_fraction, fingerprint:
    :func:`plan_fingerprint`) as JSON."""
    np.savez(path, waypoints=traj.waypoints, stops=np.array(traj.stops, dtype=int), meta=json.dumps(meta))


def load_trajectory_file(path) -> tuple[Trajectory, dict]:
    """A trajectory saved by :func:`save_trajectory` (or an evaluation's ``trajectories/*.npz``) and its meta."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError("plan", f"file not found: {path}")
    try:
        with np.load(path, allow_pickle=False) as data:
            traj = Trajectory(np.asarray(data["waypoints"], dtype=float),
                              tuple(int(i) for i in np.asarray(data["stops"]).ravel()))
            meta = json.loads(str(data["meta"])) if "meta" in data else {}
    except ConfigError as exc:
        raise ConfigError("plan", f"{path}: {exc}") from None
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as exc:
        raise ConfigError("plan", f"{path} is not a saved trajectory (.npz with waypoints and stops): "
                                  f"{type(exc).__name__}: {exc}") from None
    if not isinstance(meta, dict):
        raise ConfigError("plan", f"{path}: its meta is not a JSON object")
    return traj, meta


@dataclass
class Replay:
    """Measures sampled along a replayed trajectory (time is the robot's motion time [s])."""

    time: np.ndarray
    q: np.ndarray
    measures: dict[str, np.ndarray]  # MEASURES -> (N,)
    cost: np.ndarray  # (N,) C(gamma) of eq. 4.10 at each sample
    cost_terms: dict[str, np.ndarray]
    stop_times: list[float]
    cycle_time: float
    thresholds: dict[str, float] = field(default_factory=dict)
    unconverged_stops: int = 0  # stops whose settle did not reach the equilibrium residual (flagged, not hidden)
    damage: SegmentDamage | None = None  # per-segment damage of the cycle (recorded with states)
    fatigue: FatigueLife | None = None  # per-segment fatigue life, the cycle repeated
    qpos: np.ndarray | None = None  # (N, nq) the simulator's positions at each sample: renders without re-simulating
    given_up: bool = False  # ended by replay's ``give_up`` before the trajectory's end
    engine: str = "dynamic"  # the cable engine that produced the measures (physics.profiles.ENGINES)
    # per robot (N, vertices, 3): each cable's centreline at each sample, kept with ``qpos`` when the cables are
    # not MuJoCo's (the rod engine): the renderer draws them from these points
    cables: tuple[np.ndarray, ...] | None = None
    # the robot's segment states at each sample (replay's ``keep_states``): what colours a drawing of the cable by
    # each segment's wear cost (physics.segment_cost) where the simulator's state cannot be posed again
    states: list | None = None

    def integrated_cost(self) -> float:
        """Integral of C over the cycle [cost x s] (trapezoid over the samples)."""
        return float(np.trapezoid(self.cost, self.time)) if len(self.time) > 1 else 0.0

    def summary(self) -> dict:
        m = self.measures
        return {
            "engine": self.engine,
            "cycle_time": round(self.cycle_time, 4),
            "max_curvature": float(m["curvature"].max()),
            "max_tension": float(m["tension"].max()),
            "min_clearance": float(m["clearance"].min()),
            "max_twist_rate": float(m["twist_rate"].max()),
            "max_total_twist": float(m["total_twist"].max()),
            "max_node_force": float(m["node_force"].max()),
            "max_node_torque": float(m["node_torque"].max()),
            "unconverged_stops": self.unconverged_stops,
            "cost": self.integrated_cost(),
            "max_cost": float(self.cost.max()),
            "cost_terms": {k: float(np.trapezoid(v, self.time)) if len(self.time) > 1 else 0.0
                           for k, v in self.cost_terms.items()},
            **(self.damage.summary() if self.damage is not None else {}),
            **(self.fatigue.summary() if self.fatigue is not None else {}),
        }


def replay(sim: CableSimulator, traj: Trajectory, *, robot: int = 0, record_every: float = 0.05,
           speed_fraction: float | None = None, cost_variant: str = "thesis", start_state=None,
           until: float | None = None, record_states: bool = True, record_qpos: bool = False,
           on_sample=None, give_up=None, keep_states: bool = False) -> Replay:
    """Run ``traj`` in the simulator from a settled start (``start_state`` or a fresh reset at its first
    waypoint) and record the measures every ``record_every`` s and after settling at every stop.
    With ``until`` the replay stops at that motion time and leaves ``sim`` in that state (to render it).
    With ``record_states`` every sample also records each segment's state, from which the replay's per-segment
    damage and fatigue life are computed (the trajectory taken as one period of a repeated station cycle).
    With ``record_qpos`` every sample also keeps the simulator's positions (``Replay.qpos``), enough to draw it
    (on the rod engine the robots' and, in ``Replay.cables``, every cable's points). With ``keep_states`` (which
    needs ``record_states``) the Replay keeps the robot's segment states at every sample (``Replay.states``).
    With ``give_up`` (``give_up(time, wear_cost) -> bool``, called with every sample in order: the start's, each
    motion sample's and each stop's after its settle) the replay ends at the first sample it answers true: the
    Replay then holds the samples up to that one, ``given_up`` set (a caller that only needs to know whether the
    cycle costs more than some bound stops simulating once that is certain)."""
    if keep_states and not record_states:
        raise ConfigError("keep_states", "keeps the states recorded: it needs record_states=True")
    cost_fn = cost_function(cost_variant)
    station = sim.station
    cfg = station.config.wear_cost
    stop_if = None if give_up is None else (lambda t, m: give_up(t, cost_fn(m, cfg)))
    q_all = station.home.copy()

    def full(q):
        q_all[robot] = q
        return q_all.copy()

    if start_state is not None:
        sim.set_state(start_state)
        if not np.allclose(sim.q[robot], traj.waypoints[0], atol=1e-9):
            raise ConfigError("start_state", "the start state's robot configuration is not the trajectory's start")
    else:
        sim.reset(full(traj.waypoints[0]))
    sim.motion_time = 0.0
    measures0, states0 = sim.measures_and_states()
    samples_t, samples_q, samples_m = [0.0], [traj.waypoints[0].copy()], [measures0]
    samples_s = [states0[robot]] if record_states else []
    # MuJoCo's positions, to draw it; on the rod engine the robots' (in MuJoCo's positions) and the cables' points
    rod_cables = sim.engine != "dynamic"
    samples_x, samples_c = [], []

    def keep_positions() -> None:
        if rod_cables:
            samples_x.append(sim.mujoco_qpos())
            samples_c.append([sim.cable_points(r) for r in range(station.n_robots)])
        else:
            samples_x.append(sim.data.qpos.copy())

    if record_qpos:
        keep_positions()

    def sampled(t: float) -> None:  # called right after each motion sample is recorded, in its state
        if record_qpos:
            keep_positions()
        if on_sample is not None:
            on_sample(t)

    if on_sample is not None:
        on_sample(0.0)
    stops = set(traj.stops)
    stop_times = []
    unconverged = 0
    given_up = stop_if is not None and stop_if(0.0, measures0)
    for i, q in enumerate(traj.waypoints[1:], start=1):
        if given_up:
            break
        trace = sim.move_to(full(q), speed_fraction=speed_fraction, settle=i in stops, record_every=record_every,
                            until=until, record_states=record_states, stop_if=stop_if,
                            on_sample=sampled if record_qpos or on_sample is not None else None)
        samples_t += trace.time
        if record_qpos:  # a move of no length records one sample without calling back
            for _ in range(len(samples_t) - len(samples_x)):
                keep_positions()
        samples_q += [x[robot] for x in trace.q]
        samples_m += trace.measures
        samples_s += [x[robot] for x in trace.states]
        given_up = trace.stopped
        if given_up or until is not None and sim.motion_time >= until:
            break
        if i in stops:
            unconverged += int(sim.last_settle is not None and not sim.last_settle.converged)
            stop_times.append(sim.motion_time)
            samples_t.append(sim.motion_time)
            samples_q.append(q.copy())
            stop_measures, stop_states = sim.measures_and_states()
            samples_m.append(stop_measures)
            if record_qpos:
                keep_positions()
            if record_states:
                samples_s.append(stop_states[robot])
            given_up = stop_if is not None and stop_if(sim.motion_time, stop_measures)
    costs = [cost_fn(m, cfg) for m in samples_m]
    measures = {
        "curvature": np.array([m.max_curvature for m in samples_m]),
        "tension": np.array([m.max_tension for m in samples_m]),
        "clearance": np.array([m.min_clearance for m in samples_m]),
        "twist_rate": np.array([m.max_twist_rate for m in samples_m]),
        "total_twist": np.array([m.total_twist for m in samples_m]),
        "node_force": np.array([m.max_node_force for m in samples_m]),
        "node_torque": np.array([m.max_node_torque for m in samples_m]),
    }
    terms = {k: np.array([c.terms()[k] for c in costs]) for k in costs[0].terms()}
    damage = life = None
    if record_states:
        dresspack = station.config.robots[robot].dresspack
        damage = accumulate(samples_t, samples_s, dresspack)
        life = fatigue_life(samples_s, dresspack.fatigue, damage.arc, dresspack.tensile_stiffness)
    return Replay(np.array(samples_t), np.array(samples_q), measures, np.array([c.total for c in costs]), terms,
                  stop_times, sim.motion_time,
                  {"curvature": cfg.curvature_threshold, "clearance": cfg.clearance}, unconverged, damage, life,
                  np.array(samples_x) if record_qpos else None, given_up, sim.engine,
                  tuple(np.array(c) for c in zip(*samples_c)) if record_qpos and rod_cables else None,
                  samples_s if keep_states else None)


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


def joint_reversals(waypoints: np.ndarray) -> np.ndarray:
    """Per joint, how often it turns back along the waypoints: its moving direction flips from one moving segment
    of it to its next (changes below ``STILL_JOINT`` are no move)."""
    dq = np.diff(waypoints, axis=0)
    out = np.zeros(dq.shape[1], dtype=int)
    for j in range(dq.shape[1]):
        signs = np.sign(dq[np.abs(dq[:, j]) > STILL_JOINT, j])
        out[j] = np.count_nonzero(signs[1:] != signs[:-1])
    return out


def _reversals(waypoints: np.ndarray) -> int:
    """How often any joint turns back (:func:`joint_reversals`, all joints)."""
    return int(joint_reversals(waypoints).sum())


def schedule_smoothness(schedule) -> dict[str, float]:
    """:func:`smoothness` of one robot's station program (a ``RobotSchedule``), measured alike: reversals over the
    waypoints of all its legs per second of motion, and the largest joint acceleration of its legs' timed motions
    (each as it runs, flying by its via points or stopping at each). For legs that stop at each via point this is
    :func:`smoothness` of the same waypoints as one trajectory."""
    duration = float(np.sum(schedule.leg_durations()))
    peak = max((m.peak_acceleration() for m in schedule.motions() if m.duration > 0), default=0.0)
    return {"reversals_per_s": _reversals(np.vstack(schedule.legs)) / duration if duration > 0 else 0.0,
            "peak_joint_acceleration": float(peak)}
