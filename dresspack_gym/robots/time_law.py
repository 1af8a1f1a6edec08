"""The robots' time law: rest-to-rest straight joint-space segments, time-optimal under every joint's velocity,
acceleration and jerk limits, computed by Ruckig (the maintained online trajectory generator).

A straight segment ``q(t) = a + s(t) (b - a)`` is one scalar motion s: 0 -> 1 whose limits are the tightest of the
joints' (joint i allows s' <= v_i / |b_i - a_i|, likewise for s'' and s'''). Every joint of every robot then moves in
phase, the path stays the straight segment the planners checked for collisions, no joint exceeds its limits, and
the slowest joint is driven at its limits. Ruckig solves the scalar motion (a 7-phase jerk-limited profile).

``speed_fraction`` is the programmed speed, as in a robot program's speed data: it scales the joints' velocity
limits; accelerations and jerks stay the robot's own. (The cubic law of version 0 instead stretched every segment
to 1.5x the slowest joint's time at that speed, whatever its length: short moves accelerated far beyond what a
large robot does, long ones never reached the programmed speed.)

A path of several segments stops at each waypoint (``path_duration``), or, in station plans, flies by its via points
(:class:`PathMotion`: the corners rounded within the same limits, the curve checked by the caller).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from ruckig import InputParameter, Result, Ruckig, Synchronization
from ruckig import Trajectory as RuckigTrajectory

# Scalar motions solved per Ruckig call when durations are asked for in bulk (planners cost thousands of moves).
BATCH = 2048
# Recorded with results that depend on timing (robustness maps), so one computed under another law is not resumed.
TIME_LAW = "ruckig rest-to-rest, jerk-limited, velocity x speed_fraction"
# [rad] a joint change below this is "not moving": it would otherwise set an absurd scalar limit v / |dq|.
STILL = 1e-12


@dataclass(frozen=True)
class JointLimits:
    """Velocity [rad/s], acceleration [rad/s^2] and jerk [rad/s^3] limits per joint, arrays of one shape
    (6,) for a robot, (n_robots, 6) for a station."""

    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray

    def at_speed(self, fraction: float) -> JointLimits:
        """The limits of a program run at ``fraction`` of the rated joint speeds (velocity scaled only)."""
        return JointLimits(self.velocity * float(fraction), self.acceleration, self.jerk)

    def slowed(self, fraction: float) -> JointLimits:
        """The full-speed motion run ``1 / fraction`` times slower in time (v f, a f^2, j f^3): the same profile
        stretched, for quasi-static probing where accelerations must shrink with the speed."""
        f = float(fraction)
        return JointLimits(self.velocity * f, self.acceleration * f ** 2, self.jerk * f ** 3)

    @staticmethod
    def stack(limits) -> JointLimits:
        """One set of limits for several robots moving together: (n_robots, 6) arrays."""
        limits = list(limits)
        return JointLimits(*(np.stack([getattr(x, k) for x in limits]) for k in ("velocity", "acceleration", "jerk")))


def _scalar_limits(dq: np.ndarray, limits: JointLimits) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per segment (rows of ``dq`` flattened to (M, n)): the velocity-bound time 1/V and the scalar motion's
    limits in units where s runs over that time at speed 1 (distance 1/V, speed 1, acceleration A/V, jerk J/V).
    These units keep the numbers moderate for tiny and huge moves alike (the duration is unit-free)."""
    n = int(np.prod(np.shape(limits.velocity)))
    d = np.abs(np.asarray(dq, dtype=float)).reshape(-1, n)
    moving = d > STILL
    safe = np.where(moving, d, 1.0)
    per = [np.where(moving, np.broadcast_to(np.ravel(x), d.shape) / safe, np.inf)
           for x in (limits.velocity, limits.acceleration, limits.jerk)]
    v, a, j = (x.min(axis=1) for x in per)
    return np.where(np.isfinite(v), 1.0 / np.where(np.isfinite(v), v, 1.0), 0.0), v, a, j


