"""The wear-aware objective of one leg: motion time + integral of the wear cost (4.10), by simulating the cable
along the leg in path order from the cable state the previous legs left (thesis §5.3); its weights' range checks."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dresspack_gym.errors import ConfigError
from dresspack_gym.physics.profiles import DEFAULT_ENGINE, make_simulator
from dresspack_gym.physics.trajectory import Trajectory, replay
from dresspack_gym.physics.wear_cost import WearCost, cost_function
from dresspack_gym.stations.station import Station

from .leg_workers import LegWorkers, check_jobs

# Largest cost of one second of cycle time against one unit of ∫C dt: a second then outweighs a leg's whole
# wear integral (tens to hundreds), so the wear term no longer ranks routes (the README measures the trade-off).
MAX_TIME_WEIGHT = 1000.0
# [s] a leg's highest tension term charged as if it lasted this long (see LegCost). Measured on thesis_tension's
# cuboid moved -10 cm, the four seeds whose routes peaked at 64-85 N under (4.10) alone: 0.1 s left two of them
# above 60 N, 0.25 s brought all four under 43 N, 0.5 s and 1 s lowered some of those peaks by 2-10 N more at
# no shorter cycle times (README "Finding the low route every time").
TENSION_PEAK_TIME = 0.25
MAX_TENSION_PEAK_TIME = 60.0  # [s] a peak charged as if it lasted a minute outweighs any leg's motion time
# A leg is given up only when its lower bound passes the bound by more than this (relative, and absolute near 0):
# the bound is summed sample by sample, the leg's J by numpy's trapezoid, and the two roundings may differ.
BOUND_SLACK = 1e-9
# legs prefetched on the workers and not yet asked for (speculative refinement trials a change of route made moot)
MAX_AHEAD = 64


@dataclass(frozen=True)
class SimulatedLeg:
    """One leg's simulation: J (inf where given up), the cable's end state and the replay's summary (None where
    given up), the highest lower bound of J it tracked, and whether it was given up at the bound it ran with."""

    j: float
    end_state: np.ndarray | None
    summary: dict | None
    highest: float
    given_up: bool


def _key(start_state: np.ndarray, waypoints) -> bytes:
    return start_state.tobytes() + np.round(np.asarray(waypoints), 9).tobytes()


def check_time_weight(value) -> float:
    """``time_weight`` as a float, or a ConfigError naming the field and the allowed range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= MAX_TIME_WEIGHT:
        raise ConfigError("time_weight", f"must be a number in [0, {MAX_TIME_WEIGHT:g}] (cost of one second of "
                                         f"cycle time against one unit of ∫C dt; 0: wear alone), got {value!r}")
    return float(value)


