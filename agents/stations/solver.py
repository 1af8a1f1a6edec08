"""Weld assignment and sequencing for several robots: a min-max multiple generalised TSP solved by OR-Tools routing.

Each robot is a vehicle that starts and ends at its Home; each weld is a disjunction over its options (robot,
IK branch), exactly one visited, by that option's robot only. Travel and welding times make a time dimension
whose largest route end is the station's makespan; wear enters as arc costs. OR-Tools routing finds a first
assignment, CP-SAT improves and bounds it within a deterministic work budget, so the same problem gives the same
answer on any machine."""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from dresspack_gym.errors import ConfigError
from dresspack_gym.fields import check_choice

# how a move not planned yet is timed for the solver (StationPlanConfig.blocked_estimate)
BLOCKED_ESTIMATES = ("straight", "planned_ratio")
# how a blocked move's leg is planned (config.LEG_PLANNERS; named here, with the solver's settings, so
# the command line offers them without importing the planners)
LEG_ROUTES = ("fastest", "ompl")
OBJECTIVES = ("time", "wear", "balanced")
TIME_SCALE = 1000  # integer costs: milliseconds
WEAR_SCALE = 100_000  # integer costs: 1e-5 of the wear cost's unit x s (fine enough for a Home rate per ms)
SPAN_WEIGHT = 100  # makespan against the sum of route times in the time objective (min-max first)
DEFAULT_WORK = 10.0  # CP-SAT deterministic seconds per solve (the solver's work budget, machine-independent)
# CP-SAT deterministic seconds spent bounding the makespan (relaxation_bound): side_framing_4r's bound is 19.22 s
# at 10, 19.43 s at 60 (about a minute more, once per station and objective set: never per solve)
BOUND_WORK = 60.0
HINT_SOLUTIONS = 20  # routing local-search solutions behind CP-SAT's first assignment
HINT_BRANCHES = 100_000  # ... or at most this many search branches (work units; ~150 find 20 solutions)
# after the rounds, two robots re-solved at a time, the rest held (improve_by_pairs): improvements kept at most,
# solves at most (the search's work budget: each solve's work is PAIR_WORK), tries per pair (each re-solved on the
# legs the try before made exact)
PAIR_IMPROVEMENTS = 8
PAIR_SOLVES = 30  # side_framing_4r: 24.7 s at 12, 22.25 s at 30 (at 50 welds the same plan either way)
PAIR_TRIES = 3
PAIR_WORK = 5.0
MAKESPAN_SLACK = 0.10  # wear objective: makespan allowed above the time-optimal plan's (as a fraction)
# How the solver sees two conflicting welds both taken: "timed" schedules them conflict_wait apart (the wait is
# in the makespan); "charged" adds conflict_wait to the two routes whatever the timing, which steers answers away
# from conflicting pairs altogether (and so from legs that cross), at the price of a makespan that over-counts
INTERLOCKS = ("timed", "charged")