@lru_cache(maxsize=16)
def _solver(n: int) -> tuple[Ruckig, InputParameter, RuckigTrajectory]:
    """A Ruckig instance for ``n`` independent scalar motions from rest to rest (kept: building one costs more
    than solving it)."""
    inp = InputParameter(n)
    inp.synchronization = Synchronization.No
    inp.current_position = np.zeros(n)
    return Ruckig(n), inp, RuckigTrajectory(n)


def _check(result, what: str) -> None:
    if result not in (Result.Working, Result.Finished):
        raise RuntimeError(f"Ruckig could not time {what}: {result}")  # limits are validated positive upstream


def segment_durations(dq: np.ndarray, limits: JointLimits) -> np.ndarray:
    """Seconds of each rest-to-rest straight segment with joint changes ``dq`` (..., *limits shape)."""
    dq = np.asarray(dq, dtype=float)
    shape = dq.shape[:dq.ndim - np.ndim(limits.velocity)]
    length, v, a, j = _scalar_limits(dq, limits)
    out = np.zeros(length.size)
    todo = np.flatnonzero(length > 0)
    for start in range(0, todo.size, BATCH):
        idx = todo[start:start + BATCH]
        # padded with unit motions up to a power of two: a few solver sizes serve every call, and a single
        # duration (a roadmap edge, a planner's leg) does not pay for a full batch
        size = 1 << (idx.size - 1).bit_length()
        otg, inp, traj = _solver(size)
        pad = size - idx.size
        inp.target_position = np.concatenate([length[idx], np.ones(pad)])
        inp.max_velocity = np.ones(size)
        inp.max_acceleration = np.concatenate([a[idx] / v[idx], np.ones(pad)])
        inp.max_jerk = np.concatenate([j[idx] / v[idx], np.ones(pad)])
        _check(otg.calculate(inp, traj), f"{idx.size} segments")
        out[idx] = np.asarray(traj.independent_min_durations)[:idx.size]
    return out.reshape(shape)


def velocity_bound(dq: np.ndarray, limits: JointLimits) -> np.ndarray:
    """A lower bound of :func:`segment_durations` (the slowest joint's time at its top speed), cheap in bulk."""
    dq = np.asarray(dq, dtype=float)
    return _scalar_limits(dq, limits)[0].reshape(dq.shape[:dq.ndim - np.ndim(limits.velocity)])


class AccelerationBound:
    """A lower bound of :func:`segment_durations` for one robot's single moves, in plain Python for search loops
    that time one pair of configurations per call (a sampling planner's edge costs: numpy and Ruckig cost more
    per call than the whole estimate). Each joint alone, from rest to rest at its velocity and acceleration
    limits with jerk unbounded, needs ``d/v + v/a`` (or ``2 sqrt(d/a)`` when it never reaches v); the
    synchronised jerk-limited motion of all joints takes at least the longest of these."""

    def __init__(self, limits: JointLimits):
        if np.ndim(limits.velocity) != 1:
            raise ValueError("AccelerationBound times one robot's moves: limits of shape (n_joints,)")
        self._joints = [(float(v), float(a), float(v) * float(v) / float(a))
                        for v, a in zip(limits.velocity, limits.acceleration)]

    def __call__(self, a, b) -> float:
        """Seconds (a lower bound) of the straight move between two configurations (sequences of joint angles)."""
        t = 0.0
        for (v, acc, ramp), x, y in zip(self._joints, a, b):
            d = abs(y - x)
            tj = d / v + v / acc if d > ramp else 2.0 * math.sqrt(d / acc)
            if tj > t:
                t = tj
        return t


def path_duration(waypoints: np.ndarray, limits: JointLimits) -> float:
    """Seconds to run a path (K, *limits shape) of straight segments, stopping at every waypoint."""
    return float(segment_durations(np.diff(np.asarray(waypoints, dtype=float), axis=0), limits).sum())


