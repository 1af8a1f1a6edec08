"""Time-short legs for station plans: one taught via point where it suffices, OMPL otherwise, then shortened under
the time law.

Every waypoint of a leg is a stop (the time law is rest-to-rest), so a leg's time is the sum of its segments'
jerk-limited times, and what makes a detour slow is the number of stops and the joint swings between them. OMPL's
RRTConnect returns a path of whatever class its tree grew into (on side_framing_4r, wrist swings of 130-150 deg
on legs whose straight move changes no joint by more than 30 deg); its simplifier shortens joint-space length,
not time. What a robot programmer does instead is teach one via point beside the blocked straight move. So:

1. the straight move if it is valid;
2. else **one via point**: ``VIA_SAMPLES`` candidates drawn around the move's midpoint are timed in bulk
   (both segments, by the time law) and checked in order of that time until one gives two valid segments
   (``VIA_CHECKS`` valid candidates at most; each costs two continuous segment checks);
3. else OMPL's path (RRTConnect, simplified, shortcut), as the ``ompl`` planner returns it;
4. then the path is **shortened under the time law**: via points dropped or pulled toward their neighbours'
   midpoint, and random shortcuts between two points of the path, each kept only if the path stays valid and its
   time falls (``SHORTEN_TRIES``).

Every number of draws and checks is fixed (work units) and the draws come from the plan's generator, which the
planner re-seeds per plan: a leg's route depends on its ends, the seed and the station only.
"""

from __future__ import annotations

import numpy as np

from dresspack_gym.robots import time_law
from dresspack_gym.stations.validity import MotionValidity

from ..planners.budget import Allowance
from ..planners.composed import ComposedPlanner
from ..planners.ompl_connect import OmplConnector

VIA_SAMPLES = 256  # candidate via points per blocked move (timed in bulk, cheap)
VIA_CHECKS = 40  # ... of which at most this many valid ones are tried as two segments (the costly part)
# [rad] spread of the candidates around the move's midpoint per joint: the arm's joints (1-3) move the tool in
# space, the wrist's (4-6) turn it, and a wrist re-orientation is the cheaper way round an obstacle close to it
VIA_SPREAD = np.array([0.5, 0.5, 0.5, 1.0, 1.0, 1.0])
SHORTEN_TRIES = 60  # random shortcuts tried per leg
PULL_ROUNDS = 6  # passes over the via points (drop, or pull toward the neighbours' midpoint)
PULL_FRACTIONS = (0.5, 0.25, 0.1)  # of the way to the neighbours' midpoint, largest first
# [s] a fly-by leg's curve is checked as the path of its positions this far apart in time: each chord continuously
# (with the planner's clearance), and the curve leaves a chord by at most a dt^2 / 8 per joint (1.8e-4 rad at the
# shipped robots' largest 14.7 rad/s^2: under half a millimetre at 2.5 m of reach, inside the 5 mm margin)
CURVE_DT = 0.01


def curve_valid(motion: time_law.PathMotion, validity: MotionValidity) -> bool:
    """Whether a timed motion (a fly-by leg, which leaves its straight segments near the via points) is valid:
    its positions every :data:`CURVE_DT` joined as a path and checked like one."""
    steps = max(1, int(np.ceil(motion.duration / CURVE_DT)))
    q, _ = motion.at(np.linspace(0.0, motion.duration, steps + 1))
    return validity.path_valid(q)


def one_via(a: np.ndarray, b: np.ndarray, validity: MotionValidity, limits: time_law.JointLimits,
            rng: np.random.Generator) -> np.ndarray | None:
    """The fastest valid a -> via -> b found among the candidates (see the module docstring), or None."""
    via = 0.5 * (a + b) + rng.normal(0.0, 1.0, (VIA_SAMPLES, 6)) * VIA_SPREAD
    times = time_law.segment_durations(via - a, limits) + time_law.segment_durations(b - via, limits)
    tried = 0
    for k in np.argsort(times, kind="stable"):
        v = via[k]
        if not validity.valid(v):
            continue
        tried += 1
        if validity.segment_valid(a, v) and validity.segment_valid(v, b):
            return np.array([a, v, b])
        if tried >= VIA_CHECKS:
            break
    return None


def shorten(path: np.ndarray, validity: MotionValidity, limits: time_law.JointLimits,
            rng: np.random.Generator) -> np.ndarray:
    """``path`` (valid) made faster under the time law and still valid: pulled, shortcut, pulled again."""
    path = _pull(np.array(path, dtype=float), validity, limits)
    for _ in range(SHORTEN_TRIES):
        n = len(path) - 1
        if n < 2:
            break
        i, j = sorted(rng.choice(n, 2, replace=False))  # two different segments, a point on each
        si, sj = rng.random(2)
        p = path[i] + si * (path[i + 1] - path[i])
        q = path[j] + sj * (path[j + 1] - path[j])
        new = np.vstack([path[:i + 1], p, q, path[j + 1:]])
        if time_law.path_duration(new, limits) < time_law.path_duration(path, limits) - 1e-9 \
                and validity.segment_valid(p, q):
            path = new
    return _pull(path, validity, limits)


def _pull(path: np.ndarray, validity: MotionValidity, limits: time_law.JointLimits) -> np.ndarray:
    """Each via point dropped if its neighbours join validly at no more time, else moved part of the way toward
    their midpoint if that is faster and valid; repeated while anything changes (``PULL_ROUNDS`` at most)."""
    for _ in range(PULL_ROUNDS):
        changed = False
        i = 1
        while i < len(path) - 1:
            a, v, b = path[i - 1], path[i], path[i + 1]
            here = time_law.path_duration(path[i - 1:i + 2], limits)
            if time_law.path_duration(np.array([a, b]), limits) <= here and validity.segment_valid(a, b):
                path = np.delete(path, i, axis=0)
                changed = True
                continue
            mid = 0.5 * (a + b)
            for f in PULL_FRACTIONS:
                w = v + f * (mid - v)
                if time_law.path_duration(np.array([a, w, b]), limits) < here - 1e-9 and validity.valid(w) \
                        and validity.segment_valid(a, w) and validity.segment_valid(w, b):
                    path[i] = w
                    changed = True
                    break
            i += 1
        if not changed:
            break
    return path


class FastestRoute:
    """One candidate per leg: the straight move, else one via point, else OMPL's path; shortened under the time
    law (a route generator like :class:`~agents.routes.DirectRoute`)."""

    def __init__(self, connector: OmplConnector, validity: MotionValidity, limits: time_law.JointLimits,
                 iterations: int):
        self.connector, self.validity, self.limits = connector, validity, limits
        self.iterations = iterations

    def candidates(self, a: np.ndarray, b: np.ndarray, rng: np.random.Generator,
                   allowance: Allowance) -> list[np.ndarray]:
        if self.validity.segment_valid(a, b):
            return [np.array([a, b])]
        path = one_via(a, b, self.validity, self.limits, rng)
        if path is None:
            path = self.connector.connect(a, b, self.iterations, allowance)  # raises PlanningError if none
        return [shorten(path, self.validity, self.limits, rng)]


class FastLegPlanner(ComposedPlanner):
    """A planner of single legs whose route is :class:`FastestRoute` (the station planner's, per robot)."""

    name = "fastest-leg"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.routes = FastestRoute(self.connector, self.validity, self.motion_limits, self.budget.iterations)
