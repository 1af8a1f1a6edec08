"""Multi-robot station planning: the solver against brute force, the timing of schedules, robot-robot
coordination and its dense verification, the timed station replay, and bad station input."""

from __future__ import annotations

import copy
import itertools
from dataclasses import replace

import numpy as np
import pytest
from dresspack.agents.stations import StationPlanConfig, StationPlanner, jammed_legs
from dresspack.agents.stations.fast_routes import FastLegPlanner
from dresspack.agents.stations.jams import reroute
from dresspack.agents.stations.legs_up_front import move_key as _leg_key
from dresspack.agents.stations.problem import straight_times
from dresspack.agents.stations.solver import (
    RoutingProblem,
    improve_by_pairs,
    lower_bound,
    relaxation_bound,
    solve,
    wear_relaxation_bound,
)
from helpers import near_side_yaml

from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.multi.coordination import RobotPairDistance, coordinate, verify
from dresspack_gym.multi.replay import StationReplay
from dresspack_gym.multi.schedule import PHASES, RobotSchedule, StationSchedule
from dresspack_gym.multi.tasks import make_station_task
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.robots import time_law
from dresspack_gym.robots.time_law import JointLimits, segment_durations
from dresspack_gym.stations.config import StationConfig
from dresspack_gym.stations.station import Station


def robot_routes(p: RoutingProblem, r: int, welds: list[int]) -> list[tuple[float, float]] | None:
    """(time, wear) of every route of robot r through ``welds`` (every order, every option); None if r cannot
    reach one of them."""
    opts = [np.flatnonzero((p.node_weld == w) & (p.node_robot == r)) for w in welds]
    if any(len(o) == 0 for o in opts):
        return None
    t, wear = p.leg_time(r), p.leg_wear(r)
    out = [] if welds else [(0.0, 0.0)]
    for perm in itertools.permutations(range(len(welds))):
        for choice in itertools.product(*[opts[k] for k in perm]):
            legs = list(zip([r, *choice], [*choice, r]))
            out.append((sum(t[a, b] for a, b in legs), sum(wear[a, b] for a, b in legs)))
    return out


def assignments(p: RoutingProblem):
    """Per assignment of every weld to a robot that reaches it: each robot's routes (robot_routes)."""
    for owner in itertools.product(range(p.n_robots), repeat=p.n_welds):
        per_robot = [robot_routes(p, r, [w for w in range(p.n_welds) if owner[w] == r]) for r in range(p.n_robots)]
        if all(x is not None for x in per_robot):
            yield per_robot


def brute_force_makespan(p: RoutingProblem) -> float:
    """The optimal makespan by enumeration: every weld to every robot, every order, every option."""
    return float(min(max(min(t for t, _ in routes) for routes in per_robot) for per_robot in assignments(p)))


def random_problem(seed: int, robots: int = 3, welds: int = 5, branches: int = 2) -> RoutingProblem:
    """Robots at the corners of a 10 m square; weld branches scattered around each weld; some robots cannot
    reach some welds."""
    rng = np.random.default_rng(seed)
    homes = np.array([[0, 0], [10, 0], [5, 10], [0, 10]])[:robots]
    points, node_robot, node_weld = [*homes], list(range(robots)), [-1] * robots
    for w in range(welds):
        centre = rng.uniform(0, 10, 2)
        reach = rng.permutation(robots)[:rng.integers(1, robots + 1)]
        for r in sorted(reach):
            for _ in range(branches):
                points.append(centre + rng.normal(0, 0.5, 2))
                node_robot.append(r)
                node_weld.append(w)
    pts = np.array(points)
    dist = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    travel = np.stack([dist * (1 + 0.2 * r) for r in range(robots)])  # robots of different speeds
    return RoutingProblem(travel, np.ones(len(pts)), np.array(node_robot), np.array(node_weld), 1.0, welds)


@pytest.mark.parametrize("seed", range(6))
def test_solver_assignment_is_optimal_against_brute_force(seed):
    p = random_problem(seed)
    a = solve(p, "time", work=10)
    assert sorted(p.node_weld[n] for route in a.routes for n in route) == list(range(p.n_welds))  # each once
    for r, route in enumerate(a.routes):
        assert all(p.node_robot[n] == r for n in route)  # a robot visits its own options only
    assert a.estimate["makespan"] == pytest.approx(brute_force_makespan(p), abs=2e-3)
    assert lower_bound(p)["bound"] <= a.estimate["makespan"] + 1e-9
    # the relaxation (no conflicts here: the problem itself) is solved to optimality on problems this small, so its
    # bound is the optimum, less at most the legs' times rounded down to whole milliseconds
    relaxed = relaxation_bound(p)
    assert relaxed["relaxation"] == relaxed["relaxation_best"]
    assert a.estimate["makespan"] - (p.n_welds + 1) * 1e-3 <= relaxed["relaxation"] <= a.estimate["makespan"] + 1e-9


def glued(a: RoutingProblem, b: RoutingProblem) -> RoutingProblem:
    """Two stations side by side as one problem: ``a``'s robots first, then ``b``'s; no weld is shared."""
    Ra, Rb, Na, Nb = a.n_robots, b.n_robots, len(a.node_robot), len(b.node_robot)
    order = [*range(Ra), *range(Na, Na + Rb), *range(Ra, Na), *range(Na + Rb, Na + Nb)]  # Homes first
    travel = np.full((Ra + Rb, Na + Nb, Na + Nb), 1e3)
    travel[:Ra, :Na, :Na], travel[Ra:, Na:, Na:] = a.travel, b.travel
    node_robot = np.concatenate([a.node_robot, b.node_robot + Ra])
    node_weld = np.concatenate([a.node_weld, np.where(b.node_weld >= 0, b.node_weld + a.n_welds, -1)])
    return RoutingProblem(travel[:, order][:, :, order], np.ones(Na + Nb), node_robot[order], node_weld[order],
                          a.weld_time, a.n_welds + b.n_welds)


def test_relaxation_bound_solves_robots_that_share_no_weld_apart():
    a, b = random_problem(0, robots=2, welds=4), random_problem(1, robots=3, welds=4)
    p = glued(a, b)
    bound = relaxation_bound(p)
    assert [g["robots"] for g in bound["components"]] == [[0, 1], [2, 3, 4]]
    expect = max(brute_force_makespan(a), brute_force_makespan(b))
    assert bound["relaxation"] == bound["relaxation_best"]  # each group proven optimal
    assert expect - 5e-3 <= bound["relaxation"] <= expect + 1e-9
    alone = [relaxation_bound(x)["relaxation"] for x in (a, b)]
    assert bound["relaxation"] == pytest.approx(max(alone))
    assert bound["relaxation"] <= solve(p, "time", work=10).estimate["makespan"] + 1e-9


def first_reaching_routes(p: RoutingProblem) -> list[list[int]]:
    """A poor start: every weld to the lowest-numbered robot that reaches it, at its first option, in weld order."""
    routes = [[] for _ in range(p.n_robots)]
    for w in range(p.n_welds):
        n = int(np.flatnonzero(p.node_weld == w)[0])  # options are listed robot by robot
        routes[int(p.node_robot[n])].append(n)
    return routes


