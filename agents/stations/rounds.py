"""The solve rounds of a station plan: solve, plan the chosen legs (and run them with their cables), re-solve with
their exact times; then two robots re-solved at a time; the best answer coordinated, verified and bounded."""

from __future__ import annotations

import numpy as np

from dresspack_gym.errors import ConfigError
from dresspack_gym.multi.coordination import RobotPairDistance, verify
from dresspack_gym.multi.schedule import StationSchedule
from dresspack_gym.multi.tasks import StationTask, WeldOption

from .config import EXTRA_ROUNDS
from .coordination import routes_key
from .jams import reroute
from .plan import StationPlan
from .problem import BLOCKED, straight_times
from .solver import INTERLOCKS, PAIR_IMPROVEMENTS, PAIR_WORK, Assignment, RoutingProblem, improve_by_pairs, solve

EXACT_TOLERANCE = 0.02  # a chosen leg whose planned duration exceeds its estimate by more is re-solved with it


def solve_rounds(planner, task: StationTask, options: list[WeldOption], qs: np.ndarray,
                 stops: list[str], given: list[Assignment] = (), reference: float | None = None) -> StationPlan:
    """Solve, plan the chosen legs, re-solve with their exact times (``exact_rounds``); coordinate; verify.
    ``planner``: the StationPlanner running these rounds (its parts, settings and progress bar; passed in, not
    imported, since the planner is what composes this module). ``given``: answers found elsewhere whose legs are
    planned, candidates beside this objective's; ``reference``: the time plan's makespan, which the wear objective's
    slack is measured from. The rounds' candidates are left in ``planner.candidates``."""
    cfg, legs = planner.config, planner.legs
    candidates = list(given)
    straight = straight_times(qs, legs.limits)
    rounds, solves, bound, wear_failures = _solve_until_exact(planner, task, options, qs, stops, straight, candidates)
    problem = planner.problem(task, options)
    # the bounds depend only on the options and the straight moves: solved in a worker while this process
    # coordinates and re-solves pairs (the rounds before want every worker for their legs)
    planner.bounds.start_makespan(problem, straight, cfg.bound_work, cfg.seed)
    if cfg.objective == "wear" and reference is not None:  # its cap, as Coordinator.best measures it
        planner.bounds.start_wear(problem, straight, float(reference) * (1 + cfg.makespan_slack), cfg.bound_work,
                                  cfg.seed)
    pairs = RobotPairDistance(planner.station)
    planner.candidates = list(candidates)
    assignment, schedule, coordination = planner.coordinator.best(problem, candidates, task, options, qs, pairs,
                                                                  legs, cfg, planner.bar, reference)
    improved = 0
    if cfg.objective in ("time", "wear") and cfg.pair_solves:
        # the best answer re-solved two robots at a time (CP-SAT searches a pair far better than the whole
        # station), each better answer judged coordinated; the last is the best
        kept = _pair_improvements(planner, task, options, qs, stops, assignment, schedule, coordination, pairs)
        if kept:
            improved = len(kept)
            candidates += kept
            planner.candidates = list(candidates)
            problem = planner.problem(task, options)
            assignment, schedule, coordination = planner.coordinator.best(problem, kept[-1:], task, options, qs,
                                                                          pairs, legs, cfg, planner.bar, reference)
    verification = verify(planner.station, schedule, pairs=pairs)
    wear_bound = planner.bounds.wear(problem, straight, coordination["makespan_cap"], cfg.bound_work, cfg.seed) \
        if cfg.objective == "wear" else None
    costs = planner.costs
    return StationPlan(task, [r.name for r in planner.station.config.robots], options, assignment, schedule,
                       coordination, verification, planner.bounds.makespan(problem, straight, bound, cfg.bound_work,
                                                                           cfg.seed), cfg,
                       info={"rounds": rounds, "solves": solves, "nodes": len(qs), "pair_improvements": improved,
                             "conflict_pairs": len(problem.conflicts), "candidates": len(candidates),
                             "wear_solves_without_answer": wear_failures,
                             "unconverged_cost_settles": costs.unconverged_options(options),
                             "cheapest_weld_wear": costs.cheapest_weld_wear(task, cfg.costed_options),
                             "planned_legs": len(legs.known), "cost_settles": len(costs.rates),
                             "simulated_legs": len(legs.runs),
                             "unsettled_leg_starts": sum(not r.start_settled for r in legs.runs.values()),
                             "rerouted_legs": list(legs.log)},
                       wear_bound=wear_bound)