class SegmentMotion:
    """The timed motion of one straight segment: ``fraction(t)`` of the way and its rate at times t in
    [0, duration], plus the motion stretched to end on a whole number of simulator steps (``on_steps``)."""

    def __init__(self, dq: np.ndarray, limits: JointLimits):
        length, v, a, j = (float(x[0]) for x in _scalar_limits(dq, limits))
        self.length = length
        self.duration = 0.0
        if length <= 0:
            return
        otg, inp, _ = _solver(1)
        self._traj = RuckigTrajectory(1)  # its own: the motion is sampled later
        inp.target_position = [length]
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = [1.0], [a / v], [j / v]
        _check(otg.calculate(inp, self._traj), "a segment")
        self.duration = float(self._traj.duration)

    @property
    def peak_acceleration(self) -> float:
        """The largest |d^2 fraction / dt^2| [1/s^2] (acceleration is piecewise linear in the profile's phases, so
        its extremes are at their boundaries)."""
        if self.length <= 0:
            return 0.0
        return float(np.max(np.abs(self._traj.profiles[0][0].a))) / self.length

    @property
    def peak_jerk(self) -> float:
        """The largest |d^3 fraction / dt^3| [1/s^3] (jerk is constant in each of the profile's phases)."""
        if self.length <= 0:
            return 0.0
        return float(np.max(np.abs(self._traj.profiles[0][0].j))) / self.length

    @property
    def peak_rate(self) -> float:
        """The largest d fraction / dt [1/s] (reached where the acceleration is zero, a phase boundary)."""
        if self.length <= 0:
            return 0.0
        return float(np.max(np.abs(self._traj.profiles[0][0].v))) / self.length

    def at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """(fraction of the segment covered, its rate [1/s]) at times ``t`` [s] (clipped to the motion)."""
        t = np.clip(np.atleast_1d(np.asarray(t, dtype=float)), 0.0, self.duration)
        if self.length <= 0:
            return np.ones_like(t), np.zeros_like(t)
        pos, vel = np.empty_like(t), np.empty_like(t)
        for i, ti in enumerate(t):
            p, v, _ = self._traj.at_time(float(ti))
            pos[i], vel[i] = p[0], v[0]
        return np.clip(pos / self.length, 0.0, 1.0), vel / self.length

    def on_steps(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(fraction, rate) after each of the ceil(duration / dt) steps of ``dt``: the motion slowed by a hair so
        it ends exactly on the last step (a slower copy of a motion within the limits stays within them)."""
        steps = int(np.ceil(self.duration / dt - 1e-9)) if self.duration > 0 else 0
        if steps == 0:
            return np.zeros(0), np.zeros(0)
        stretch = self.duration / (steps * dt)
        frac, rate = self.at(np.arange(1, steps + 1) * dt * stretch)
        frac[-1] = 1.0
        return frac, rate * stretch


def pass_velocities(waypoints: np.ndarray, limits: JointLimits) -> np.ndarray:
    """(K, 6) joint velocities [rad/s] at which a path flies by its via points (zero at its two ends): per joint,
    the smaller of the peak speeds the straight segments before and after the via point reach when each is run
    rest to rest, and zero in a joint that turns back there (or does not move on one side). So a joint never
    passes a via point faster than either neighbouring segment would move it, and the corner is rounded as a
    robot's zone rounds a fly-by point."""
    pts = np.asarray(waypoints, dtype=float)
    peaks = np.array([SegmentMotion(d, limits).peak_rate * d for d in np.diff(pts, axis=0)])
    v = np.zeros_like(pts)
    before, after = peaks[:-1], peaks[1:]
    same = np.sign(before) * np.sign(after) > 0
    v[1:-1] = np.where(same, np.sign(before) * np.minimum(np.abs(before), np.abs(after)), 0.0)
    # a segment that cruises peaks at the limit, and Ruckig wants a target below it: each point's velocity scaled
    # down as a whole (per joint clipping would turn it off the line, and Ruckig could then not keep to the line)
    top = np.ravel(limits.velocity) * (1.0 - 1e-9)
    scale = np.min(np.where(np.abs(v) > top, top / np.maximum(np.abs(v), 1e-300), 1.0), axis=1, keepdims=True)
    return v * scale


class PathMotion:
    """The timed motion of one path (K, n joints) from rest to rest: stopping at every via point (its straight
    segments, each a :class:`SegmentMotion`), or flying by them (``fly_by``): each section a jerk-limited motion
    from one point's :func:`pass_velocities` to the next's, within every joint's limits (Ruckig, phase-
    synchronised where the states allow, so a section between two rests stays a straight segment). Flying by
    leaves the straight segments near the via points: whoever uses it checks the curve (:meth:`at`) first."""

    def __init__(self, waypoints: np.ndarray, limits: JointLimits, fly_by: bool = False):
        self.waypoints = np.asarray(waypoints, dtype=float)
        self.fly_by = bool(fly_by) and len(self.waypoints) > 2
        dq = np.diff(self.waypoints, axis=0)
        if not self.fly_by:
            self._segments = [SegmentMotion(d, limits) for d in dq]
            durations = [m.duration for m in self._segments]
        else:
            n = self.waypoints.shape[1]
            v = pass_velocities(self.waypoints, limits)
            otg, inp = Ruckig(n), InputParameter(n)
            inp.synchronization = Synchronization.Phase  # straight where it can be; Ruckig falls back to Time
            inp.max_velocity, inp.max_acceleration, inp.max_jerk = (np.ravel(x) for x in (
                limits.velocity, limits.acceleration, limits.jerk))
            self._sections = []
            for i in range(len(dq)):
                inp.current_position, inp.current_velocity = self.waypoints[i], v[i]
                inp.current_acceleration = np.zeros(n)
                inp.target_position, inp.target_velocity = self.waypoints[i + 1], v[i + 1]
                inp.target_acceleration = np.zeros(n)
                traj = RuckigTrajectory(n)
                _check(otg.calculate(inp, traj), "a fly-by section")
                self._sections.append(traj)
            durations = [float(t.duration) for t in self._sections]
        self.section_durations = np.array(durations)
        self.section_starts = np.concatenate([[0.0], np.cumsum(durations)[:-1]])
        self.duration = float(np.sum(durations))

    def at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions and velocities ((N, n), (N, n)) at times ``t`` (N,) [s] from the path's start (clipped
        to the motion: at rest at its ends)."""
        t = np.clip(np.atleast_1d(np.asarray(t, dtype=float)), 0.0, self.duration)
        k = np.clip(np.searchsorted(self.section_starts, t, side="right") - 1, 0, len(self.section_durations) - 1)
        q = np.empty((len(t), self.waypoints.shape[1]))
        qd = np.zeros_like(q)
        for sec in np.unique(k):
            rows = np.flatnonzero(k == sec)
            local = t[rows] - self.section_starts[sec]
            if not self.fly_by:
                a, b = self.waypoints[sec], self.waypoints[sec + 1]
                frac, rate = self._segments[sec].at(local)
                q[rows] = a + frac[:, None] * (b - a)
                qd[rows] = rate[:, None] * (b - a)
                continue
            traj = self._sections[sec]
            for r, tl in zip(rows, local):
                p, v, _ = traj.at_time(float(min(tl, traj.duration)))
                q[r], qd[r] = p, v
        end = t >= self.duration  # exactly the last point at rest (not the float rounding of the sections' sum)
        q[end], qd[end] = self.waypoints[-1], 0.0
        return q, qd

    def peak_acceleration(self) -> float:
        """The largest |joint acceleration| [rad/s^2] over the motion (at its profiles' phase boundaries)."""
        if not self.fly_by:
            return max((m.peak_acceleration * float(np.max(np.abs(d)))
                        for m, d in zip(self._segments, np.diff(self.waypoints, axis=0))), default=0.0)
        return max((float(np.max(np.abs(p.a))) for traj in self._sections for p in traj.profiles[0]), default=0.0)
