"""The station planner's time-short legs (agents/stations/fast_routes.py): against a joint-space obstacle whose fastest
one-via detour is known, and on the shipped side-framing station's blocked moves against OMPL's paths."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from dresspack.agents.planners.composed import OmplPlanner
from dresspack.agents.stations.fast_routes import FastLegPlanner, one_via, shorten

from dresspack_gym.io.loading import load_station
from dresspack_gym.multi.tasks import make_station_task
from dresspack_gym.robots.time_law import JointLimits, path_duration, segment_durations
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import Task

LIMITS = JointLimits(np.full(6, 1.0), np.full(6, 8.0), np.full(6, 80.0))


class BoxInJointSpace:
    """Validity with one obstacle: the joint-space box |q0| < 0.2, |q1| < 0.5 (every other joint free). A
    segment is checked exactly (slab intersection), so the test measures the search, not a sampled check."""

    lo = np.array([-0.2, -0.5])
    hi = np.array([0.2, 0.5])

    def valid(self, q) -> bool:
        q = np.asarray(q)[:2]
        return not bool(np.all((q > self.lo) & (q < self.hi)))

    def segment_valid(self, a, b) -> bool:
        a, d = np.asarray(a)[:2], np.asarray(b)[:2] - np.asarray(a)[:2]
        t0, t1 = 0.0, 1.0
        for k in range(2):
            if abs(d[k]) < 1e-15:
                if not self.lo[k] < a[k] < self.hi[k]:
                    return True
                continue
            u, v = sorted(((self.lo[k] - a[k]) / d[k], (self.hi[k] - a[k]) / d[k]))
            t0, t1 = max(t0, u), min(t1, v)
        return not t0 < t1

    def path_valid(self, path) -> bool:
        return self.valid(path[0]) and all(self.segment_valid(p, q) for p, q in zip(path[:-1], path[1:]))


def test_one_via_round_a_joint_space_box_takes_the_fastest_detour():
    """From q0 = -1 to +1 through the box: any detour needs joint 0 to travel 1 rad to the via and 1 rad on (the
    via's q0 splits the 2 rad, and the rest-to-rest time of a move is its slowest joint's), so no path with one
    stop beats 2 T(1 rad); a via at q0 = 0 with |q1| >= 0.625 reaches it, and the search finds it."""
    box = BoxInJointSpace()
    a, b = np.zeros(6), np.zeros(6)
    a[0], b[0] = -1.0, 1.0
    assert not box.segment_valid(a, b)
    best = 2 * float(segment_durations(np.array([1.0, 0, 0, 0, 0, 0]), LIMITS))
    path = one_via(a, b, box, LIMITS, np.random.default_rng(0))
    assert path is not None and len(path) == 3
    assert all(box.segment_valid(p, q) for p, q in zip(path[:-1], path[1:]))
    found = path_duration(path, LIMITS)
    assert best - 1e-9 <= found <= 1.05 * best
    # shortening keeps it valid and can only make it faster; from a poor detour (far round the box, with a
    # needless wrist turn) it comes down to the same optimum
    poor = np.array([a, [0.0, 2.0, 0.3, 1.5, -1.0, 0.5], b])
    assert all(box.segment_valid(p, q) for p, q in zip(poor[:-1], poor[1:]))
    short = shorten(poor, box, LIMITS, np.random.default_rng(1))
    assert all(box.segment_valid(p, q) for p, q in zip(short[:-1], short[1:]))
    assert path_duration(short, LIMITS) <= 1.02 * best < path_duration(poor, LIMITS)
    # a via that is not needed is dropped: the straight move is the fastest motion between two configurations
    free = np.array([[1.0, 0, 0, 0, 0, 0], [1.3, 0.9, 0, 0, 0, 0], [1.5, 0.8, 0, 0, 0, 0]])
    np.testing.assert_array_equal(shorten(free, box, LIMITS, np.random.default_rng(0)), free[[0, -1]])


def test_no_via_found_is_none_not_a_colliding_path():
    class Nowhere(BoxInJointSpace):
        def segment_valid(self, a, b) -> bool:
            return False

    assert one_via(np.zeros(6), np.ones(6), Nowhere(), LIMITS, np.random.default_rng(0)) is None


@pytest.fixture(scope="module")
def blocked_moves():
    """Robot r1 of the shipped side-framing station and the first six moves between its Home and its weld
    options whose straight move is blocked (by the car body, a parked neighbour or the joint restrictions)."""
    station = Station(load_station("side_framing_4r"))
    planners = [FastLegPlanner(station, r, seed=0) for r in range(station.n_robots)]
    fast = planners[0]
    task = make_station_task(station, lambda r: planners[r].validity.checker.collides)
    qs = [task.homes[0], *(o.q for opts in task.options.values() for o in opts if o.robot == 0)]
    moves = []
    for i, j in ((i, j) for i in range(len(qs)) for j in range(len(qs)) if i != j):
        if not fast.validity.segment_valid(qs[i], qs[j]):
            moves.append((qs[i], qs[j]))
        if len(moves) == 6:
            break
    return station, fast, moves


def test_fastest_legs_are_valid_reproducible_and_faster_than_ompl_paths(blocked_moves):
    """On the station's blocked moves the legs are collision-free, the same whatever was planned before, and
    together faster than OMPL's RRTConnect paths (the station planner's legs before; 36 % less on the 24 detours
    of a 40-weld time plan)."""
    station, fast, moves = blocked_moves
    ompl = OmplPlanner(station, 0, seed=0)
    fast_t = ompl_t = 0.0
    legs = []
    for a, b in moves:
        leg = fast.plan(Task(0, a, (), np.zeros((0, 6)), b)).trajectory.waypoints
        assert fast.validity.path_valid(leg)
        np.testing.assert_array_equal(leg[[0, -1]], [a, b])
        legs.append(leg)
        fast_t += path_duration(leg, fast.motion_limits)
        ompl_t += path_duration(ompl.plan(Task(0, a, (), np.zeros((0, 6)), b)).trajectory.waypoints,
                                ompl.motion_limits)
    assert fast_t < 0.85 * ompl_t
    # in reverse order, from a fresh planner: the same legs
    again = FastLegPlanner(station, 0, seed=0)
    for (a, b), leg in reversed(list(zip(moves, legs))):
        np.testing.assert_array_equal(again.plan(Task(0, a, (), np.zeros((0, 6)), b)).trajectory.waypoints, leg)


def test_station_plan_config_names_the_leg_routes():
    from dresspack.agents.stations import LEG_PLANNERS, StationPlanConfig

    from dresspack_gym.errors import ConfigError

    assert set(LEG_PLANNERS) == {"fastest", "ompl"} and StationPlanConfig().leg_route == "fastest"
    with pytest.raises(ConfigError, match="leg_route.*fastest.*ompl"):
        replace(StationPlanConfig(), leg_route="rrt")


def test_a_fly_by_that_cuts_a_corner_into_an_obstacle_is_caught():
    """At an obtuse corner both joints keep their direction, so the fly-by rounds it toward the chord; a small box
    put where the rounded curve strays farthest from the segments (clear of them) is hit by the curve and caught,
    while stopping at the via point keeps to the checked segments."""
    from dresspack.agents.stations.fast_routes import curve_valid

    from dresspack_gym.robots.time_law import PathMotion

    path = np.array([[0.0, 0.0, 0, 0, 0, 0], [1.0, 1.0, 0, 0, 0, 0], [2.0, 1.2, 0, 0, 0, 0]])
    stop, fly = PathMotion(path, LIMITS), PathMotion(path, LIMITS, fly_by=True)
    assert fly.duration < stop.duration
    q, _ = fly.at(np.linspace(0.0, fly.duration, 2001))

    def off_path(x):  # distance in (q0, q1) from the two segments
        d = []
        for p0, p1 in zip(path[:-1, :2], path[1:, :2]):
            f = np.clip(np.dot(x - p0, p1 - p0) / np.dot(p1 - p0, p1 - p0), 0.0, 1.0)
            d.append(np.linalg.norm(x - (p0 + f * (p1 - p0))))
        return min(d)

    gap = np.array([off_path(x) for x in q[:, :2]])
    assert gap.max() > 0.01  # the corner is rounded, not a hair's width
    box = BoxInJointSpace()
    box.lo, box.hi = q[gap.argmax(), :2] - 0.4 * gap.max(), q[gap.argmax(), :2] + 0.4 * gap.max()
    assert all(box.segment_valid(p, r) for p, r in zip(path[:-1], path[1:]))
    assert curve_valid(stop, box) and not curve_valid(fly, box)


def test_station_legs_fly_by_where_the_curve_is_clear(blocked_moves):
    """The station planner times each leg by its motion: flying by where the rounded curve passes the check (on
    the shipped station's blocked moves, some do), else stopping; --stop-at-via-points stops everywhere."""
    from dresspack.agents.stations import StationPlanConfig, StationPlanner

    station, fast, moves = blocked_moves
    planner = StationPlanner(station, StationPlanConfig())
    still = StationPlanner(station, StationPlanConfig(fly_by=False))
    legs = [fast.plan(Task(0, a, (), np.zeros((0, 6)), b)).trajectory.waypoints for a, b in moves]
    flown = 0
    for leg in legs:
        m, s = planner.legs.motion(0, leg), still.legs.motion(0, leg)
        assert not s.fly_by and s.duration == pytest.approx(path_duration(leg, fast.motion_limits))
        if m.fly_by:
            flown += 1
            assert m.duration < s.duration
        else:
            assert m.duration == s.duration
    assert flown >= 1