@dataclass(frozen=True)
class RoutingProblem:
    """Node 0..R-1: robot r's Home; node R+k: option k. ``travel[r]`` (N, N) [s] robot r's motion time between
    nodes (only its own Home and options matter); ``cost_rate`` (N,) the wear cost rate C at each node's
    configuration; ``node_robot`` / ``node_weld`` the robot and weld index of each node (-1: a Home)."""

    travel: np.ndarray  # (R, N, N)
    cost_rate: np.ndarray  # (N,)
    node_robot: np.ndarray  # (N,)
    node_weld: np.ndarray  # (N,)
    weld_time: float
    n_welds: int
    # option pairs of different robots that cannot be welded at the same time (the robots would touch), and
    # the least time [s] between the starts of their welds when both are taken: the first robot welds and
    # leaves before the second arrives (an interlock zone). The solver schedules such welds apart in time, so
    # the waits they need are in its makespan, or charges the pair that wait (INTERLOCKS); the wear objective
    # also charges it at the cables' rates.
    conflicts: np.ndarray | None = None  # (K, 2) node pairs
    conflict_wait: float = 0.0
    # (R, N, N) robot r's integrated wear cost of the move i -> j and the weld at j as simulated (its cable from
    # settled at i, through the motion and the weld); NaN where not simulated (the estimate stands in)
    simulated_wear: np.ndarray | None = None

    @property
    def n_robots(self) -> int:
        return self.travel.shape[0]

    def leg_wear(self, r: int) -> np.ndarray:
        """Wear of robot r's move i -> j and the weld at j: as simulated where it was (``simulated_wear``), else
        estimated: the motion at the mean of the two configurations' settled cost rates, then the weld at j's
        (the path-independent part of 4.10)."""
        c = self.cost_rate
        wear = self.travel[r] * 0.5 * (c[:, None] + c[None, :])
        weld = np.where(self.node_weld >= 0, self.weld_time * c, 0.0)
        estimate = wear + weld[None, :]
        if self.simulated_wear is None:
            return estimate
        simulated = self.simulated_wear[r]
        return np.where(np.isfinite(simulated), simulated, estimate)

    def leg_time(self, r: int) -> np.ndarray:
        """Robot r's motion i -> j plus the weld at j [s]."""
        return self.travel[r] + np.where(self.node_weld >= 0, self.weld_time, 0.0)[None, :]

    def idle_wear(self, ends, makespan: float) -> float:
        """Wear of the cables of robots done before the station's cycle ends, hanging at Home until it does (what
        a station replay over the makespan counts): robot r's Home rate x (makespan - its end)."""
        return float(sum(self.cost_rate[r] * (makespan - end) for r, end in enumerate(ends)))

    def evaluate(self, routes: list[list[int]]) -> dict:
        """Makespan [s], summed time [s] and wear of routes (node lists without the Homes); ``wear`` counts the
        cables of robots done early hanging at Home until the makespan (``idle_wear``)."""
        ends, wear = self.route_ends(routes), 0.0
        for r, route in enumerate(routes):
            path = [r, *route, r]
            w = self.leg_wear(r)
            wear += sum(w[a, b] for a, b in zip(path[:-1], path[1:]))
        idle = self.idle_wear(ends, max(ends))
        wear += idle
        return {"makespan": float(max(ends)), "time": float(sum(ends)), "wear": float(wear), "idle_wear": idle,
                "robot_times": [float(e) for e in ends], "conflicts": len(self.taken_conflicts(routes)),
                "timed_makespan": self.timed_makespan(routes)}

    def taken_conflicts(self, routes: list[list[int]]) -> list[tuple[int, int]]:
        """The conflicting option pairs that ``routes`` both take."""
        if self.conflicts is None:
            return []
        taken = {n for route in routes for n in route}
        return [(int(a), int(b)) for a, b in self.conflicts if a in taken and b in taken]

    def timed_makespan(self, routes: list[list[int]]) -> float:
        """The makespan [s] of ``routes`` when conflicting welds keep ``conflict_wait`` between their starts (the
        robots wait where they are): the earliest such schedule (``timed_schedule``)."""
        return self.timed_schedule(routes)[0]

    def timed_schedule(self, routes: list[list[int]]) -> tuple[float, dict, list[int], dict]:
        """A schedule of ``routes`` of the least makespan whose conflicting welds keep ``conflict_wait`` between
        their starts, in the solver's integer milliseconds: (makespan [s], each option's weld end [ms], each
        robot's return Home [ms], for each taken conflicting pair whether its first option goes first). CP-SAT
        chooses which weld of each pair goes first (exact unless very many pairs: then the best order found)."""
        from ortools.sat.python import cp_model

        pairs = self.taken_conflicts(routes) if self.conflict_wait > 0 else []
        if not pairs:  # nothing to order: each weld as its route reaches it (the makespan not rounded to ms)
            end, rets = {}, []
            for r, route in enumerate(routes):
                t = np.rint(self.leg_time(r) * TIME_SCALE).astype(np.int64)
                clock = 0
                for prev, n in zip([r, *route], route):
                    clock += int(t[prev, n])
                    end[n] = clock
                rets.append(clock + int(t[route[-1], r]) if route else 0)
            return max(self.route_ends(routes)), end, rets, {}
        m = cp_model.CpModel()
        horizon = int(np.rint((sum(self.route_ends(routes)) + len(pairs) * self.conflict_wait)
                              * TIME_SCALE)) + 1
        end, rets = {}, []
        for r, route in enumerate(routes):
            t = np.rint(self.leg_time(r) * TIME_SCALE).astype(np.int64)
            prev, prev_end = r, 0
            for n in route:
                end[n] = m.new_int_var(0, horizon, f"e{n}")
                m.add(end[n] >= prev_end + int(t[prev, n]))
                prev, prev_end = n, end[n]
            ret = m.new_int_var(0, horizon, f"ret{r}")
            m.add(ret >= prev_end + int(t[prev, r]))
            rets.append(ret)
        gap = int(np.rint(self.conflict_wait * TIME_SCALE))
        first = {}
        for a, b in pairs:
            first[(a, b)] = a_first = m.new_bool_var(f"first{a}_{b}")
            m.add(end[b] >= end[a] + gap).only_enforce_if(a_first)
            m.add(end[a] >= end[b] + gap).only_enforce_if(a_first.Not())
        makespan = m.new_int_var(0, horizon, "makespan")
        m.add_max_equality(makespan, rets)
        m.minimize(makespan)
        solver = _deterministic_solver(DEFAULT_WORK)
        status = solver.solve(m)
        if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):  # every order is feasible: cannot happen
            raise RuntimeError(f"timing {len(pairs)} conflicting weld pairs: CP-SAT status "
                               f"{solver.status_name(status)}")
        return (solver.value(makespan) / TIME_SCALE, {n: solver.value(e) for n, e in end.items()},
                [solver.value(x) for x in rets], {k: bool(solver.value(x)) for k, x in first.items()})

    def route_ends(self, routes: list[list[int]]) -> list[float]:
        """Each robot's end [s]: its legs and welds without waits."""
        ends = []
        for r, route in enumerate(routes):
            path = [r, *route, r]
            t = self.leg_time(r)
            ends.append(float(sum(t[a, b] for a, b in zip(path[:-1], path[1:]))))
        return ends