def check_tension_peak_time(value) -> float:
    """``tension_peak_time`` as a float, or a ConfigError naming the field and the allowed range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= MAX_TENSION_PEAK_TIME:
        raise ConfigError("tension_peak_time",
                          f"must be a number of seconds in [0, {MAX_TENSION_PEAK_TIME:g}], got {value!r}")
    return float(value)


class LegCost:
    """``cost(start_state, waypoints) -> (J, end_state, summary)`` with
    J = time_weight * T + wear_weight * (∫C dt + tension_peak_time * max C_F).

    ``tension_peak_time`` [s] charges the leg's highest tension term C_F = w_F F² as if it lasted that long.
    (4.10)'s curvature and clearance terms are zero in normal motion and fire only at the bad moments, but its
    tension term charges the free-hanging cable's tension all the time, so its integral mostly measures motion
    time and barely sees a brief peak (70 N for 0.1 s costs w_F F² Δt ≈ 0.5 at w_F = 1e-3, less than the half
    second a lower route takes). The peak is what overloads a hose and its retraction system, and what the thesis
    reports of its routes (the low one "never exceeds 40 N"). 0 (the default) is (4.10)'s integral alone.

    With ``cost_variant="life"`` the leg's wear is its own fatigue damage: w_life x the Miner damage of the worst
    segment over the leg's strain history (rainflow-counted, the leg taken as one period), the damage per cycle the
    leg adds, in place of the states' excursion integral (which stands in for it where only states are known).

    ``engine`` (physics.profiles.ENGINES) simulates the legs: the rod engine by default. With ``jobs`` > 1, legs a
    caller :meth:`prefetch`-es are simulated on that many worker processes; every answer, counter and cache entry
    is the one simulating them one after another gives (tests/agents/test_leg_workers.py)."""

    def __init__(self, station: Station, robot: int = 0, *, time_weight: float = 1.0, wear_weight: float = 1.0,
                 tension_peak_time: float = 0.0, cost_variant: str = "thesis", record_every: float = 0.05,
                 engine: str = DEFAULT_ENGINE, jobs: int = 1):
        self.sim = make_simulator(station, engine)
        self.settings = dict(robot=robot, time_weight=time_weight, wear_weight=wear_weight,
                             tension_peak_time=tension_peak_time, cost_variant=cost_variant,
                             record_every=record_every, engine=engine)
        self.robot = robot
        self.time_weight, self.wear_weight = check_time_weight(time_weight), float(wear_weight)
        self.tension_peak_time = check_tension_peak_time(tension_peak_time)
        cost_function(cost_variant)  # a bad name fails here, naming the field, not in the first replay
        self.cost_variant = cost_variant
        self.w_life = station.config.wear_cost.w_life
        self.record_every = record_every
        # the time law the replay moves the robot by (the simulator's, at the station's programmed speed)
        self._limits = station.config.robots[robot].robot.joint_motion_limits.at_speed(
            station.config.simulation.speed_fraction)
        self.evaluations = 0  # cable simulations run
        self.given_up = 0  # of them, simulations ended once the leg certainly cost more than its query's bound
        self.queries = 0  # cost() calls, cached or not: the refiners' work unit (independent of the cache)
        self._cache: dict[bytes, tuple[float, np.ndarray, dict]] = {}
        self.jobs = check_jobs(jobs)
        self._ahead: dict = {}  # key -> a worker's simulation of that leg, started by prefetch
        self._workers = LegWorkers(LegCost, station.config, self.settings, self.jobs) if self.jobs > 1 else None

    def reset(self) -> None:
        """Forget the cache and the counters (once per plan, so a plan never depends on an earlier one)."""
        self.evaluations = self.queries = self.given_up = 0
        self._cache.clear()
        self._ahead.clear()

    def start_state(self, q_start: np.ndarray) -> np.ndarray:
        q = self.sim.station.home.copy()
        q[self.robot] = q_start
        self.sim.reset(q)
        return self.sim.get_state()

    def cost(self, start_state: np.ndarray, waypoints: np.ndarray,
             bound: float = math.inf) -> tuple[float, np.ndarray | None, dict | None]:
        """``(J, end_state, summary)`` of the leg from ``start_state``; with a ``bound``, ``(inf, None, None)``
        where J certainly exceeds it, the simulation ended as soon as that was certain (a caller that keeps a leg
        only if it costs at most the bound learns the same, sooner). So J itself is returned where J <= bound.

        A leg :meth:`prefetch` simulated with this bound or a higher one gives the same answer from its result."""
        self.queries += 1
        key = _key(start_state, waypoints)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        ahead = self._ahead.pop(key, None)
        raw = ahead.result() if ahead is not None else None
        if raw is None or (raw.given_up and ahead.bound < bound):  # given up below this bound: not known here
            raw = self.simulate(start_state, waypoints, bound)
        self.evaluations += 1
        if self._gives_up(raw, bound):
            self.given_up += 1
            return math.inf, None, None
        out = (raw.j, raw.end_state, raw.summary)
        self._cache[key] = out
        return out

    def prefetch(self, start_state: np.ndarray, legs, bound: float = math.inf) -> None:
        """Start simulating ``legs`` from ``start_state`` with ``bound`` on the worker processes (``jobs`` > 1;
        otherwise nothing): the :meth:`cost` queries of them that follow answer from those simulations, exactly as
        they would have simulating one leg after another."""
        if self._workers is None:
            return
        for leg in legs:
            key = _key(start_state, leg)
            if key not in self._cache and key not in self._ahead:
                if len(self._ahead) >= MAX_AHEAD:  # speculations never asked for: the oldest go
                    del self._ahead[next(iter(self._ahead))]
                self._ahead[key] = self._workers.submit(start_state, np.asarray(leg, dtype=float), bound)

    def simulate(self, start_state: np.ndarray, waypoints: np.ndarray, bound: float = math.inf, *,
                 track: bool = False) -> SimulatedLeg:
        """The leg simulated from ``start_state``, ended where J certainly exceeds ``bound``; no cache, no counts.
        ``track``: J's lower bound is followed even without a bound (a worker's leg may answer a bounded query
        later); otherwise an unbounded leg spends no per-sample wear cost on it."""
        traj = Trajectory(np.asarray(waypoints), (len(waypoints) - 1,))
        life = self.cost_variant == "life"
        # the life variant's J comes from the whole leg's strain history: no sample-by-sample lower bound of it
        above = None if life else (self._lower_bound(traj, bound) if track else self._above(traj, bound))
        rep = replay(self.sim, traj, robot=self.robot, record_every=self.record_every,
                     cost_variant=self.cost_variant, start_state=start_state, give_up=above,
                     record_states=life)  # other variants: C carries the wear, no per-segment count needed
        highest = above.highest if above is not None else -math.inf
        if rep.given_up:
            return SimulatedLeg(math.inf, None, None, highest, True)
        s = rep.summary()
        peak = float(np.max(rep.cost_terms["tension"])) if self.tension_peak_time else 0.0
        wear = self.w_life * float(rep.fatigue.damage_per_cycle.max()) if life else s["cost"]
        j = self.time_weight * rep.cycle_time + self.wear_weight * (wear + self.tension_peak_time * peak)
        return SimulatedLeg(j, self.sim.get_state(), s, highest, False)

    def _gives_up(self, raw: SimulatedLeg, bound: float) -> bool:
        """Whether a query with ``bound`` ends with ``raw``'s leg given up: its simulation was (at this bound or a
        lower one), or the lower bound it tracked passed this bound's limit (where the query's own simulation
        would have stopped), or (life) its J passed it."""
        if raw.given_up:
            return True
        if not math.isfinite(bound):
            return False
        limit = bound + BOUND_SLACK * max(1.0, abs(bound))
        return raw.j > limit if self.cost_variant == "life" else raw.highest > limit

    def _above(self, traj: Trajectory, bound: float):
        """The replay's ``give_up`` for ``bound`` (None: no bound, or weights under which J's lower bound does not
        grow with the samples)."""
        return self._lower_bound(traj, bound) if math.isfinite(bound) else None

    def _lower_bound(self, traj: Trajectory, bound: float):
        """J's lower bound followed sample by sample, giving up above ``bound`` (None: weights under which it does
        not grow with the samples)."""
        if self.wear_weight < 0:
            return None
        # the replay's motion time: each segment's whole steps cover its duration (SegmentMotion.on_steps, which
        # may fall short of it by 1e-9 steps; the batched durations match it to 1e-12)
        motion = float(traj.segment_durations(self._limits).sum())
        floor = self.time_weight * max(0.0, motion - 1e-6 * len(traj.waypoints))
        return _LowerBound(floor, self.wear_weight, self.tension_peak_time, bound)


class _LowerBound:
    """A replay's ``give_up``: whether the leg's J = time_weight T + wear_weight (∫C dt + tension_peak_time max C_F)
    certainly exceeds ``bound``, given its samples so far. Its motion time is known before it runs (``floor``:
    time_weight T), and the trapezoid of C over the samples so far and their highest C_F only grow with more samples
    while C >= 0 (every wear term is); a sample with C < 0 ends the bound (never gives up)."""

    def __init__(self, floor: float, wear_weight: float, peak_time: float, bound: float):
        self.floor, self.wear_weight, self.peak_time = floor, wear_weight, peak_time
        self.limit = bound + BOUND_SLACK * max(1.0, abs(bound))
        self.t = self.c = None
        self.area = self.peak = 0.0
        self.lower = floor  # J's lower bound given the samples so far
        self.valid = True
        self.highest = -math.inf  # the highest lower bound while every sample's C >= 0 (what give_up compares)

    def __call__(self, t: float, cost: WearCost) -> bool:
        c = cost.total
        self.valid = self.valid and c >= 0.0 and cost.tension >= 0.0
        if not self.valid:
            return False
        if self.t is not None:
            self.area += (t - self.t) * (c + self.c) / 2.0
        self.t, self.c = t, c
        self.peak = max(self.peak, cost.tension)
        peak = self.peak_time * self.peak if self.peak_time else 0.0
        self.lower = self.floor + self.wear_weight * (self.area + peak)
        self.highest = max(self.highest, self.lower)
        return self.lower > self.limit