@pytest.mark.parametrize("seed", range(3))
def test_held_routes_are_kept_and_the_other_robots_solved_optimally_against_brute_force(seed):
    p = random_problem(seed + 20, robots=3, welds=6)
    start = first_reaching_routes(p)
    held = max(range(3), key=lambda r: len(start[r]))
    a = solve(p, "time", work=10, start=start, hold={held: start[held]})
    assert a.routes[held] == start[held]
    assert sorted(p.node_weld[n] for route in a.routes for n in route) == list(range(p.n_welds))
    held_end = p.route_ends(start)[held]
    rest = [w for w in range(p.n_welds) if w not in {int(p.node_weld[n]) for n in start[held]}]
    free = [r for r in range(3) if r != held]
    best = np.inf
    for owner in itertools.product(free, repeat=len(rest)):
        times = [robot_routes(p, r, [w for w, o in zip(rest, owner) if o == r]) for r in free]
        if all(t is not None for t in times):
            best = min(best, max(held_end, *(min(x for x, _ in t) for t in times)))
    assert a.estimate["makespan"] == pytest.approx(best, abs=2e-3)


@pytest.mark.parametrize("seed", range(3))
def test_re_solving_robot_pairs_finds_the_optimum_of_two_robots_from_a_poor_start(seed):
    p = random_problem(seed, robots=2, welds=6)
    start = first_reaching_routes(p)
    _, kept = improve_by_pairs(p, start)
    best = brute_force_makespan(p)
    if p.evaluate(start)["makespan"] > best + 2e-3:
        assert kept, "the poor start was kept"
    final = kept[-1] if kept else start
    assert p.evaluate(final)["makespan"] == pytest.approx(best, abs=2e-3)
    spans = [p.evaluate(r)["makespan"] for r in [start, *kept]]
    assert all(b <= a + 1e-9 for a, b in itertools.pairwise(spans))


def test_re_solving_robot_pairs_improves_three_robots_and_judges_answers_on_their_exact_legs():
    p = random_problem(7, robots=3, welds=7)
    start = first_reaching_routes(p)
    _, kept = improve_by_pairs(p, start)
    assert kept and p.evaluate(kept[-1])["makespan"] < p.evaluate(start)["makespan"] - 1.0
    # every leg the start does not take turns out 10x slower once planned: an answer that looked faster is then
    # slower, and none is kept
    used = {(r, a, b) for r, route in enumerate(start) for a, b in zip([r, *route], [*route, r])}
    calls = []

    def exact(routes):
        calls.append(routes)
        travel = p.travel.copy()
        for r, route in enumerate(routes):
            for a, b in zip([r, *route], [*route, r]):
                if (r, a, b) not in used:
                    travel[r, a, b] = 10 * p.travel[r, a, b]
        return replace(p, travel=travel)

    slow, kept = improve_by_pairs(p, start, exact)
    assert calls and kept == []
    assert slow.evaluate(calls[-1])["makespan"] > slow.evaluate(start)["makespan"]


def test_solver_is_deterministic_and_wear_objective_respects_the_makespan_cap():
    p = random_problem(11, robots=3, welds=6)
    p = replace(p, cost_rate=np.random.default_rng(3).uniform(1, 10, len(p.node_robot)))
    a, b = solve(p, "time", work=10), solve(p, "time", work=10)
    assert a.routes == b.routes
    cap = 1.1 * a.estimate["makespan"]
    w = solve(p, "wear", work=10, makespan_cap=cap)
    assert w.estimate["makespan"] <= cap + 1e-3
    assert w.estimate["wear"] <= a.estimate["wear"] + 1e-6
    with pytest.raises(ConfigError, match="objective"):
        solve(p, "cheapest")


def earliest_timed_makespan(p: RoutingProblem, routes: list[list[int]]) -> float:
    """The makespan of ``routes`` with every taken conflicting pair's weld starts ``conflict_wait`` apart, by
    enumeration: every choice of which weld of each pair goes first, earliest times by relaxing the precedences
    (a choice that makes a cycle is impossible)."""
    taken = {n for route in routes for n in route}
    pairs = [(int(a), int(b)) for a, b in p.conflicts if a in taken and b in taken]
    arcs = []  # (before, after, least time between their weld ends); Homes as ('home', r) / ('back', r)
    for r, route in enumerate(routes):
        path = [("home", r), *route, ("back", r)]
        nodes = [r, *route, r]
        t = p.leg_time(r)
        arcs += [(u, v, t[a, b]) for u, v, a, b in zip(path[:-1], path[1:], nodes[:-1], nodes[1:])]
    best = np.inf
    for first in itertools.product((True, False), repeat=len(pairs)):
        cons = arcs + [(a, b, p.conflict_wait) if f else (b, a, p.conflict_wait) for (a, b), f in zip(pairs, first)]
        end = {u: 0.0 for c in cons for u in c[:2]}
        for _ in range(len(end) + 1):
            changed = False
            for u, v, d in cons:
                if end[v] < end[u] + d - 1e-12:
                    end[v], changed = end[u] + d, True
            if not changed:
                best = min(best, max(end[("back", r)] for r in range(len(routes))))
                break
    return float(best)


def conflicted_problem(seed: int) -> RoutingProblem:
    """Two robots, four welds (one branch per robot that reaches it), some cross-robot option pairs in conflict."""
    p = random_problem(seed, robots=2, welds=4, branches=1)
    rng = np.random.default_rng(100 + seed)
    cross = [(a, b) for a in range(2, len(p.node_robot)) for b in range(a + 1, len(p.node_robot))
             if p.node_robot[a] != p.node_robot[b]]
    conflicts = np.array([c for c in cross if rng.random() < 0.7], dtype=int).reshape(-1, 2)
    return replace(p, conflicts=conflicts, conflict_wait=10.0)


def test_conflicting_welds_start_apart_and_the_wait_is_in_the_makespan():
    """Two robots, one weld each, 1 s from Home, 1 s welds, 3 s apart from each other, in conflict (3 s between
    their starts): split, one robot waits 2 s (makespan 6 s, not 3 s); one robot doing both takes 7 s. With 5 s
    between their starts the split takes 8 s, and one robot does both."""
    # nodes: Homes 0, 1; weld 0 by robot 0 (2) or 1 (5), weld 1 by robot 1 (3) or 0 (4)
    travel = np.full((2, 6, 6), 1.0)
    travel[0, 2, 4] = travel[0, 4, 2] = travel[1, 3, 5] = travel[1, 5, 3] = 3.0
    p = RoutingProblem(travel, np.ones(6), np.array([0, 1, 0, 1, 0, 1]), np.array([-1, -1, 0, 1, 1, 0]), 1.0, 2,
                       conflicts=np.array([[2, 3], [4, 5]]), conflict_wait=3.0)
    a = solve(p, "time", work=5)
    assert a.routes in ([[2], [3]], [[4], [5]])
    assert a.estimate["makespan"] == pytest.approx(3.0)  # legs and welds alone
    assert a.estimate["timed_makespan"] == pytest.approx(6.0)
    assert earliest_timed_makespan(p, a.routes) == pytest.approx(6.0)
    b = solve(replace(p, conflict_wait=5.0), "time", work=5)
    assert sorted(map(len, b.routes)) == [0, 2] and b.estimate["timed_makespan"] == pytest.approx(7.0)
    # the relaxation bound ignores the conflicts: the split's 3 s, a bound of both waits' plans
    assert relaxation_bound(p)["relaxation"] == pytest.approx(3.0)