@dataclass(frozen=True)
class Assignment:
    """Per robot, the option nodes it visits in order; the estimates of the solved problem."""

    routes: list[list[int]]
    estimate: dict
    objective: str


def solve(problem: RoutingProblem, objective: str = "time", *, work: float = DEFAULT_WORK,
          makespan_cap: float | None = None, wear_weight: float | None = None, seed: int = 0,
          time_limit: float | None = None, start: list[list[int]] | None = None,
          interlocks: str = "timed", hold: dict[int, list[int]] | None = None) -> Assignment:
    """Assign and order the welds. ``time``: minimise the makespan, then the summed time; ``wear``: minimise
    the wear estimate with every route within ``makespan_cap`` [s]; ``balanced``: time plus ``wear_weight`` x
    wear (both in seconds), makespan first.

    OR-Tools routing (guided local search over the disjunctions, ``HINT_SOLUTIONS`` solutions) gives a first
    assignment; CP-SAT, started from it, improves it and bounds it, for ``work`` deterministic seconds (CP-SAT's
    machine-independent work measure, so the answer does not depend on machine load; ``time_limit`` [s] is an
    optional wall-clock cap on top). ``start``: routes to start from instead (e.g. the previous round's answer).
    ``hold``: robots whose routes are given (robot -> its route): the others share the remaining welds.
    The estimate says whether the answer is proven optimal and carries CP-SAT's bound on the makespan."""
    check_choice("objective", objective, OBJECTIVES)
    check_choice("interlocks", interlocks, INTERLOCKS)
    if objective == "balanced" and wear_weight is None:
        raise ConfigError("wear_weight", "the balanced objective needs a wear weight (seconds per unit of wear)")
    R = problem.n_robots
    horizon = int(np.rint(max(problem.leg_time(r).max() for r in range(R)) * (problem.n_welds + 2) * TIME_SCALE)) + 1
    cap = horizon if makespan_cap is None else min(horizon, int(np.rint(makespan_cap * TIME_SCALE)))
    arc_cost = []
    for r in range(R):
        t = problem.leg_time(r) * TIME_SCALE
        if objective == "time":
            arc_cost.append(np.rint(t).astype(np.int64))
        elif objective == "wear":
            arc_cost.append(np.rint(problem.leg_wear(r) * WEAR_SCALE).astype(np.int64))
        else:
            arc_cost.append(np.rint(t + wear_weight * problem.leg_wear(r) * TIME_SCALE).astype(np.int64))
    span = SPAN_WEIGHT if objective != "wear" else 0
    hint = start if start is not None else _routing_first(problem, arc_cost, span, cap, horizon)
    routes, status = _cp_sat(problem, arc_cost, span, cap, hint, work, seed, time_limit, objective, interlocks, hold)
    if status and objective == "time" and (problem.conflicts is None or problem.conflict_wait == 0):
        # every route's summed time is at most the makespan, so objective <= (span + R) x makespan (not with
        # conflict charges: they are guesses of waits, not times a plan must take)
        status["makespan_bound"] = status["objective_bound"] / (span + R) / TIME_SCALE
    if routes is None:
        what = f"within a makespan of {makespan_cap:.1f} s" if makespan_cap is not None else ""
        raise ConfigError("objective", f"the solver found no assignment of the welds {what}".strip())
    estimate = problem.evaluate(routes)
    estimate.update(status)
    return Assignment(routes, estimate, objective)