def _solve_until_exact(planner, task: StationTask, options: list[WeldOption], qs: np.ndarray,
                       stops: list[str], straight: np.ndarray, candidates: list[Assignment]) -> tuple:
    """The rounds: solve, plan the chosen legs, re-solve until no chosen leg is slower (or wears more) than its
    estimate, ``exact_rounds`` at most (more while no answer has every leg planned). Every answer is appended to
    ``candidates``; returns (rounds, solves, CP-SAT's makespan bound from straight-move rounds, wear solves that
    found no answer)."""
    cfg, legs = planner.config, planner.legs
    rounds, solves, bound, wear_failures = 0, 0, 0.0, 0
    bar = planner.bar("solve, plan the chosen legs (rounds, at most)", cfg.exact_rounds)
    fastest = chosen = None
    answers = {}  # the previous round's fastest answer per interlock model
    while True:
        problem = planner.problem(task, options)
        # the fastest answer two ways: conflicting welds scheduled apart, or charged a wait and so avoided
        # (whose answers' legs cross less); both are candidates, and the coordination of their planned legs
        # decides. Later rounds start from the previous answer (still feasible: only leg times changed)
        # (independent solves: all but the last in workers, beside this process's)
        pending = {}
        for k, model in enumerate(INTERLOCKS):
            previous_answer = answers.get(model)
            kwargs = dict(work=cfg.work, seed=cfg.seed, time_limit=cfg.time_budget,
                          start=previous_answer.routes if previous_answer is not None else None, interlocks=model)
            pending[model] = planner.workers.submit("solve", (problem, "time", kwargs)) \
                if k < len(INTERLOCKS) - 1 else None
            if pending[model] is None:
                answers[model] = solve(problem, "time", **kwargs)
            solves += 1
        answers.update({model: p.get() for model, p in pending.items() if p is not None})
        answers = {model: answers[model] for model in INTERLOCKS}  # in their order, as min() below breaks ties
        fastest = min(answers.values(), key=lambda a: (a.estimate["timed_makespan"], a.estimate["time"]))
        if np.array_equal(problem.travel, straight):  # a bound of any plan only while no leg is a planned path
            bound = max(bound, fastest.estimate.get("makespan_bound", 0.0))
        previous = chosen.routes if chosen is not None and chosen is not fastest else None
        chosen = fastest
        if cfg.objective in ("wear", "time"):
            # the least-wear answer within the slack is also a candidate of the time objective: the solver
            # times most legs by estimates, and an answer of shorter, cheaper legs can turn out the faster
            # one once they are planned.
            # Started from the fastest answer, which is within the cap by construction: never infeasible
            try:
                chosen = solve(problem, "wear", work=cfg.work, seed=cfg.seed, time_limit=cfg.time_budget,
                               makespan_cap=fastest.estimate["timed_makespan"] * (1 + cfg.makespan_slack),
                               start=fastest.routes)
            except ConfigError:  # the budget ran out before CP-SAT took the start: keep the fastest
                wear_failures += 1
            solves += 1
        elif cfg.objective == "balanced":
            weight = fastest.estimate["time"] / max(fastest.estimate["wear"], 1e-9)
            chosen = solve(problem, "balanced", work=cfg.work, seed=cfg.seed, time_limit=cfg.time_budget,
                           wear_weight=weight, start=previous)
            solves += 1
        rounds += 1
        solved = {id(a): a for a in [*answers.values(), chosen]}.values()
        legs.prefetch([m for a in solved for m in _moves(problem, a)], qs)  # every answer's new legs in one batch
        changed = sum(plan_chosen_legs(planner, problem, a, qs, stops) for a in solved)
        candidates += solved  # every leg of each is planned now: exactly evaluable
        bar.update(1)
        done = changed == 0 or rounds >= cfg.exact_rounds
        if done and rounds < EXTRA_ROUNDS * cfg.exact_rounds and not any(
                all(legs.leg(r, a, b, qs) is not None for r, route in enumerate(c.routes)
                    for a, b in zip([r, *route], [*route, r])) for c in candidates):
            done = False  # every answer so far lost a leg to a jam: solve again without it
        if done:
            break
    bar.close()
    return rounds, solves, bound, wear_failures


