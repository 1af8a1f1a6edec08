"""Planners: valid trajectories (brute-force checked), replay reproduces the planner's numbers, wear-aware
planning lowers the measured wear, failures are clear and bounded in time."""

import json
import subprocess
import sys
import time

import numpy as np
import pytest

pytest.importorskip("ompl.base")

from dresspack.agents.planners.base import PlanningError  # noqa: E402
from dresspack.agents.planners.composed import OmplPlanner, ThesisLocalPlanner  # noqa: E402
from dresspack.agents.planners.registry import plan_station  # noqa: E402

from dresspack_gym.cli.main import main as cli_main  # noqa: E402
from dresspack_gym.io.loading import load_station  # noqa: E402
from dresspack_gym.physics.profiles import DEFAULT_ENGINE, make_simulator  # noqa: E402
from dresspack_gym.physics.trajectory import replay  # noqa: E402
from dresspack_gym.robots.time_law import SegmentMotion  # noqa: E402
from dresspack_gym.stations.collision import RobotCollisionChecker  # noqa: E402
from dresspack_gym.stations.station import Station  # noqa: E402
from dresspack_gym.stations.tasks import make_task  # noqa: E402


@pytest.fixture(scope="module")
def default_station():
    return Station(load_station("default"))


@pytest.fixture(scope="module")
def curvature_station():
    return Station(load_station("thesis_curvature"))


def brute_force_valid(station, waypoints, step_deg=0.5):
    """Every configuration every 0.5 deg along the path: limits, restrictions, no collision."""
    placement = station.config.robots[0]
    lim = placement.robot.joint_limits
    checker = RobotCollisionChecker(station)
    for a, b in zip(waypoints[:-1], waypoints[1:]):
        n = max(1, int(np.ceil(np.degrees(np.max(np.abs(b - a))) / step_deg)))
        for t in np.linspace(0, 1, n + 1):
            q = a + t * (b - a)
            if np.any(q < lim[:, 0] - 1e-9) or np.any(q > lim[:, 1] + 1e-9):
                return False
            if not placement.restrictions.allowed(q)[0] or checker.collides(q):
                return False
    return True


def test_ompl_baseline_is_valid_visits_the_stops_and_respects_speed_limits(default_station):
    # bounded by its work budget alone: a wall cap is what a loaded machine runs out of (a 20 s cap failed a
    # CI run with a third process on the two cores)
    planner = OmplPlanner(default_station, seed=0)
    task = make_task(default_station, 0, planner.validity.checker.collides)
    res = planner.plan(task)
    traj = res.trajectory
    assert brute_force_valid(default_station, traj.waypoints)
    assert np.allclose(traj.waypoints[[0, *traj.stops]], task.waypoints())
    # the simulator's time law: every joint of every segment within its speed at the programmed fraction
    robot = default_station.config.robots[0].robot
    limits = robot.joint_motion_limits.at_speed(default_station.config.simulation.speed_fraction)
    durations = traj.segment_durations(limits)
    for dq in np.diff(traj.waypoints, axis=0):
        _, rate = SegmentMotion(dq, limits).on_steps(0.001)
        assert np.all(np.abs(dq) * np.max(rate, initial=0.0) <= limits.velocity * (1 + 1e-9))
    assert res.info["duration"] == pytest.approx(durations.sum())


def test_replay_reproduces_the_wear_aware_planners_objective(curvature_station):
    planner = ThesisLocalPlanner(curvature_station, evaluations=24, seed=1)
    task = make_task(curvature_station, 0, planner.validity.checker.collides)
    res = planner.plan(task)
    rep = replay(make_simulator(curvature_station, DEFAULT_ENGINE), res.trajectory)
    assert rep.cycle_time + rep.integrated_cost() == pytest.approx(res.info["objective"], rel=1e-6)
    assert brute_force_valid(curvature_station, res.trajectory.waypoints)


def test_wear_aware_planning_lowers_the_measured_distance_cost():
    """The distance scenario's wear-unaware route passes close to the obstacles; the thesis's local method keeps
    the cable clear (measured ∫C dt 186 against 90 with the jerk-limited time law). (The curvature scenario's
    wear-unaware route stays within 0.3 1/m of κ0 and every method finds the same path there now: nothing to
    lower.)"""
    station = Station(load_station("thesis_distance"))
    base = plan_station(station, "ompl", seed=0)
    aware = plan_station(station, "thesis-local", seed=0, evaluations=30)
    b, a = base.summary(), aware.summary()
    assert a["cost"] < 0.6 * b["cost"]
    assert a["cost_terms"]["distance"] < b["cost_terms"]["distance"]
    assert a["cycle_time"] < 1.25 * b["cycle_time"]


def test_invalid_task_configuration_is_a_clear_error(default_station):
    planner = OmplPlanner(default_station, time_budget=5)
    task = make_task(default_station, 0, planner.validity.checker.collides)
    bad = task.goals.copy()
    bad[0, 4] = np.radians(500.0)  # beyond joint 5's limit
    from dataclasses import replace

    with pytest.raises(PlanningError, match="outside the joint limits"):
        planner.plan(replace(task, goals=bad))