def improve_by_pairs(problem: RoutingProblem, routes: list[list[int]], exact=None, judge=None, *,
                     objective: str = "time",
                     makespan_cap: float | None = None, work: float = PAIR_WORK, seed: int = 0,
                     time_limit: float | None = None, improvements: int = PAIR_IMPROVEMENTS, solves: int = PAIR_SOLVES,
                     tries: int = PAIR_TRIES, progress=None) -> tuple[RoutingProblem, list[list[list[int]]]]:
    """Answers better than ``routes``, by re-solving two robots at a time (a large-neighbourhood search whose
    neighbourhoods are robot pairs): the pair shares its welds while the other robots' routes are held (their
    interlocks with the pair still timed). CP-SAT, which does not converge on a whole station in its budget,
    searches such a pair far better. ``time``: the robot back Home last (its interlock waits included) with each
    other robot, earliest back first; judged by (conflict-timed makespan, slowest route, summed time). ``wear``:
    every pair, most wear first, each for the least wear with the conflict-timed makespan within
    ``makespan_cap``; judged by (time over the cap, wear, makespan). An answer that looks better is made exact by
    ``exact(routes)`` (plans its legs; returns the problem with their times and wear; None: the problem is exact
    already) and kept only if it is still better on those, and then by ``judge(problem, routes)`` (a tuple, lower
    is better; e.g. the makespan once the robots are coordinated; None: the solver's measures above); a pair is
    re-solved on the exact legs (``tries`` at most). Returns the last problem and the kept routes, each better
    than the one before: at most ``improvements`` of them, found in at most ``solves`` solves (work units)."""
    check_choice("objective", objective, ("time", "wear"))
    if objective == "wear" and makespan_cap is None:
        raise ConfigError("makespan_cap", "re-solving pairs for wear needs a makespan cap [s]")

    def measure(e: dict) -> tuple:  # of an evaluation (RoutingProblem.evaluate, or a solve's estimate)
        if objective == "time":
            return e["timed_makespan"], max(e["robot_times"]), e["time"]
        return max(0.0, e["timed_makespan"] - makespan_cap), e["wear"], e["timed_makespan"]

    def score(p: RoutingProblem, rs) -> tuple:
        return measure(p.evaluate(rs))

    def pairs(p: RoutingProblem, rs) -> list[tuple[int, int]]:
        R = p.n_robots
        if objective == "wear":
            worn = [sum(p.leg_wear(r)[a, b] for a, b in zip([r, *rs[r]], [*rs[r], r])) for r in range(R)]
            return sorted(itertools.combinations(range(R), 2), key=lambda x: (-(worn[x[0]] + worn[x[1]]), x))
        back, ends = p.timed_schedule(rs)[2], p.route_ends(rs)  # back Home: interlock waits included
        slowest = max(range(R), key=lambda r: (back[r], ends[r]))
        return [(slowest, r) for r in sorted(range(R), key=lambda r: (back[r], ends[r], r)) if r != slowest]

    judge = judge or score
    current, kept, left = [list(r) for r in routes], [], solves
    verdict, measured = judge(problem, current), score(problem, current)  # the current answer's, on ``problem``
    for _ in range(improvements):
        improved = False
        for pair in pairs(problem, current):
            hold = {r: current[r] for r in range(problem.n_robots) if r not in pair}
            for _try in range(tries):
                if left <= 0:
                    break
                left -= 1
                try:
                    answer = solve(problem, objective, work=work, seed=seed, time_limit=time_limit, start=current,
                                   interlocks="timed", hold=hold, makespan_cap=makespan_cap)
                except ConfigError:  # no answer within the cap in the budget (a start over the cap)
                    break
                new, new_measured = answer.routes, measure(answer.estimate)  # the estimate evaluates on ``problem``
                if new_measured >= measured:
                    break  # no better on the legs known
                if exact is not None:
                    problem = exact(new)
                    measured, new_measured = score(problem, current), score(problem, new)
                if new_measured < measured:
                    new_verdict = judge(problem, new)
                    if new_verdict < verdict:
                        current, verdict, measured, improved = new, new_verdict, new_measured, True
                        kept.append(new)
                        break
            if improved:
                break
        if progress is not None:
            progress.update(1)
        if not improved:
            break
    return problem, kept


def _routing_first(problem: RoutingProblem, arc_cost, span: int, cap: int, horizon: int) -> list[list[int]] | None:
    """A good first assignment from OR-Tools routing (None if it finds none within the cap)."""
    from ortools.constraint_solver import pywrapcp, routing_enums_pb2
    from ortools.util import optional_boolean_pb2

    R, N = problem.n_robots, len(problem.node_robot)
    manager = pywrapcp.RoutingIndexManager(N, R, list(range(R)), list(range(R)))
    routing = pywrapcp.RoutingModel(manager)
    time_cb = []
    for r in range(R):
        # a robot only visits its own options: entering another robot's node takes longer than any route may
        other = problem.node_robot != r
        t = np.rint(problem.leg_time(r) * TIME_SCALE).astype(np.int64)
        t[:, other] = horizon + 1
        time_cb.append(routing.RegisterTransitMatrix(t.tolist()))
        c = arc_cost[r].copy()
        c[:, other] = 0
        routing.SetArcCostEvaluatorOfVehicle(routing.RegisterTransitMatrix(c.tolist()), r)
    routing.AddDimensionWithVehicleTransits(time_cb, 0, cap, True, "time")
    routing.GetDimensionOrDie("time").SetGlobalSpanCostCoefficient(span)
    for w in range(problem.n_welds):
        nodes = np.flatnonzero(problem.node_weld == w)
        routing.AddDisjunction([manager.NodeToIndex(int(n)) for n in nodes])  # no penalty: exactly one visited
    params = pywrapcp.DefaultRoutingSearchParameters()
    params.first_solution_strategy = routing_enums_pb2.FirstSolutionStrategy.PARALLEL_CHEAPEST_INSERTION
    params.local_search_metaheuristic = routing_enums_pb2.LocalSearchMetaheuristic.GUIDED_LOCAL_SEARCH
    ops = params.local_search_operators
    # moving a weld to another robot means one option goes inactive and another active on another route: the
    # combined moves that do this are off by default
    for name in ("use_relocate_and_make_active", "use_exchange_and_make_active", "use_extended_swap_active",
                 "use_exchange_path_start_ends_and_make_active"):
        setattr(ops, name, optional_boolean_pb2.BOOL_TRUE)
    params.solution_limit = HINT_SOLUTIONS
    params.lns_time_limit.seconds = 3600  # sub-searches end on their own, never on the clock (determinism)
    # a problem with few solutions may never give guided local search HINT_SOLUTIONS of them (two welds: it
    # searched for ever): a limit on its search branches, a work count, ends it the same way on any machine
    routing.AddSearchMonitor(routing.solver().BranchesLimit(HINT_BRANCHES))
    solution = routing.SolveWithParameters(params)
    if solution is None:
        return None
    routes = []
    for r in range(R):
        idx = solution.Value(routing.NextVar(routing.Start(r)))
        route = []
        while not routing.IsEnd(idx):
            route.append(manager.IndexToNode(idx))
            idx = solution.Value(routing.NextVar(idx))
        routes.append(route)
    return routes