@pytest.mark.parametrize("seed", [1, 2, 3, 5])  # problems whose interlocks change the best answer
def test_solver_with_interlocks_is_optimal_against_brute_force(seed):
    """With conflicting pairs the solver minimises the makespan including the waits they need: the same as
    enumerating every assignment, every order and every choice of which conflicting weld goes first."""
    p = conflicted_problem(seed)
    assert len(p.conflicts) > 0
    a = solve(p, "time", work=10)
    best = np.inf
    option = {(int(r), int(w)): n for n, (r, w) in enumerate(zip(p.node_robot, p.node_weld)) if w >= 0}
    for owner in itertools.product(range(2), repeat=p.n_welds):
        if any((r, w) not in option for w, r in enumerate(owner)):
            continue  # a robot that cannot reach the weld
        mine = [[option[(r, w)] for w in range(p.n_welds) if owner[w] == r] for r in range(2)]
        for r0 in itertools.permutations(mine[0]):
            for r1 in itertools.permutations(mine[1]):
                best = min(best, earliest_timed_makespan(p, [list(r0), list(r1)]))
    assert earliest_timed_makespan(p, a.routes) == pytest.approx(a.estimate["timed_makespan"], abs=2e-3)
    assert a.estimate["timed_makespan"] == pytest.approx(best, abs=2e-3)
    blind = solve(replace(p, conflicts=None), "time", work=10)  # the answer that ignores the interlocks
    assert earliest_timed_makespan(p, blind.routes) > best + 1.0


@pytest.fixture(scope="module")
def two_robot_station() -> Station:
    """The near side of the shipped side-framing station: robots r1 and r2, four of their welds."""
    cfg = load_station("side_framing_4r")
    names = ("r1_sill_1", "r1_b_pillar_1", "r2_b_pillar_1", "r2_sill_1")
    welds = tuple(w for w in cfg.weld_points if w.name in names)
    return Station(replace(cfg, robots=cfg.robots[:2], weld_points=welds))


def test_station_solver_is_optimal_on_a_two_robot_station(two_robot_station):
    planner = StationPlanner(two_robot_station, StationPlanConfig(kept_options=2, costed_options=2))
    task = make_station_task(two_robot_station, lambda r: planner.legs.planners[r].validity.checker.collides)
    assert all(set(task.candidates(w)) == {0, 1} for w in task.weld_names)  # both robots reach every weld
    options = planner.costs.choose(task, planner.config.costed_options, planner.config.kept_options)
    p = replace(planner.problem(task, options), conflicts=None)  # the pure min-max problem brute force solves
    a = solve(p, "time", work=10)
    assert a.estimate["makespan"] == pytest.approx(brute_force_makespan(p), abs=2e-3)
    assert all(len(route) for route in a.routes)  # the min-max splits the welds over both robots


def test_schedule_timing_follows_the_time_law_with_welds_and_waits():
    limits = JointLimits(np.full(6, 1.0), np.full(6, 4.0), np.full(6, 40.0))
    home, a, b = np.zeros(6), np.full(6, 0.3), np.array([0.5, 0, 0, 0, 0, 0])
    s = RobotSchedule.as_soon_as_possible(0, ["w1", "w2"], [np.array([home, a]), np.array([a, b]), np.array([b, home])],
                                          limits, weld_time=2.0)
    d = [float(segment_durations(x - y, limits)) for x, y in [(a, home), (b, a), (home, b)]]
    assert s.end_time == pytest.approx(sum(d) + 4.0)
    q, qd = s.at([d[0], d[0] + 1.0, d[0] + 2.0, s.end_time + 5.0, -1.0])
    np.testing.assert_allclose(q[0], a)
    np.testing.assert_allclose(q[1], a)  # welding: standing still at the weld
    np.testing.assert_allclose(qd[1], 0.0)
    np.testing.assert_allclose(q[3], home)
    np.testing.assert_allclose(q[4], home)
    mid = s.at([d[0] / 2])[0][0]
    np.testing.assert_allclose(mid, a / 2)  # a rest-to-rest profile is symmetric: half way at half time
    late = s.delayed(1, 3.0)
    assert late.waits().tolist() == pytest.approx([0.0, 3.0, 0.0])
    assert late.end_time == pytest.approx(s.end_time + 3.0)
    assert late.intervals()["wait"] == [pytest.approx((d[0] + 2.0, d[0] + 5.0))]
    # what the robot does, read off the same timing: moving, welding, waiting (the delay), done once Home
    t = [d[0] / 2, d[0] + 1.0, d[0] + 3.0, d[0] + 5.0 + d[1] / 2, late.end_time + 1.0]
    assert [PHASES[k] for k in late.phase_at(t)] == ["moving", "welding", "waiting", "moving", "done"]


def test_the_wear_split_gives_each_phase_its_time_at_its_rate():
    """A replay whose cost is constant per phase: each phase's share is its rate x its duration, and the shares
    (and the terms) sum to the integrated cost."""
    limits = JointLimits(np.full(6, 1.0), np.full(6, 4.0), np.full(6, 40.0))
    home, a = np.zeros(6), np.full(6, 0.3)
    s = RobotSchedule.as_soon_as_possible(0, ["w1"], [np.array([home, a]), np.array([a, home])], limits, 2.0)
    s = s.delayed(1, 1.5)  # 1.5 s waiting at the weld after welding
    makespan = s.end_time + 3.0  # another robot finishes later: 3 s done at Home
    t = np.linspace(0.0, makespan, 4001)
    rate = {"moving": 10.0, "welding": 4.0, "waiting": 7.0, "done": 1.0}
    phase = np.array([PHASES[k] for k in s.phase_at(t)])
    cost = np.array([rate[p] for p in phase])[:, None]
    stay = StationSchedule((s, RobotSchedule.as_soon_as_possible(1, [], [np.array([home, home])], limits, 2.0)),
                           np.zeros((2, 6)))
    rep = StationReplay(t, {}, np.hstack([cost, np.full_like(cost, 2.0)]), makespan,
                        terms={"curvature": np.hstack([cost, np.full_like(cost, 2.0)]) * 0.25,
                               "distance": np.hstack([cost, np.full_like(cost, 2.0)]) * 0.75})
    split = rep.wear_split(stay)
    moving = float(np.sum(s.leg_durations()))
    expected = {"moving": 10.0 * moving, "welding": 4.0 * 2.0, "waiting": 7.0 * 1.5, "done": 1.0 * 3.0}
    for p, v in expected.items():  # within one sample interval's worth of rate at each of the 6 phase changes
        assert split[0]["by_phase"][p] == pytest.approx(v, abs=6 * 10.0 * (t[1] - t[0]))
    assert sum(split[0]["by_phase"].values()) == pytest.approx(rep.integrated_cost()[0], rel=1e-12)
    assert split[1]["by_phase"] == pytest.approx({"moving": 0.0, "welding": 0.0, "waiting": 0.0,
                                                  "done": 2.0 * makespan})
    assert sum(split[0]["by_term"].values()) == pytest.approx(rep.integrated_cost()[0], rel=1e-12)
    assert split[0]["by_term"]["distance"] == pytest.approx(3 * split[0]["by_term"]["curvature"])


def _both_to_one_weld(station: Station) -> StationSchedule:
    """Both robots sent to the same weld option at the same time (a collision by construction)."""
    task = make_station_task(station, lambda r: None, ["r2_b_pillar_1"])
    q = {r: next(o.q for o in task.options["r2_b_pillar_1"] if o.robot == r) for r in (0, 1)}
    limits = station.config.robots[0].robot.joint_motion_limits.at_speed(station.config.simulation.speed_fraction)
    robots = tuple(RobotSchedule.as_soon_as_possible(r, ["r2_b_pillar_1"], [np.array([task.homes[r], q[r]]),
                                                                             np.array([q[r], task.homes[r]])],
                                                     limits, 1.0) for r in (0, 1))
    return StationSchedule(robots, task.homes)