def test_unreachable_goal_fails_within_the_time_budget(curvature_station):
    planner = OmplPlanner(curvature_station, time_budget=1.5)
    task = make_task(curvature_station, 0, planner.validity.checker.collides)
    goal = task.goals[0]
    real = planner.validity.checker.min_distance
    assert planner.validity.checker.chain_reach().min() > 0.1

    def caged(q):  # a shell of "obstacle" around the weld in joint space (0.1 m/rad: a Lipschitz-valid distance)
        r = np.max(np.abs(np.asarray(q) - goal))
        return min(real(q), 0.1 * max(0.05 - r, r - 0.3))

    planner.validity.checker.min_distance = caged
    planner.validity.checker.min_distances = lambda qs: np.array([caged(q) for q in np.atleast_2d(qs)])
    t0 = time.perf_counter()
    with pytest.raises(PlanningError, match="no collision-free path"):
        planner.plan(task)
    assert time.perf_counter() - t0 < 1.5 + 3.0


def test_plan_cli_prints_the_measures(tmp_path, capsys):
    assert cli_main(["plan", "--station", "thesis_curvature", "--planner", "ompl", "--json", "--plot",
                     str(tmp_path / "p.png")]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("success", "cycle_time", "planning_time", "max_curvature", "max_tension", "min_clearance",
                "max_twist_rate", "cost"):
        assert key in out
    assert out["success"] is True and (tmp_path / "p.png").stat().st_size > 10_000
    with pytest.raises(SystemExit):
        cli_main(["plan", "--station", "thesis_curvature", "--planner", "rrt-magic"])


def test_core_package_imports_no_torch_sb3_or_ompl():
    code = ("import sys, pkgutil, importlib, dresspack_gym\n"
            "for m in pkgutil.walk_packages(dresspack_gym.__path__, 'dresspack_gym.'):\n"
            "    importlib.import_module(m.name)\n"
            "bad = [m for m in ('torch', 'stable_baselines3', 'sb3_contrib', 'ompl') if m in sys.modules]\n"
            "print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_chain_reach_bounds_every_multi_joint_move(default_station):
    checker = RobotCollisionChecker(default_station)
    rng = np.random.default_rng(0)
    lim = default_station.config.robots[0].robot.joint_limits
    reach = checker.chain_reach()
    import mujoco

    m, d = checker.model, checker.data
    geoms = checker.robot.geom_ids
    for _ in range(30):
        q0 = rng.uniform(lim[:, 0], lim[:, 1])
        q1 = np.clip(q0 + rng.normal(0, 0.3, 6), lim[:, 0], lim[:, 1])
        d.qpos[default_station.robots[0].qpos] = q0
        mujoco.mj_kinematics(m, d)
        p0 = d.geom_xpos[geoms].copy()
        worst = 0.0
        for t in np.linspace(0, 1, 21)[1:]:
            d.qpos[default_station.robots[0].qpos] = q0 + t * (q1 - q0)
            mujoco.mj_kinematics(m, d)
            worst = max(worst, float(np.max(np.linalg.norm(d.geom_xpos[geoms] - p0, axis=1))))
        assert worst <= reach @ np.abs(q1 - q0) + 1e-9


@pytest.mark.slow  # full ompl and ompl-wear plans on the tension station (~25 s)
def test_global_wear_planner_finds_the_low_tension_route():
    """Thesis tension case: the wear-unaware route drags the cable over the cuboid (~370 N); with the shipped wear
    map the global planner takes the route under it, near the free-hanging cable's ~25 N (seeds 0-2 peak at 35, 31
    and 43 N with the peak-tension term; every seed of the 20-seed study stays under 46 N on this station, under
    2x the lowest, 30 N, README)."""
    base = plan_station("thesis_tension", "ompl", seed=0).summary()
    aware = plan_station("thesis_tension", "ompl-wear", seed=0).summary()
    assert aware["planner_info"]["wear_map"] is not None
    assert base["max_tension"] > 300
    assert aware["max_tension"] < 60
    assert aware["cost"] < 0.2 * base["cost"]


def test_leg_cost_charges_the_peak_tension_term_as_if_it_lasted_tension_peak_time():
    """J(τ) - J(0) = τ · w_F · (max F)² of the leg, replayed independently: C_F = w_F F² pointwise, so its peak is
    w_F times the square of the highest tension measured; τ = 0 is (4.10)'s integral alone. The straight move
    across thesis_tension drags the cable over the cuboid: a peak worth charging."""
    from dresspack.agents.planners.leg_cost import LegCost

    from dresspack_gym.physics.trajectory import Trajectory

    station = Station(load_station("thesis_tension"))
    task = make_task(station, 0, RobotCollisionChecker(station).collides)
    leg = task.goals[:2]  # side_a -> side_b straight: over the cuboid
    plain, charged = LegCost(station), LegCost(station, tension_peak_time=0.25)
    state = plain.start_state(leg[0])
    j0, _, _ = plain.cost(state, leg)
    j1, _, _ = charged.cost(state, leg)
    rep = replay(make_simulator(station, DEFAULT_ENGINE), Trajectory(leg, (1,)), start_state=state,
                 record_states=False)
    peak_f = float(rep.measures["tension"].max())
    assert peak_f > 100.0
    assert j0 == pytest.approx(rep.cycle_time + rep.integrated_cost(), rel=1e-9)
    assert j1 - j0 == pytest.approx(0.25 * station.config.wear_cost.w_tension * peak_f ** 2, rel=1e-9)


BAD_LEG_COST_SETTINGS = (
    [("ompl-wear", "tension_peak_time", bad, r"must be a number of seconds in \[0, 60\]")
     for bad in (-0.1, float("nan"), 61.0, True, "0.25")]
    + [(planner, "time_weight", bad, r"must be a number in \[0, 1000\]") for planner in ("ompl-wear", "thesis-local")
       for bad in (-0.5, -1.0, 1000.5, float("nan"), float("inf"), True, "2")])


@pytest.mark.parametrize("planner,name,bad,message", BAD_LEG_COST_SETTINGS)
def test_a_bad_leg_cost_setting_is_an_error_naming_it(planner, name, bad, message):
    from dresspack.agents.planners.registry import make_planner

    from dresspack_gym.errors import ConfigError

    with pytest.raises(ConfigError, match=f"^{name}: {message}"):
        make_planner(planner, Station(load_station("thesis_curvature")), **{name: bad})


@pytest.mark.parametrize("flag,applies_to,value,message", [
    ("--tension-peak-time", "ompl-wear and ompl-wear-fmt only", "0.5", "must be a number in [0, 60.0] s"),
    ("--time-weight", "thesis-local, ompl-wear, ompl-wear-fmt, ppo-search only", "5",
     "must be a number in [0, 1000.0] per s"),
    ("--proposals", "ppo-search only", "2", "must be an integer in [1, 64]"),
    ("--refine", "ppo-search only", "2", "must be an integer in [0, 10000]"),
    ("--alternatives", "ppo-search only", "2", "must be an integer in [0, 1000]"),
])
def test_plan_cli_leg_cost_flags_only_for_the_planners_that_use_them(capsys, flag, applies_to, value, message):
    name = flag[2:].replace("-", "_")
    assert cli_main(["plan", "--station", "thesis_curvature", "--planner", "ompl", flag, value]) == 2
    assert f"{name}: {flag} applies to {applies_to}, not ompl" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli_main(["plan", "--station", "thesis_curvature", "--planner", "ompl-wear", flag, "-1"])
    assert message in capsys.readouterr().err


def test_plan_cli_cost_to_go_only_for_ppo_search(capsys):
    assert cli_main(["plan", "--station", "thesis_curvature", "--planner", "ompl", "--cost-to-go", "cost_to_go"]) == 2
    assert "cost_to_go: --cost-to-go applies to ppo-search only, not ompl" in capsys.readouterr().err


def test_leg_cost_time_weight_charges_each_second_that_much_more():
    """J(w) - J(1) = (w - 1) · T of the leg, T its replayed cycle time; the wear terms are the same."""
    from dresspack.agents.planners.leg_cost import LegCost

    station = Station(load_station("thesis_tension"))
    task = make_task(station, 0, RobotCollisionChecker(station).collides)
    leg = task.goals[:2]
    plain, faster = LegCost(station), LegCost(station, time_weight=12.5)
    state = plain.start_state(leg[0])
    j1, _, s1 = plain.cost(state, leg)
    j12, _, _ = faster.cost(state, leg)
    assert s1["cycle_time"] > 1.0
    assert j12 - j1 == pytest.approx(11.5 * s1["cycle_time"], rel=1e-9)


def test_a_wall_cap_that_cuts_the_wear_aware_search_returns_the_route_found_with_a_flag(curvature_station):
    """A cap already used up when the search starts: no via route, no refinement, yet a valid answer (the first
    candidate, the wear-unaware route) flagged ``wall_cap_reached``; without a cap the flag is False."""
    from dresspack.agents.planners.registry import make_planner

    task = make_task(curvature_station, 0, RobotCollisionChecker(curvature_station).collides)
    cut = make_planner("ompl-wear", curvature_station, time_budget=1e-6).plan(task)
    assert cut.info["wall_cap_reached"] is True
    assert cut.info["routes_explored"] == len(task.waypoints()) - 1  # one candidate per leg
    assert brute_force_valid(curvature_station, cut.trajectory.waypoints)
    full = make_planner("ompl-wear", curvature_station, routes=2, evaluations=2).plan(task)
    assert full.info["wall_cap_reached"] is False and full.info["routes_explored"] > cut.info["routes_explored"]