def _deterministic_solver(work: float, seed: int | None = None):
    """A CP-SAT solver whose answer depends only on the model, ``work`` (deterministic seconds, CP-SAT's
    machine-independent work measure) and ``seed`` (None: CP-SAT's default): one worker, as several race."""
    from ortools.sat.python import cp_model

    solver = cp_model.CpSolver()
    solver.parameters.num_workers = 1
    # CP-SAT's own Ctrl-C handler leaves SIGINT at its default when a solve ends: the next Ctrl-C would kill the
    # command outright, without its line saying what it saved (Python's handler stays, and stops after the solve)
    solver.parameters.catch_sigint_signal = False
    if seed is not None:
        solver.parameters.random_seed = int(seed)
    solver.parameters.max_deterministic_time = float(work)
    return solver


def _route_circuits(m, problem: RoutingProblem) -> tuple[dict, list[dict]]:
    """The routes in CP-SAT model ``m``: per robot a circuit through its Home and the options it takes (the
    others skipped by self-loops; a robot that takes none stays Home), each weld's options taken exactly once.
    Returns the literal of each (robot, option) taken and, per robot, the literal of each arc (a, b)."""
    taken, arcs_of = {}, []
    for r in range(problem.n_robots):
        nodes = [r] + [int(n) for n in np.flatnonzero((problem.node_robot == r) & (problem.node_weld >= 0))]
        local = {n: k for k, n in enumerate(nodes)}
        arcs, lits = [], {}
        idle = m.new_bool_var(f"idle{r}")
        arcs.append((0, 0, idle))
        for n in nodes[1:]:
            skip = m.new_bool_var(f"skip{r}_{n}")
            taken[(r, n)] = skip.Not()
            arcs.append((local[n], local[n], skip))
            m.add_implication(idle, skip)  # the circuit of a robot that works runs through its Home
        for a in nodes:
            for b in nodes:
                if a == b or (problem.node_weld[a] >= 0 and problem.node_weld[a] == problem.node_weld[b]):
                    continue  # two options of one weld are never both taken
                x = m.new_bool_var(f"x{r}_{a}_{b}")
                lits[(a, b)] = x
                arcs.append((local[a], local[b], x))
        m.add_circuit(arcs)
        arcs_of.append(lits)
    for w in range(problem.n_welds):
        m.add_exactly_one([taken[(int(problem.node_robot[n]), int(n))] for n in np.flatnonzero(problem.node_weld == w)])
    return taken, arcs_of