def plan_chosen_legs(planner, problem: RoutingProblem, assignment: Assignment, qs: np.ndarray,
                     stops: list[str]) -> int:
    """Plan every leg of the assignment and run it with its robot's cable (a leg that jams the cable is
    re-routed or blocked); the number that took longer, or (objectives with wear) wore more, than estimated."""
    legs = planner.legs
    legs.prefetch(_moves(problem, assignment), qs)
    changed = 0
    for r, route in enumerate(assignment.routes):
        path = [r, *route, r]
        wear = problem.leg_wear(r)
        for a, b in zip(path[:-1], path[1:]):
            estimate = problem.travel[r, a, b]
            leg = legs.leg(r, a, b, qs)
            weld = problem.weld_time if problem.node_weld[b] >= 0 else 0.0
            if leg is not None and legs.run(r, leg, weld).jammed:
                reroute(legs, planner.station.home, planner.names, r, a, b, qs, stops, "jammed its cable alone", weld)
                leg = legs.leg(r, a, b, qs)
            real = BLOCKED if leg is None else legs.motion(r, leg).duration
            changed += real > estimate * (1 + EXACT_TOLERANCE) + 1e-6
            if leg is not None and planner.config.objective != "time":
                changed += legs.run(r, leg, weld).wear > wear[a, b] * (1 + EXACT_TOLERANCE) + 1e-6
    return changed


def _moves(problem: RoutingProblem, assignment: Assignment) -> list[tuple[int, int, int, float]]:
    """Every leg of ``assignment``: (robot, from node, to node, weld time at its end)."""
    return [(r, a, b, problem.weld_time if problem.node_weld[b] >= 0 else 0.0)
            for r, route in enumerate(assignment.routes) for a, b in zip([r, *route], [*route, r])]


def _pair_improvements(planner, task: StationTask, options: list[WeldOption], qs: np.ndarray,
                       stops: list[str], best: Assignment, schedule: StationSchedule, coordination: dict,
                       pairs: RobotPairDistance) -> list[Assignment]:
    """Better answers than ``best`` (the rounds' best, coordinated as ``schedule``), two robots re-solved at a
    time (solver.improve_by_pairs); each answer's legs are planned (and run with their cables) and the robots
    coordinated before it is judged. The wear objective keeps within ``coordination``'s cap."""
    cfg = planner.config
    problem = planner.problem(task, options)
    cap = coordination["makespan_cap"]
    if cfg.objective == "wear" and schedule.makespan > cap + 1e-9:
        return []  # no candidate within the cap: nothing to improve on
    verdicts = {}
    if cfg.objective == "time":
        verdicts[routes_key(best.routes)] = (schedule.makespan, problem.evaluate(best.routes)["time"])
    else:
        verdicts[routes_key(best.routes)] = (0.0, best.estimate["wear_with_waits"], schedule.makespan)

    def exact(routes):
        # the problem passed only times the estimates plan_chosen_legs counts changes against (unused here)
        plan_chosen_legs(planner, problem, Assignment(routes, {}, cfg.objective), qs, stops)
        return planner.problem(task, options)

    def judge(p: RoutingProblem, routes) -> tuple:
        """An answer as the plan would be, coordinated: the solver's interlocks see two robots at one weld,
        not legs that cross (on side_framing_4r an answer of 27.4 s coordinated to 31.6 s)."""
        if routes_key(routes) in verdicts:
            return verdicts[routes_key(routes)]
        verdict = (np.inf,)
        estimate = p.evaluate(routes)
        if estimate["makespan"] < BLOCKED:
            best_time = min(v[0] for v in verdicts.values()) if cfg.objective == "time" else np.inf
            got = planner.coordinator.coordinated(p, routes, task, options, qs, pairs, planner.legs, cap=best_time)
            if got is not None and got[1]["resolved"]:
                span, wear = got[0].makespan, got[2]
                verdict = ((span, estimate["time"]) if cfg.objective == "time"
                           else (max(0.0, span - cap), wear, span))
        verdicts[routes_key(routes)] = verdict
        return verdict

    bar = planner.bar("re-solving the robots two at a time (improvements, at most)", PAIR_IMPROVEMENTS)
    problem, kept = improve_by_pairs(problem, best.routes, exact, judge, objective=cfg.objective,
                                     makespan_cap=cap if cfg.objective == "wear" else None, work=PAIR_WORK,
                                     solves=cfg.pair_solves, seed=cfg.seed, time_limit=cfg.time_budget,
                                     progress=bar)
    bar.close()
    return [Assignment(routes, problem.evaluate(routes), cfg.objective) for routes in kept]
