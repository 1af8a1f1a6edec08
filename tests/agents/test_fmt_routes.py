"""OMPL FMT* over the wear map (ompl-wear-fmt): the objective is the time integral of the Python state cost, the time
estimate is a lower bound of the time law, searches are reproducible from their seed and improve on the direct
move by their own objective, and the planner plans reproducibly."""

import numpy as np
import pytest

pytest.importorskip("ompl.base")

from dresspack.agents.planners.fmt_routes import FmtSearch, TimeWearObjective  # noqa: E402
from dresspack.agents.planners.map_roadmap import fine_wear, motion_time  # noqa: E402
from dresspack.agents.planners.registry import make_planner  # noqa: E402

from dresspack_gym.errors import ConfigError  # noqa: E402
from dresspack_gym.io.loading import load_station  # noqa: E402
from dresspack_gym.robots import time_law  # noqa: E402
from dresspack_gym.stations.station import Station  # noqa: E402
from dresspack_gym.stations.tasks import make_task  # noqa: E402


@pytest.fixture(scope="module")
def tension():
    station = Station(load_station("thesis_tension"))
    planner = make_planner("ompl-wear-fmt", station, 0, seed=0, fmt_samples=300, routes=3, evaluations=4)
    task = make_task(station, 0, planner.validity.checker.collides, None)
    return station, planner, task


def test_acceleration_bound_is_a_lower_bound_of_the_time_law(tension):
    station = tension[0]
    limits = station.config.robots[0].robot.joint_motion_limits.at_speed(0.5)
    bound = time_law.AccelerationBound(limits)
    rng = np.random.default_rng(3)
    ratios = []
    for scale in (1e-3, 0.05, 0.5, 3.0):
        for _ in range(200):
            a = rng.uniform(-2, 2, 6)
            b = a + rng.normal(0.0, scale, 6)
            ratios.append(bound(a, b) / float(time_law.segment_durations(b - a, limits)))
    assert max(ratios) <= 1.0 + 1e-12
    # jerk-free for long moves: a long single-joint move differs from the law only by the jerk phases (a / j each)
    v, a_max, j_max = (float(x[0]) for x in (limits.velocity, limits.acceleration, limits.jerk))
    dq = np.zeros(6)
    dq[0] = 3.0
    exact = float(time_law.segment_durations(dq, limits))
    assert bound(np.zeros(6), dq) == pytest.approx(3.0 / v + v / a_max)
    assert exact - bound(np.zeros(6), dq) == pytest.approx(a_max / j_max, rel=1e-6)  # the jerk-limited ramps


def test_objective_integrates_the_python_state_cost_over_time(tension):
    """motionCost = (time bound) x trapezoid of 1 + w C at the ends: checked against a state cost known in closed
    form (OMPL's own StateCostIntegralObjective would integrate over joint-space length instead)."""
    import ompl.base as ob

    station, planner = tension[:2]
    space = ob.RealVectorStateSpace(6)
    bounds = ob.RealVectorBounds(6)
    bounds.setLow(-4.0)
    bounds.setHigh(4.0)
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(lambda s: True)
    si.setup()

    class LinearCost:  # C(q) = |q_0|
        def cost(self, q):
            return abs(float(q[0]))

    bound = time_law.AccelerationBound(planner.motion_limits)
    objective = TimeWearObjective.build(si, LinearCost(), bound, weight=3.0)
    s1, s2 = space.allocState(), space.allocState()
    a, b = np.array([0.5, 0.1, 0.2, 0.0, 0.0, 0.0]), np.array([1.5, -0.3, 0.2, 0.4, 0.0, 1.0])
    for j in range(6):
        s1[j], s2[j] = a[j], b[j]
    expected = bound(a, b) * 0.5 * ((1 + 3.0 * 0.5) + (1 + 3.0 * 1.5))
    assert objective.motionCost(s1, s2).value() == pytest.approx(expected, rel=1e-12)
    assert objective.stateCost(s2).value() == pytest.approx(1 + 3.0 * 1.5)


@pytest.mark.slow  # about 15-20 s on 2 cores: the fast tier's time
def test_fmt_search_is_reproducible_valid_and_beats_the_direct_move_by_its_objective(tension):
    """The crossing leg of thesis_tension: the direct move drags the predicted cable through the cuboid (map cost
    high); FMT*'s route is valid, far cheaper by the same objective, and the same for the same seed."""
    _, planner, task = tension
    search = planner.routes.roadmap
    assert isinstance(search, FmtSearch)
    a, b = task.waypoints()[1:3]
    weight = 10.0
    route = search.route(a, b, weight, np.random.default_rng(5))
    again = search.route(a, b, weight, np.random.default_rng(5))
    np.testing.assert_array_equal(route, again)
    assert planner.validity.path_valid(route)
    np.testing.assert_array_equal(route[0], a)
    np.testing.assert_array_equal(route[-1], b)

    def objective(p, q):
        t = motion_time(p, q, search.limits)
        return t + weight * fine_wear(search.cost, p, q, t)

    along = sum(objective(p, q) for p, q in zip(route[:-1], route[1:]))
    assert along < 0.5 * objective(a, b)


@pytest.mark.slow  # two ompl-wear-fmt plans (~25 s)
def test_planner_is_reproducible_and_reports_its_search(tension):
    station, planner = tension[:2]
    task = make_task(station, 0, planner.validity.checker.collides, ["side_b"])  # Home -> side_b -> Home
    plans = []
    for _ in range(2):
        p = make_planner("ompl-wear-fmt", station, 0, seed=1, fmt_samples=100, routes=2, evaluations=1)
        plans.append(p.plan(task))
    np.testing.assert_array_equal(plans[0].trajectory.waypoints, plans[1].trajectory.waypoints)
    info = plans[0].info
    assert info["wear_map"] is not None and info["fmt_samples"] == 100 and info["fmt_motion_checks"] > 0


def test_bad_fmt_settings_name_the_field(tension):
    station = tension[0]
    with pytest.raises(ConfigError, match="fmt_samples"):
        make_planner("ompl-wear-fmt", station, 0, fmt_samples=3)
    with pytest.raises(ConfigError, match="fmt_radius_multiplier"):
        make_planner("ompl-wear-fmt", station, 0, fmt_radius_multiplier=0.0)