def _cp_sat(problem: RoutingProblem, arc_cost, span: int, cap: int, hint, work: float, seed: int,
            time_limit: float | None, objective: str = "time", interlocks: str = "timed",
            hold: dict[int, list[int]] | None = None) -> tuple[list[list[int]] | None, dict]:
    """The exact model: per robot a circuit through its Home and the options it takes (the others skipped by
    self-loops); each weld's options taken exactly once; each taken weld's end time follows its route's arcs,
    and two conflicting welds that are both taken start ``conflict_wait`` apart (either first), so the robots'
    waits for each other are in the makespan (``interlocks="charged"``: each route is charged half of
    ``conflict_wait`` per pair instead); route ends within the cap; the objective with the makespan weighted by
    ``span`` (min-max first); the robots in ``hold`` take their given routes."""
    from ortools.sat.python import cp_model

    R = problem.n_robots
    m = cp_model.CpModel()
    taken, arcs_of = _route_circuits(m, problem)
    for r, route in (hold or {}).items():
        path = {(a, b) for a, b in zip([r, *route], [*route, r])} if route else set()
        for (a, b), x in arcs_of[r].items():
            m.add(x == int((a, b) in path))
    busy, cost_terms = [], []  # busy: each route's legs and welds [ms], without waits
    for r, lits in enumerate(arcs_of):
        t = np.rint(problem.leg_time(r) * TIME_SCALE).astype(np.int64)
        busy.append(sum(int(t[a, b]) * x for (a, b), x in lits.items()))
        cost_terms += [int(arc_cost[r][a, b]) * x for (a, b), x in lits.items()]
    ends, rets, firsts = [], [], {}  # rets: when each robot is back Home, waits included
    conflicts = problem.conflicts if problem.conflicts is not None and problem.conflict_wait > 0 else []
    if interlocks == "timed":
        # when each taken option's weld ends [ms]: following the circuit's arcs, so a conflicting pair can be
        # scheduled apart (the later robot waits) and its wait is in the makespan
        for r, lits in enumerate(arcs_of):
            t = np.rint(problem.leg_time(r) * TIME_SCALE).astype(np.int64)
            own = {n for ab in lits for n in ab if n != r}
            end = {n: m.new_int_var(0, cap, f"e{n}") for n in own}
            ret = m.new_int_var(0, cap, f"ret{r}")
            for (a, b), x in lits.items():
                after = 0 if a == r else end[a]
                m.add((ret if b == r else end[b]) >= after + int(t[a, b])).only_enforce_if(x)
            ends.append(end)
            m.add(ret >= busy[r])  # implied by the arcs; stated for the solver's bounds
            rets.append(ret)
    charges = [[] for _ in range(R)]
    gap = int(np.rint(problem.conflict_wait * TIME_SCALE))
    half = int(np.rint(0.5 * problem.conflict_wait * TIME_SCALE))
    for a, b in conflicts:
        ra, rb = int(problem.node_robot[a]), int(problem.node_robot[b])
        both = [taken[(ra, int(a))], taken[(rb, int(b))]]
        if interlocks == "timed":
            firsts[(int(a), int(b))] = a_first = m.new_bool_var(f"first_{a}_{b}")
            m.add(ends[rb][int(b)] >= ends[ra][int(a)] + gap).only_enforce_if([*both, a_first])
            m.add(ends[ra][int(a)] >= ends[rb][int(b)] + gap).only_enforce_if([*both, a_first.Not()])
            if span:
                continue
        pair = m.new_bool_var(f"conflict_{a}_{b}")
        m.add_bool_or([both[0].Not(), both[1].Not(), pair])
        if interlocks == "charged":
            charges[ra].append(half * pair)
            charges[rb].append(half * pair)
        if span == 0:  # the wear objective: the waiting cables' cost
            rate = 0.5 * (problem.cost_rate[a] + problem.cost_rate[b])
            cost_terms.append(int(np.rint(problem.conflict_wait * rate * WEAR_SCALE)) * pair)
        else:
            cost_terms.append(2 * half * pair)
    if interlocks == "charged":
        for r in range(R):
            ret = m.new_int_var(0, cap, f"ret{r}")
            m.add(ret == busy[r] + sum(charges[r]))
            rets.append(ret)
    makespan = m.new_int_var(0, cap, "makespan")
    m.add_max_equality(makespan, rets)
    if objective == "wear":
        # a robot done early hangs its cable at Home until the station's cycle ends: that wear counts too (as in the
        # station replay), at its Home's rate per millisecond of the wait. (The balanced objective weighs the
        # makespan itself, which already pulls the robots' ends together.)
        for r in range(R):
            per_ms = problem.cost_rate[r] * WEAR_SCALE / TIME_SCALE
            cost_terms.append(int(np.rint(per_ms)) * (makespan - busy[r]))
    m.minimize(span * makespan + sum(cost_terms))
    if hint is not None:
        used = {(r, a, b) for r, route in enumerate(hint) for a, b in zip([r, *route], [*route, r])}
        for r, lits in enumerate(arcs_of):
            for (a, b), x in lits.items():
                m.add_hint(x, (r, a, b) in used)
    if hint is not None and interlocks == "timed":
        # and a timing of it, so the hint is a whole solution (CP-SAT need not repair one)
        _, end_ms, ret_ms, first = problem.timed_schedule(hint)
        for r, route in enumerate(hint):
            m.add_hint(rets[r], ret_ms[r])
            for n in route:
                m.add_hint(ends[r][n], end_ms[n])
        for key, x in firsts.items():
            m.add_hint(x, first.get(key, True))
        m.add_hint(makespan, max(ret_ms))
    solver = _deterministic_solver(work, seed)
    if time_limit is not None:
        solver.parameters.max_time_in_seconds = float(time_limit)
    status = solver.solve(m)
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return None, {}
    routes = []
    for r, lits in enumerate(arcs_of):
        succ = {a: b for (a, b), x in lits.items() if solver.value(x)}
        route, node = [], succ.get(r, r)
        while node != r:
            route.append(int(node))
            node = succ[node]
        routes.append(route)
    info = {"optimal": status == cp_model.OPTIMAL, "solver_work": round(solver.deterministic_time, 3),
            "objective_bound": float(solver.best_objective_bound)}
    return routes, info