def test_coordination_resolves_a_conflict_by_waiting_and_the_dense_check_confirms_it(two_robot_station):
    schedule = _both_to_one_weld(two_robot_station)
    pairs = RobotPairDistance(two_robot_station)
    before = verify(two_robot_station, schedule, pairs=pairs)
    assert before["collisions"] > 0 and before["min_distance"] < 0
    fixed, info = coordinate(two_robot_station, schedule, pairs)
    assert info["resolved"] and info["waits"] > 0
    after = verify(two_robot_station, fixed, pairs=pairs)
    assert after["collisions"] == 0 and after["min_distance"] > 0
    # the robot that waited did so while the other was at the weld: its wait covers the other's weld
    first = fixed.robot(info["order"][0])
    second = fixed.robot(info["order"][1])
    assert second.leg_start[0] >= first.leg_end()[0] + first.weld_time - second.leg_durations()[0]


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_coordination_keeps_the_order_of_least_makespan(two_robot_station):
    """Both robots to one weld; r2 welds 5 s, r1 1 s. Placing the longest program first (r2, r1 waits for it)
    ends later than letting r1 through first: coordination tries both orders and keeps the shorter, which is
    the shortest of the orders tried one by one."""
    task = make_station_task(two_robot_station, lambda r: None, ["r2_b_pillar_1"])
    q = {r: next(o.q for o in task.options["r2_b_pillar_1"] if o.robot == r) for r in (0, 1)}
    limits = two_robot_station.config.robots[0].robot.joint_motion_limits.at_speed(
        two_robot_station.config.simulation.speed_fraction)
    robots = tuple(RobotSchedule.as_soon_as_possible(r, ["r2_b_pillar_1"], [np.array([task.homes[r], q[r]]),
                                                                             np.array([q[r], task.homes[r]])],
                                                     limits, weld) for r, weld in ((0, 1.0), (1, 5.0)))
    schedule = StationSchedule(robots, task.homes)
    assert robots[1].end_time > robots[0].end_time
    pairs = RobotPairDistance(two_robot_station)
    each = {o: coordinate(two_robot_station, schedule, pairs, order=o)[0].makespan for o in ((0, 1), (1, 0))}
    assert each[(0, 1)] < each[(1, 0)] - 0.05  # the longest-first order is the worse one here
    fixed, info = coordinate(two_robot_station, schedule, pairs)
    assert info["resolved"] and info["order"] == [0, 1]
    assert fixed.makespan == pytest.approx(min(each.values()), abs=1e-12)
    assert verify(two_robot_station, fixed, pairs=pairs)["collisions"] == 0
    # with a shorter makespan in hand elsewhere, no order is worth finishing; with a longer one the same answer
    assert coordinate(two_robot_station, schedule, pairs, cap=fixed.makespan - 0.01)[0] is None
    capped, capped_info = coordinate(two_robot_station, schedule, pairs, cap=fixed.makespan + 0.01)
    assert capped.makespan == fixed.makespan and capped_info["order"] == info["order"]


def test_pair_distance_matches_base_separation(two_robot_station):
    """At Home both robots stand 1.8 m apart along y: the nearest surfaces are closer than the bases' centres and
    farther than zero; moving r2's base 0.5 m closer (same poses) brings them exactly 0.5 m closer, as long as the
    nearest points stay the nearest (a rigid translation along the line joining them)."""
    pairs = RobotPairDistance(two_robot_station)
    pairs.pose(two_robot_station.home)
    d = pairs.distance(0, 1)
    assert 0 < d < 1.8
    cfg = two_robot_station.config
    moved = replace(cfg.robots[1], base_pos=(cfg.robots[1].base_pos[0], cfg.robots[1].base_pos[1] - 0.5, 0.0))
    closer = Station(replace(cfg, robots=(cfg.robots[0], moved), weld_points=()))
    p2 = RobotPairDistance(closer)
    p2.pose(closer.home)
    assert p2.distance(0, 1) == pytest.approx(d - 0.5, abs=1e-6)


def test_follow_drives_the_cables_like_move_to(two_robot_station):
    """A timed program that is one straight segment gives the same cables as move_to (same steps, same law):
    r1 turns its base for about 0.5 s (exactly a whole number of steps), r2 stands still."""
    st = two_robot_station
    limits = st.config.robots[0].robot.joint_motion_limits.at_speed(st.config.simulation.speed_fraction)
    duration = round(0.5 / st.model.opt.timestep) * st.model.opt.timestep
    lo, hi = 0.0, 1.0  # the base turn that takes `duration` (the law's time grows with the distance)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if segment_durations(np.array([mid, 0, 0, 0, 0, 0]), limits) < duration else (lo, mid)
    target = st.home.copy()
    target[0, 0] += 0.5 * (lo + hi)
    a, b = CableSimulator(st), CableSimulator(st)
    a.reset(st.home)
    b.reset(st.home)
    a.move_to(target, settle=False)
    program = StationSchedule((
        RobotSchedule.as_soon_as_possible(0, [], [np.array([st.home[0], target[0]])], limits, 0.0),
        RobotSchedule.as_soon_as_possible(1, [], [np.array([st.home[1], st.home[1]])], limits, 0.0)), st.home)
    assert program.makespan == pytest.approx(duration)
    b.follow(program.at, duration, record_every=0.1)
    assert b.motion_time == pytest.approx(a.motion_time)
    np.testing.assert_allclose(b.cable_points(0), a.cable_points(0), atol=1e-6)
    np.testing.assert_allclose(b.cable_points(1), a.cable_points(1), atol=1e-6)


def test_a_weld_no_robot_can_reach_is_named(two_robot_station):
    cfg = two_robot_station.config
    far = replace(cfg.weld_points[0], name="far_away", pos=(20.0, 0.0, 1.0))
    st = Station(replace(cfg, weld_points=(*cfg.weld_points, far)))
    with pytest.raises(ConfigError, match=r"weld_points\.far_away: no robot can weld it \(r1: out of reach; "
                                          r"r2: out of reach\)"):
        make_station_task(st, lambda r: None)


def test_overlapping_robot_bases_are_named(two_robot_station):
    cfg = two_robot_station.config
    on_top = replace(cfg.robots[1], base_pos=(cfg.robots[0].base_pos[0] + 0.3, cfg.robots[0].base_pos[1], 0.0))
    with pytest.raises(ConfigError, match=r"robots\[1\].*'r2' overlaps robot 'r1'"):
        Station(replace(cfg, robots=(cfg.robots[0], on_top), weld_points=()))


def test_an_empty_robot_list_is_refused(tmp_path):
    path = tmp_path / "empty.yaml"
    path.write_text("name: empty\nrobots: []\nweld_points: []\n")
    with pytest.raises(ConfigError, match="robots: a station needs at least one robot"):
        load_station(path)


def test_plan_config_errors_name_the_field():
    with pytest.raises(ConfigError, match="objective"):
        StationPlanConfig(objective="fast")
    with pytest.raises(ConfigError, match="weld_time"):
        StationPlanConfig(weld_time=-1)
    with pytest.raises(ConfigError, match="pair_solves"):
        StationPlanConfig(pair_solves=-1)
    with pytest.raises(ConfigError, match="bound_work"):
        StationPlanConfig(bound_work=0)
    assert isinstance(StationConfig, type)