def lower_bound(problem: RoutingProblem) -> dict:
    """Lower bounds on the makespan [s] of any assignment (in the problem's times, whose straight-move legs are
    themselves lower bounds of planned legs):

    - ``single``: the weld whose cheapest round trip (Home -> weld -> Home plus the weld, over the robots that
      reach it) is the longest;
    - ``load``: every weld costs at least its weld time plus its cheapest arrival (from its robot's Home or
      another of its options), and every robot that works returns Home at least as fast as its nearest option
      allows; with u robots working the busiest carries at least (sum of arrivals + u smallest returns) / u;
      the bound is the smallest of these over u (an assignment relaxation of the routes);
    - ``forced``: the welds only one robot reaches, counted for that robot;
    - ``bound``: the largest."""
    R = problem.n_robots
    single, arrive = 0.0, np.full(problem.n_welds, np.inf)
    forced = np.zeros(R)
    for w in range(problem.n_welds):
        nodes = np.flatnonzero(problem.node_weld == w)
        trip, best = np.inf, np.inf
        robots = set()
        for n in nodes:
            r = int(problem.node_robot[n])
            robots.add(r)
            t = problem.travel[r]
            own = np.flatnonzero((problem.node_robot == r) & (problem.node_weld != w))
            trip = min(trip, t[r, n] + problem.weld_time + t[n, r])
            best = min(best, problem.weld_time + t[own, n].min())
        single = max(single, trip)
        arrive[w] = best
        if len(robots) == 1:
            forced[robots.pop()] += best
    returns = sorted(float(problem.travel[r][np.flatnonzero((problem.node_robot == r) & (problem.node_weld >= 0)), r]
                           .min(initial=np.inf)) for r in range(R))
    returns = [x for x in returns if np.isfinite(x)]
    total = float(arrive.sum())
    load = min((total + sum(returns[:u])) / u for u in range(1, len(returns) + 1)) if returns else total
    return {"single": float(single), "load": float(load), "forced": float(forced.max()),
            "bound": float(max(single, load, forced.max()))}


def robot_components(problem: RoutingProblem) -> list[list[int]]:
    """The robots grouped by the welds they share: two robots are in one group when some weld has options of both
    (through any chain of such welds). Groups share no weld, so their routes are independent (e.g. the two sides
    of a car body)."""
    group = list(range(problem.n_robots))

    def root(r: int) -> int:
        while group[r] != r:
            r = group[r]
        return r

    for w in range(problem.n_welds):
        robots = sorted({int(r) for r in problem.node_robot[problem.node_weld == w]})
        for r in robots[1:]:
            group[root(r)] = root(robots[0])
    members: dict[int, list[int]] = {}
    for r in range(problem.n_robots):
        members.setdefault(root(r), []).append(r)
    return sorted(members.values())


def sub_problem(problem: RoutingProblem, robots: list[int]) -> RoutingProblem:
    """``problem`` restricted to ``robots`` and the welds they reach (renumbered; no conflicts): one group of
    :func:`robot_components`, whose every weld is reached by these robots only."""
    R = problem.n_robots
    nodes = [*robots, *(n for n in range(R, len(problem.node_robot)) if int(problem.node_robot[n]) in robots)]
    welds = {w: k for k, w in enumerate(sorted({int(problem.node_weld[n]) for n in nodes[len(robots):]}))}
    local = {r: k for k, r in enumerate(robots)}
    ix = np.ix_(nodes, nodes)
    weld_of = [-1] * len(robots) + [welds[int(problem.node_weld[n])] for n in nodes[len(robots):]]
    return RoutingProblem(np.stack([problem.travel[r][ix] for r in robots]), problem.cost_rate[nodes],
                          np.array([local[int(problem.node_robot[n])] for n in nodes]), np.array(weld_of),
                          problem.weld_time, len(welds))


def relaxation_bound(problem: RoutingProblem, work: float = BOUND_WORK, seed: int = 0) -> dict:
    """A lower bound [s] on the makespan of any routes of ``problem``, waits included: CP-SAT's proven bound on
    the min-max routes with the conflicts ignored (a wait only lengthens a plan) and every leg time rounded down
    to whole milliseconds, so the bound stays below the true optimum. Solving this smaller model alone, with
    CP-SAT's strongest linear relaxation, bounds far tighter than the full model's objective does. Robots that
    share no weld (:func:`robot_components`) route independently, so each group is solved alone, on an equal
    share of ``work``, and the station's bound is the largest group's (side_framing_4r, two groups of 2 robots:
    19.22 s against 19.20 s for the whole station in the same work; 19.24 s in twice the work).
    ``relaxation``: the bound; ``relaxation_best``: the best routes' makespan it found (the bound is proven
    tight when the two meet), both None if CP-SAT proved nothing within ``work``; ``components``: per group its
    robots, bound and best."""
    groups, components = [], robot_components(problem)
    for robots in components:
        sub = problem if len(robots) == problem.n_robots else sub_problem(problem, robots)
        groups.append({"robots": robots, **_relaxation(sub, work / len(components), seed)})
    if any(g["relaxation"] is None for g in groups):
        return {"relaxation": None, "relaxation_best": None, "components": groups}
    return {"relaxation": max(g["relaxation"] for g in groups),
            "relaxation_best": max(g["relaxation_best"] for g in groups), "components": groups}