@pytest.mark.slow  # two station plans with replays and pictures (~45 s)
def test_station_plan_command_writes_plans_pictures_and_a_comparison(tmp_path, capsys):
    from dresspack_gym.cli.main import main

    station = near_side_yaml(tmp_path)
    out = tmp_path / "plans"
    code = main(["station-plan", "--station", str(station), "--objective", "time", "wear", "--work", "0.5",
                 "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 0, text
    import json

    summary = json.loads((out / "summary.json").read_text())
    assert set(summary) == {"time", "wear"}
    for objective, s in summary.items():
        assert s["verification"]["collisions"] == 0
        assert sorted(w for ws in s["welds"].values() for w in ws) == sorted(
            ["r1_sill_1", "r1_b_pillar_1", "r2_b_pillar_1", "r2_sill_1"])
        assert s["makespan"] >= s["makespan_lower_bound"] - 1e-9
        assert s["replay"]["cost"] > 0 and s["replay"]["jammed"] == []
        assert s["replay"]["start_settled"] and s["replay"]["start_force_residual"] < 0.02
        # a weld whose costing settle did not come to rest (the cable creeping on the robot's arm) is named, and
        # the printed line says so
        unsettled = s["info"]["unconverged_cost_settles"]
        assert set(unsettled) <= {"r1_sill_1", "r1_b_pillar_1", "r2_b_pillar_1", "r2_sill_1"}
        if unsettled:
            assert "come from" in text
        for f in ("plan.json", "gantt.png", "wear.png", "assignment.png", "r1.npz", "r2.npz"):
            assert (out / objective / f).is_file(), f
    # the wear objective keeps within its makespan slack of the time plan it is compared with
    wear = summary["wear"]
    assert wear["coordination"]["makespan_reference"] == pytest.approx(summary["time"]["makespan"], abs=1e-3)
    assert wear["makespan"] <= 1.1 * summary["time"]["makespan"] + 1e-3
    # the time plan is one of its candidates: it is never worse on its own measure than the time plan (within
    # the slack, which the time plan meets)
    assert wear["estimate"]["wear_with_waits"] <= summary["time"]["estimate"]["wear_with_waits"] + 1e-6
    assert "summary.md" in text
    for s in summary.values():  # the replayed wear, split by phase and by the cost's terms, adds up
        split = s["replay"]["wear_split"]
        assert sum(sum(r["by_phase"].values()) for r in split.values()) == pytest.approx(s["replay"]["cost"])
        assert sum(sum(r["by_term"].values()) for r in split.values()) == pytest.approx(s["replay"]["cost"])
        welding = sum(r["by_phase"]["welding"] for r in split.values())
        assert welding >= 0.9 * s["info"]["cheapest_weld_wear"]  # the cables move a little while welding
    assert "Where the replayed wear" in (out / "summary.md").read_text()
    # the wear objective states the least wear estimate its options allow within its cap; the time plan has none
    bound = wear["wear_estimate_bound"]
    assert bound["makespan_cap"] == pytest.approx(wear["coordination"]["makespan_cap"], abs=1e-3)
    assert 0 < bound["bound"] <= bound["best"] + 1e-9
    assert "wear_estimate_bound" not in summary["time"]
    assert "have a wear estimate below" in (out / "summary.md").read_text()
    # dresspack eval compares the plans like planners: replayed again in the same simulator, the same figures
    compared = tmp_path / "compared"
    assert main(["eval", "--station-plans", str(out / "time"), str(out / "wear"), "--station", str(station),
                 "--out", str(compared)]) == 0
    rows = json.loads((compared / "station_comparison.json").read_text())
    assert [r["plan"] for r in rows] == ["time", "wear"]
    for r in rows:
        s = summary[r["plan"]]
        assert r["makespan"] == pytest.approx(s["makespan"], abs=1e-3)
        assert r["cost"] == pytest.approx(s["replay"]["cost"], rel=1e-9)
        assert (r["collisions"], r["samples"]) == (s["verification"]["collisions"], s["verification"]["samples"])
        assert r["max_tension"] == pytest.approx(max(x["max_tension"] for x in s["replay"]["robots"].values()))
        assert r["reversals_per_s"] >= 0 and r["peak_joint_acceleration"] > 0
    for f in ("station_comparison.md", "station_comparison.csv", "station_wear.png"):
        assert (compared / f).is_file(), f
    capsys.readouterr()
    assert main(["eval", "--station-plans", str(tmp_path), "--station", str(station), "--out", str(compared)]) == 2
    assert "station_plans" in capsys.readouterr().err
    assert main(["eval", "--station-plans", str(out / "time"), "--station", "default", "--out", str(compared)]) == 2
    assert "station" in capsys.readouterr().err


def test_station_plan_command_names_a_weld_no_robot_can_reach(tmp_path, capsys):
    from dresspack_gym.cli.main import main

    far = {"name": "far_away", "robot": "r1", "pos": [20.0, 0.0, 1.0], "approach": [0, 0, -1]}
    station = near_side_yaml(tmp_path, extra=[far])
    assert main(["station-plan", "--station", str(station), "--out", str(tmp_path / "x"), "--json"]) == 2
    import json

    err = json.loads(capsys.readouterr().out)
    assert err["field"] == "weld_points.far_away" and "no robot can weld it" in err["error"]


def test_a_cable_pulled_beyond_the_jam_strain_is_flagged():
    """The flag is EA x 5 % per cable: a 1e7 N tension (a cable pinned by a robot) is flagged, 100 N is not."""
    from dresspack_gym.multi.replay import JAM_STRAIN

    ea = np.array([2.0e5, 2.0e5])
    tension = np.array([[10.0, 20.0], [100.0, 1e7], [50.0, 30.0]])
    measures = {k: np.zeros((3, 2)) for k in ("curvature", "clearance", "twist_rate")}
    measures["tension"] = tension
    rep = StationReplay(np.array([0.0, 0.1, 0.2]), measures, np.ones((3, 2)), 0.2, JAM_STRAIN * ea)
    assert rep.jammed() == [1]
    assert rep.summary(["a", "b"])["jammed"] == ["b"]


def test_a_cost_settle_that_does_not_reach_equilibrium_is_reported(two_robot_station, tmp_path):
    """With no time to settle (MuJoCo's settle runs for a time; the rod engine solves for rest), the option's cost
    comes from a shape that is not an equilibrium: it is listed, and the verdict survives the cost cache."""
    cfg = two_robot_station.config
    hurried = Station(replace(cfg, simulation=replace(cfg.simulation, settle_time=0.0)))
    planner = StationPlanner(hurried, StationPlanConfig(physics="dynamic"))
    task = make_station_task(hurried, lambda r: None, ["r1_sill_1"])
    option = task.options["r1_sill_1"][0]
    planner.costs.rate(option.robot, option.q)
    assert planner.costs.unconverged_options([option]) == ["r1_sill_1"]
    planner.costs.save(tmp_path / "costs.json")
    again = StationPlanner(two_robot_station, StationPlanConfig(physics="dynamic"))
    again.costs.load(tmp_path / "costs.json")
    assert again.costs.unconverged_options([option]) == ["r1_sill_1"]
    settled = StationPlanner(two_robot_station, StationPlanConfig(physics="dynamic"))
    settled.costs.rate(option.robot, option.q)
    assert settled.costs.unconverged_options([option]) == []


@pytest.mark.slow  # about 15-20 s on 2 cores: the fast tier's time
def test_a_leg_that_jams_its_cable_is_rerouted_then_blocked(two_robot_station):
    """The replay's verdict reaches the plan: a jam found while robot 0 runs its second leg blames that leg; the
    leg is re-routed (another OMPL route, or through Home), and once the re-routes are spent it is blocked for
    the solver. Another objective's planner does not inherit the re-routes."""
    from dresspack.agents.stations import BLOCKED, REROUTES

    planner = StationPlanner(two_robot_station, StationPlanConfig(kept_options=2, costed_options=2, cable_repairs=0,
                                                                  work=0.5))
    plan = planner.plan()
    assert plan.replay is None and "cable_replays" not in plan.info  # no repairs: planning alone, as before
    s = plan.schedule.robot(0)
    assert len(s.legs) >= 3
    t = np.arange(0.0, plan.schedule.makespan, 0.05)
    tension = np.zeros((len(t), 2))
    mid = 0.5 * (s.leg_start[1] + s.leg_end()[1])
    tension[t >= mid, 0] = 1e4  # robot 0's cable jams half way through leg 1 and stays jammed
    measures = {k: np.zeros((len(t), 2)) for k in ("curvature", "clearance", "twist_rate")}
    plan.replay = StationReplay(t, {**measures, "tension": tension}, np.ones((len(t), 2)), t[-1],
                                np.array([70.0, 70.0]))
    qs = np.vstack([plan.task.homes, [o.q for o in plan.options]])
    path = [0, *plan.assignment.routes[0], 0]
    assert jammed_legs(plan, qs) == [(0, path[1], path[2])]
    # while it stands at the weld after the leg, the leg into that weld is still the one blamed
    tension[:] = 0.0
    tension[t >= s.leg_end()[1] + 0.1, 0] = 1e4
    assert jammed_legs(plan, qs) == [(0, path[1], path[2])]
    # a robot that stays Home has no leg to blame: its cable was pinned by another robot
    idle = copy.copy(plan)
    idle.assignment = replace(plan.assignment, routes=[[], plan.assignment.routes[1]])
    assert jammed_legs(idle, qs) == []

    old = planner.legs.leg(0, path[1], path[2], qs)
    stops = ["Home"] * 2 + [o.weld for o in plan.options]
    done = [reroute(planner.legs, two_robot_station.home, planner.names, 0, path[1], path[2], qs, stops, "test",
                    1.0)["now"] for _ in range(len(REROUTES) + 1)]
    assert done[-1] == "blocked" and set(done[:-1]) <= {*REROUTES, "blocked"}
    assert planner.legs.leg(0, path[1], path[2], qs) is None
    assert planner.problem(plan.task, plan.options).travel[0, path[1], path[2]] == BLOCKED
    other = planner.reconfigured(replace(planner.config, objective="wear"))
    np.testing.assert_array_equal(other.legs.leg(0, path[1], path[2], qs), old)


def test_the_solver_reads_a_simulated_leg_wear_where_there_is_one():
    """Without a simulation the leg's wear is the estimate (motion at the mean settled rate, then the weld); a
    simulated value replaces it for that leg only."""
    p = random_problem(3)
    estimate = p.leg_wear(0)
    c = p.cost_rate
    i, j = 0, int(np.flatnonzero(p.node_robot == 0)[1])
    assert estimate[i, j] == pytest.approx(p.travel[0, i, j] * 0.5 * (c[i] + c[j]) + p.weld_time * c[j])
    simulated = np.full(p.travel.shape, np.nan)
    simulated[0, i, j] = 123.0
    q = replace(p, simulated_wear=simulated)
    wear = q.leg_wear(0)
    assert wear[i, j] == 123.0
    wear[i, j] = estimate[i, j]
    np.testing.assert_array_equal(wear, estimate)
    np.testing.assert_array_equal(q.leg_wear(1), p.leg_wear(1))


def test_a_simulated_leg_standing_still_wears_at_its_settled_rate(two_robot_station):
    """A leg that does not move, run for 2 s: its cable stays settled, so its wear is the settled cost rate
    times 2 s (the same settle, the same cost function); a real leg's wear is that of its samples."""
    planner = StationPlanner(two_robot_station, StationPlanConfig())
    task = make_station_task(two_robot_station, lambda r: None, ["r1_sill_1"])
    q = task.options["r1_sill_1"][0].q
    rate = planner.costs.rate(0, q)
    still = planner.legs.run(0, np.array([q, q]), 2.0)
    assert still.start_settled and not still.jammed
    assert still.wear == pytest.approx(2.0 * rate, rel=2e-3)
    moved = planner.legs.run(0, np.array([two_robot_station.home[0], q]), 1.0)
    assert moved.wear > 0 and moved.max_tension > 0
    assert planner.legs.run(0, np.array([two_robot_station.home[0], q]), 1.0) is moved  # cached


@pytest.mark.slow  # two station plans with leg cable runs (~30 s)
def test_a_leg_that_jams_its_cable_alone_is_rerouted_while_planning(two_robot_station, monkeypatch):
    """The cable run of every chosen leg reaches the plan without a station replay: a leg whose run jams the
    cable is re-routed or blocked, logged with its reason, and the plan no longer uses it."""
    from dresspack.agents.stations import LegRun

    config = StationPlanConfig(kept_options=2, costed_options=2, cable_repairs=0, work=0.5)
    first = StationPlanner(two_robot_station, config).plan()
    bad = first.schedule.robot(0).legs[0]
    planner = StationPlanner(two_robot_station, config)
    real = planner.legs.run

    def run(robot, leg, weld_time):
        out = real(robot, leg, weld_time)
        if robot == 0 and np.array_equal(leg, bad):
            return LegRun(out.wear, 1e6, True, out.start_settled)
        return out

    monkeypatch.setattr(planner.legs, "run", run)
    plan = planner.plan()
    moved = plan.info["rerouted_legs"]
    assert moved and moved[0]["robot"] == "r1" and moved[0]["from"] == "Home"
    assert moved[0]["why"] == "jammed its cable alone"
    assert not any(np.array_equal(leg, bad) for leg in plan.schedule.robot(0).legs)
    assert plan.info["simulated_legs"] > 0


@pytest.mark.slow  # a station plan, a replay and a repair round (~30 s)
def test_a_cable_repair_keeps_the_answers_found_before_it(two_robot_station, monkeypatch):
    """A jam found in the station replay re-routes its leg and the station is planned again: the answers of the
    rounds before are still candidates then (their jammed leg re-routed), not thrown away."""
    config = StationPlanConfig(kept_options=2, costed_options=2, cable_repairs=1, work=0.5)
    planner = StationPlanner(two_robot_station, config)
    import dresspack.agents.stations.planner as planning

    before, calls = [], []

    def jam_once(plan, qs):  # the first replay's verdict: the first leg of a robot that works jammed
        calls.append(len(planner.candidates))
        if not before:
            before.extend(planner.candidates)
            r = next(r for r, route in enumerate(plan.assignment.routes) if route)
            return [(r, r, plan.assignment.routes[r][0])]
        return jammed_legs(plan, qs)

    monkeypatch.setattr(planning, "jammed_legs", jam_once)
    planner.plan()
    assert len(calls) == 2 and calls[1] > calls[0]  # the repair's rounds added answers to the earlier ones
    assert before and all(any(c is b for c in planner.candidates) for b in before)


def brute_force_wear(p: RoutingProblem, cap: float) -> float:
    """The least wear within a makespan cap by enumeration, counting the cables of robots done early hanging at
    Home until the makespan (every weld to every robot, every order, every option)."""
    best = np.inf
    for per_robot in assignments(p):
        for combo in itertools.product(*per_robot):
            ends = [c[0] for c in combo]
            if max(ends) <= cap:
                best = min(best, sum(c[1] for c in combo) + p.idle_wear(ends, max(ends)))
    return float(best)


def brute_force_route_wear(p: RoutingProblem, cap: float) -> float:
    """The least summed route wear (no cables hanging at Home) of routes whose every robot is back within ``cap``."""
    best = np.inf
    for per_robot in assignments(p):
        for combo in itertools.product(*per_robot):
            if max(c[0] for c in combo) <= cap:
                best = min(best, sum(c[1] for c in combo))
    return float(best)


@pytest.mark.parametrize("seed", [0, 1])
def test_wear_relaxation_bounds_the_least_wear_within_the_cap_per_group_of_robots(seed):
    """Each group of robots that share welds is solved alone to the brute-force optimum of its route wear, the
    station's bound is their sum, it never exceeds the wear objective's answer (which also counts Home waits), and
    a cap no routes meet bounds anything."""
    rng = np.random.default_rng(seed)
    a, b = random_problem(seed, robots=2, welds=4), random_problem(seed + 10, robots=2, welds=3)
    a, b = (replace(x, cost_rate=rng.uniform(1, 10, len(x.node_robot))) for x in (a, b))
    p = glued(a, b)
    p = replace(p, cost_rate=np.concatenate([a.cost_rate[:2], b.cost_rate[:2], a.cost_rate[2:], b.cost_rate[2:]]))
    cap = 1.1 * solve(p, "time", work=10).estimate["makespan"]
    bound = wear_relaxation_bound(p, cap, work=20)
    assert [g["robots"] for g in bound["components"]] == [[0, 1], [2, 3]]
    expect = brute_force_route_wear(a, cap) + brute_force_route_wear(b, cap)
    assert bound["best"] == pytest.approx(expect, rel=1e-4)
    assert expect - 1e-3 <= bound["bound"] <= expect + 1e-9
    assert bound["bound"] <= solve(p, "wear", work=10, makespan_cap=cap).estimate["wear"] + 1e-9
    tighter = wear_relaxation_bound(p, 0.8 * cap, work=20)["bound"]
    assert tighter >= bound["bound"] - 1e-9  # less time allows no less wear
    assert wear_relaxation_bound(p, 1e-3, work=5)["bound"] == np.inf


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_wear_objective_is_optimal_against_brute_force_with_the_cables_waiting_at_home(seed):
    """The wear objective minimises what a station replay measures: the routes' wear plus the cables of robots
    done early hanging at Home until the makespan (Home rates made large so that this term matters)."""
    p = random_problem(seed, robots=2, welds=4)
    rates = np.random.default_rng(seed).uniform(1, 10, len(p.node_robot))
    rates[:2] = 40.0
    p = replace(p, cost_rate=rates)
    cap = 1.1 * solve(p, "time", work=10).estimate["makespan"]
    w = solve(p, "wear", work=10, makespan_cap=cap)
    assert w.estimate["optimal"]
    assert w.estimate["wear"] == pytest.approx(brute_force_wear(p, cap), rel=2e-3)
    ends = w.estimate["robot_times"]
    assert w.estimate["idle_wear"] == pytest.approx(sum(rates[r] * (max(ends) - e) for r, e in enumerate(ends)))


@pytest.mark.slow  # three station plans (about 3 min)
def test_an_objective_plans_the_same_whatever_was_planned_before_it(two_robot_station, monkeypatch):
    """``dresspack station-plan`` plans its objectives with one planner (the legs are reused): the wear plan after
    a time plan equals the wear plan of a fresh planner, and the time plan inside it equals the time plan (which
    the planner reuses instead of planning it again)."""
    config = StationPlanConfig(kept_options=2, costed_options=2, cable_repairs=0, work=0.5)
    first = StationPlanner(two_robot_station, config)
    timed = first.plan()
    solved = []
    original = StationPlanner._rounds
    monkeypatch.setattr(StationPlanner, "_rounds",
                        lambda self, *a, **k: solved.append(self.config.objective) or original(self, *a, **k))
    after = first.reconfigured(replace(config, objective="wear")).plan()
    assert solved == ["wear"]  # the time candidate is the time plan above, not planned again
    fresh = StationPlanner(two_robot_station, replace(config, objective="wear")).plan()
    assert solved == ["wear", "time", "wear"]
    assert after.assignment.routes == fresh.assignment.routes
    assert after.schedule.makespan == fresh.schedule.makespan
    assert after.assignment.estimate["wear_with_waits"] == fresh.assignment.estimate["wear_with_waits"]
    assert after.assignment.estimate["wear_with_waits"] <= timed.assignment.estimate["wear_with_waits"] + 1e-9
    # the makespan bound is one of the options, not of the legs an objective happened to plan: the same for both
    assert after.bound == timed.bound and timed.bound["bound"] <= timed.schedule.makespan


def test_planned_ratio_times_unplanned_moves_like_the_detours_planned_so_far(two_robot_station):
    """``blocked_estimate="planned_ratio"`` (the default): a move that is neither a valid straight move nor
    planned is timed as its straight move slowed by the median of the planned detours' slow-downs; planned legs
    keep their exact times, and ``"straight"`` keeps the straight-move time (a lower bound)."""
    planner = StationPlanner(two_robot_station, StationPlanConfig(kept_options=2, costed_options=2,
                                                                  blocked_estimate="straight"))
    task = make_station_task(two_robot_station, lambda r: planner.legs.planners[r].validity.checker.collides)
    options = planner.costs.choose(task, planner.config.costed_options, planner.config.kept_options)
    planner.legs.check_straight_moves(task, options)
    qs = np.vstack([task.homes, [o.q for o in options]])
    straight = straight_times(qs, planner.legs.limits)
    base = planner.problem(task, options).travel
    node_robot = np.concatenate([[0, 1], [o.robot for o in options]])
    own = [(r, i, j) for r in range(2) for i, j in itertools.permutations(range(len(qs)), 2)
           if node_robot[i] == r == node_robot[j]]
    blocked = [(r, i, j) for r, i, j in own if _leg_key(r, qs[i], qs[j]) not in planner.legs.known]
    assert len(blocked) >= 2
    np.testing.assert_array_equal(base, straight)  # nothing planned but straight moves: all straight times
    (r, i, j), rest = blocked[0], blocked[1:]
    detour = np.array([qs[i], 0.5 * (qs[i] + qs[j]) + 0.2, qs[j]])  # a planned leg by a via point
    key = _leg_key(r, qs[i], qs[j])
    planner.legs.paths[key] = detour
    planner.legs.known.add(key)
    exact = time_law.path_duration(detour, planner.legs.limits[r])
    ratio = exact / straight[r, i, j]
    assert ratio > 1.0
    lower = planner.problem(task, options).travel
    assert lower[r, i, j] == exact and all(lower[x] == straight[x] for x in rest)
    scaled = planner.reconfigured(replace(planner.config, blocked_estimate="planned_ratio"))
    scaled.legs.known = set(planner.legs.known)
    travel = scaled.problem(task, options).travel
    assert travel[r, i, j] == exact
    for x in rest:
        assert travel[x] == pytest.approx(straight[x] * ratio, rel=1e-12)
    valid = [x for x in own if x not in blocked]
    assert valid and all(travel[x] == straight[x] for x in valid)  # valid straight moves are exact already


@pytest.mark.parametrize("seed", [0, 1])
def test_re_solving_robot_pairs_for_wear_finds_the_least_wear_within_the_cap(seed):
    """Two robots (the pair is the whole station): from the time answer to the least wear within the makespan cap,
    as brute force finds it; every kept answer within the cap and wearing less than the one before."""
    p = random_problem(seed, robots=2, welds=4)
    rates = np.random.default_rng(seed).uniform(1, 10, len(p.node_robot))
    rates[:2] = 40.0
    p = replace(p, cost_rate=rates)
    start = solve(p, "time", work=10)
    cap = 1.1 * start.estimate["makespan"]
    _, kept = improve_by_pairs(p, start.routes, objective="wear", makespan_cap=cap)
    final = kept[-1] if kept else start.routes
    assert p.evaluate(final)["wear"] == pytest.approx(brute_force_wear(p, cap), rel=2e-3)
    wear = [p.evaluate(r)["wear"] for r in [start.routes, *kept]]
    assert all(b < a for a, b in itertools.pairwise(wear))
    assert all(p.evaluate(r)["timed_makespan"] <= cap + 1e-9 for r in kept)
    with pytest.raises(ConfigError, match="makespan_cap"):
        improve_by_pairs(p, start.routes, objective="wear")


def test_every_move_planned_up_front_is_exact_both_ways_and_resumes_from_its_cache(two_robot_station, tmp_path,
                                                                                     monkeypatch):
    """``plan_every_move``: every robot's moves between its Home and options are planned (in worker processes),
    each the same path both ways, and the solver times every one of them exactly. The legs go to a
    cache file as they finish; a later run reads them back (a torn last line is planned again), and a cache
    written with other settings is ignored. Workers change nothing."""
    from dresspack.agents.stations import legs_up_front as station_legs

    cfg = StationPlanConfig(kept_options=1, costed_options=1)
    planner = StationPlanner(two_robot_station, cfg)
    task = make_station_task(two_robot_station, lambda r: planner.legs.planners[r].validity.checker.collides)
    options = planner.costs.choose(task, planner.config.costed_options, planner.config.kept_options)
    planner.legs.check_straight_moves(task, options)
    cache = tmp_path / "planned_legs.jsonl"
    planner.legs.plan_every_move(task, options, cache, workers=2)
    qs = np.vstack([task.homes, [o.q for o in options]])
    node_robot = np.concatenate([[0, 1], [o.robot for o in options]])
    own = [(r, i, j) for r in range(2) for i, j in itertools.permutations(range(len(qs)), 2)
           if node_robot[i] == r == node_robot[j]]
    assert all(_leg_key(r, qs[i], qs[j]) in planner.legs.known for r, i, j in own)
    travel = planner.problem(task, options).travel
    detours = 0
    for r, i, j in own:
        leg, back = planner.legs.paths[_leg_key(r, qs[i], qs[j])], planner.legs.paths[_leg_key(r, qs[j], qs[i])]
        np.testing.assert_array_equal(leg, back[::-1])
        assert planner.legs.planners[r].validity.path_valid(leg)
        assert travel[r, i, j] == planner.legs.motion(r, leg).duration == pytest.approx(travel[r, j, i], abs=1e-12)
        detours += len(leg) > 2
    assert detours >= 2  # some moves are blocked as straight moves: these are planned paths
    planned = [line for line in cache.read_text().splitlines()[1:]]
    assert len(planned) >= detours // 2

    def refuse(*a, **k):
        raise AssertionError("a cached leg was planned again")

    again = StationPlanner(two_robot_station, cfg)
    again.legs.check_straight_moves(task, options)
    monkeypatch.setattr(station_legs, "plan_leg", refuse)
    again.legs.plan_every_move(task, options, cache, workers=1)
    for r, i, j in own:
        key = _leg_key(r, qs[i], qs[j])
        np.testing.assert_array_equal(again.legs.paths[key], planner.legs.paths[key])
    monkeypatch.undo()
    # an interrupted write: the last line torn in half is planned again, in one worker, to the same leg
    text = cache.read_text()
    cache.write_text(text[:len(text) - len(text.splitlines()[-1]) // 2 - 1])
    calls = []
    original = station_legs.plan_leg
    monkeypatch.setattr(station_legs, "plan_leg", lambda *a: calls.append(a) or original(*a))
    torn = StationPlanner(two_robot_station, cfg)
    torn.legs.check_straight_moves(task, options)
    torn.legs.plan_every_move(task, options, cache, workers=1)
    assert len(calls) == 1
    for r, i, j in own:
        key = _leg_key(r, qs[i], qs[j])
        np.testing.assert_array_equal(torn.legs.paths[key], planner.legs.paths[key])
    assert len(cache.read_text().splitlines()) == len(text.splitlines()) + 1  # the torn line stays, unread
    # another seed: the cache does not apply
    assert station_legs._read_cache(cache, station_legs.fingerprint(two_robot_station.config, FastLegPlanner,
                                                                    cfg.iterations, cfg.seed + 1)) == {}



@pytest.mark.slow  # three station plans, one with every move planned (~50 s)
def test_legs_up_front_make_every_move_exact_for_the_wear_objective_only(two_robot_station, tmp_path):
    """``legs_up_front``: the wear objective plans every own move before its rounds (to the leg cache) and its
    solver knows them all; the time objective plans lazily whatever the flag says, so its plan is the lazy one."""
    config = StationPlanConfig(kept_options=1, costed_options=1, cable_repairs=0, work=0.5, legs_up_front=True,
                               jobs=1)
    wear = StationPlanner(two_robot_station, replace(config, objective="wear"))
    cache = tmp_path / "planned_legs.jsonl"
    plan = wear.plan(leg_cache=cache)
    task = plan.task
    qs = np.vstack([task.homes, [o.q for o in plan.options]])
    node_robot = np.concatenate([[0, 1], [o.robot for o in plan.options]])
    node_weld = [None, None, *(o.weld for o in plan.options)]
    own = [(r, i, j) for r in range(2) for i, j in itertools.permutations(range(len(qs)), 2)
           if node_robot[i] == r == node_robot[j] and (node_weld[i] is None or node_weld[i] != node_weld[j])]
    assert all(_leg_key(r, qs[i], qs[j]) in wear.legs.known for r, i, j in own)
    assert plan.info["planned_legs"] >= len(own)
    assert cache.is_file() and len(cache.read_text().splitlines()) > 1
    assert plan.schedule.makespan <= plan.coordination["makespan_cap"] + 1e-9
    lazy = StationPlanner(two_robot_station, replace(config, legs_up_front=False)).plan()
    timed = StationPlanner(two_robot_station, config).plan(leg_cache=tmp_path / "unused.jsonl")
    assert timed.assignment.routes == lazy.assignment.routes and timed.schedule.makespan == lazy.schedule.makespan
    assert timed.info["planned_legs"] < len(own) and not (tmp_path / "unused.jsonl").exists()
    with pytest.raises(ConfigError, match="jobs"):
        StationPlanConfig(jobs=0)


def test_planning_every_move_up_front_refuses_a_bad_worker_count(two_robot_station):
    from dresspack.agents.stations.legs_up_front import plan_moves

    with pytest.raises(ConfigError, match="workers"):
        plan_moves(two_robot_station.config, FastLegPlanner, 100, 0, [], workers=0)


def test_station_plan_command_refuses_a_bound_work_of_zero(capsys):
    from dresspack_gym.cli.main import main

    with pytest.raises(SystemExit) as exit_:
        main(["station-plan", "--station", "side_framing_4r", "--bound-work", "0"])
    assert exit_.value.code == 2
    assert "--bound-work" in capsys.readouterr().err


@pytest.mark.parametrize("flag", ["--jobs", "--leg-workers", "--kept-options", "--costed-options"])
def test_station_plan_command_refuses_zero_workers_or_options(flag, capsys):
    from dresspack_gym.cli.main import main

    with pytest.raises(SystemExit) as exit_:
        main(["station-plan", "--station", "side_framing_4r", flag, "0"])
    assert exit_.value.code == 2
    assert flag in capsys.readouterr().err