def _relaxation(problem: RoutingProblem, work: float, seed: int) -> dict:
    """CP-SAT's bound and best makespan [s] of the min-max routes of ``problem`` without conflicts."""
    from ortools.sat.python import cp_model

    m = cp_model.CpModel()
    _, arcs_of = _route_circuits(m, problem)
    times = [np.floor(problem.leg_time(r) * TIME_SCALE).astype(np.int64) for r in range(problem.n_robots)]
    horizon = int(max(t.max() for t in times)) * (problem.n_welds + 2) + 1
    makespan = m.new_int_var(0, horizon, "makespan")
    for t, lits in zip(times, arcs_of):
        m.add(makespan >= sum(int(t[a, b]) * x for (a, b), x in lits.items()))
    m.minimize(makespan)
    solver = _deterministic_solver(work, seed)
    solver.parameters.linearization_level = 2  # cuts from the circuits: the bound this is for
    status = solver.solve(m)
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return {"relaxation": None, "relaxation_best": None}
    return {"relaxation": float(solver.best_objective_bound) / TIME_SCALE,
            "relaxation_best": float(solver.objective_value) / TIME_SCALE}


def wear_relaxation_bound(problem: RoutingProblem, makespan_cap: float, work: float = BOUND_WORK,
                          seed: int = 0) -> dict:
    """A lower bound on the wear estimate (:meth:`RoutingProblem.leg_wear` without the simulated legs) of any
    routes of ``problem`` whose every robot is back Home within ``makespan_cap`` [s]: CP-SAT's proven bound on the
    least-wear routes with conflicts and waits ignored (they only add time and wear), the cables of robots done
    early not counted (their Home wear is >= 0), every leg time rounded down to whole milliseconds and every leg's
    wear down to the solver's unit. Groups of robots that share no weld (:func:`robot_components`) are solved alone
    on an equal share of ``work``; the bound is their sum. Give it straight-move times (no motion is faster) and it
    bounds the estimate of every plan within the cap over these options: how much wear the options themselves
    allow, whatever the legs (``bound``; ``best``: the least-wear routes found, None if CP-SAT found none)."""
    groups = []
    components = robot_components(problem)
    estimate = replace(problem, simulated_wear=None, conflicts=None)
    for robots in components:
        sub = estimate if len(robots) == problem.n_robots else sub_problem(estimate, robots)
        groups.append({"robots": robots, **_wear_relaxation(sub, makespan_cap, work / len(components), seed)})
    if any(g["bound"] is None for g in groups):
        return {"bound": None, "best": None, "makespan_cap": makespan_cap, "components": groups}
    best = None if any(g["best"] is None for g in groups) else sum(g["best"] for g in groups)
    return {"bound": sum(g["bound"] for g in groups), "best": best, "makespan_cap": makespan_cap,
            "components": groups}


def _wear_relaxation(problem: RoutingProblem, makespan_cap: float, work: float, seed: int) -> dict:
    """CP-SAT's bound and best summed leg wear of routes of ``problem`` within ``makespan_cap``, no conflicts."""
    from ortools.sat.python import cp_model

    m = cp_model.CpModel()
    _, arcs_of = _route_circuits(m, problem)
    cap = int(np.ceil(makespan_cap * TIME_SCALE))
    cost = []
    for r, lits in enumerate(arcs_of):
        t = np.floor(problem.leg_time(r) * TIME_SCALE).astype(np.int64)
        w = np.floor(problem.leg_wear(r) * WEAR_SCALE).astype(np.int64)
        m.add(sum(int(t[a, b]) * x for (a, b), x in lits.items()) <= cap)
        cost += [int(w[a, b]) * x for (a, b), x in lits.items()]
    m.minimize(sum(cost))
    solver = _deterministic_solver(work, seed)
    solver.parameters.linearization_level = 2
    status = solver.solve(m)
    if status == cp_model.INFEASIBLE:
        return {"bound": np.inf, "best": None}  # no routes within the cap at all: any bound holds
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):  # no routes found yet: the bound may still hold
        bound = float(solver.best_objective_bound)
        return {"bound": bound / WEAR_SCALE if np.isfinite(bound) else None, "best": None}
    return {"bound": float(solver.best_objective_bound) / WEAR_SCALE,
            "best": float(solver.objective_value) / WEAR_SCALE}
