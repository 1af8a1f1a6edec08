"""``ppo-search``: the policy's most probable moves, ranked by a learned cost to go or by simulating each one's
continuation by the policy to the episode's end; then other routes and the route's vias, scored by cable simulation."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dresspack_gym.env.dresspack_env import EnvSnapshot
from dresspack_gym.errors import ConfigError
from dresspack_gym.physics.profiles import DEFAULT_ENGINE
from dresspack_gym.physics.trajectory import Trajectory
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import Task

from ..planners.base import PlanningError
from ..planners.budget import DEFAULT_ROUTES
from ..planners.leg_cost import TENSION_PEAK_TIME, LegCost
from ..planners.ompl_connect import OmplConnector
from ..planners.refine import LocalRefiner, refine_legs
from ..planners.routes import VIA_TRIES_PER_ROUTE, ViaRoutes
from .cost_model import CostModel
from .policy import STILL, EpisodeFailed, PolicyPlanner

PROPOSALS = 3  # actions tried at every step: the policy's most probable allowed moves
MAX_PROPOSALS = 64
# leg-cost queries (accurate cable simulations of a leg) per plan that move the found route's vias off the action
# set's grid: 20 take the search from 1.29x to 1.12x ompl-wear's T + ∫C dt on 30 drawn welds in ~10 s, 10 to 1.18x
# (docs/results_learned.md)
REFINE = 20
MAX_REFINE = 10_000
ALTERNATIVES = 4  # OMPL routes per leg scored against the found route's leg before refining
MAX_ALTERNATIVES = 1_000


def ranked_proposals(probs: np.ndarray, moving: np.ndarray, stay_action: int, k: int) -> list[int]:
    """The ``k`` most probable allowed moves (``moving``: masks without moves to where the robot stands), the wait
    left out unless it is all there is (it changes nothing a search could prefer it for); equal probabilities in
    action order, so the choice is reproducible."""
    allowed = np.flatnonzero(moving)
    if len(allowed) > 1:
        allowed = allowed[allowed != stay_action]
    return [int(a) for a in allowed[np.lexsort((allowed, -probs[allowed]))][:k]]


# what ranks ppo-search's proposals: by default their continuations, simulated (``none``); ``auto``: the cost-to-go
# model shipped beside the policy (its folder's cost_to_go.pt) where it ships one. On 30 drawn welds x 3 seeds of
# the station the policy never trained on, the shipped model's ranking ends 8 % above the simulated search's T + ∫C
# dt (1.000x against 0.926x ompl-wear's) in about two thirds of its planning time (docs/results_learned.md)
AUTO = "auto"
NONE = "none"  # simulate every proposal's continuation
SHIPPED_COST_TO_GO = "cost_to_go"  # the file name (cost_to_go.pt) a policy folder ships its model under


def resolve_cost_to_go(ref: str | Path | None, policy_file: Path) -> Path | None:
    """The cost-to-go model file that ranks the proposals, or None where the continuations are simulated: ``auto``
    (the policy folder's cost_to_go.pt if it ships one), ``none`` (or None), a path, or the name of a model shipped
    beside the policy; a ConfigError naming the field and the shipped names otherwise."""
    if ref is None or ref == NONE:
        return None
    if ref == AUTO:
        shipped = policy_file.parent / f"{SHIPPED_COST_TO_GO}.pt"
        return shipped if shipped.is_file() else None
    path = Path(ref)
    if path.is_file():
        return path
    shipped = policy_file.parent / f"{ref}.pt"
    if shipped.is_file():
        return shipped
    names = sorted(p.stem for p in policy_file.parent.glob("*.pt"))
    raise ConfigError("cost_to_go", f"{ref} is neither {AUTO}, {NONE}, a file (a model.pt of dresspack "
                                    "train-cost-model) nor a model shipped with the policy "
                                    f"({names or 'it ships none'})")


def auto_fallback(ref: str | Path | None, policy) -> str | None:
    """The one line that says what runs where ``auto`` finds no cost-to-go model beside the policy ``policy``
    (ppo-search then simulates the continuations, as ``none``); None where nothing falls back."""
    if ref != AUTO:
        return None
    from .policy import resolve_policy

    model_file, _ = resolve_policy(policy)
    shipped = model_file.parent / f"{SHIPPED_COST_TO_GO}.pt"
    if shipped.is_file():
        return None
    return (f"--cost-to-go auto: {model_file.parent} ships no {shipped.name}; ppo-search ranks its proposals by "
            f"simulating their continuations (as --cost-to-go {NONE})")


def load_cost_to_go(path, n_actions: int) -> CostModel:
    """A cost-to-go model (``dresspack train-cost-model --config cost_to_go``'s model.pt) for a policy of
    ``n_actions`` actions, or a ConfigError naming the field."""
    try:
        model = CostModel.load(path)
    except Exception as exc:  # torch's own message says what is wrong with the file
        raise ConfigError("cost_to_go", f"{path} is not a cost model ({type(exc).__name__}: {exc})") from None
    if model.label != "to_go":
        raise ConfigError("cost_to_go", f"{path} predicts a step's cost ({model.label!r}), not the cost to go: fit "
                                        "one with dresspack train-cost-model --config cost_to_go")
    if model.n_actions != n_actions:
        raise ConfigError("cost_to_go", f"{path} was fit for a policy of {model.n_actions} actions; this policy has "
                                        f"{n_actions}")
    return model


def _check_count(value, field: str, lo: int, hi: int, meaning: str = "") -> int:
    """An integer (not a bool) in [lo, hi], or a ConfigError naming the field (``meaning``: what lo stands for)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ConfigError(field, f"must be an integer in [{lo}, {hi}]{f' ({meaning})' if meaning else ''}, "
                                 f"got {value!r}")
    return int(value)


def check_refine(refine) -> int:
    """The refinement's leg-cost queries a plan, or a ConfigError naming the field."""
    return _check_count(refine, "refine", 0, MAX_REFINE, "0: no refinement")


def check_alternatives(alternatives) -> int:
    """OMPL routes per leg scored against the found route's leg, or a ConfigError naming the field."""
    return _check_count(alternatives, "alternatives", 0, MAX_ALTERNATIVES, "0: the found route's legs only")


def check_proposals(proposals) -> int:
    """The number of proposals a step, or a ConfigError naming the field."""
    return _check_count(proposals, "proposals", 1, MAX_PROPOSALS)


class RankedChooser:
    """The ranked planner's rule for one episode: of the policy's ``proposals`` most probable allowed moves, the one
    of least predicted cost to go (``model``), the most probable of equals. A proposal back to a configuration the
    robot stood at since its last goal is taken only if all are: a learned ranking can prefer a move that makes no
    progress, and then again its reverse, until the episode's steps run out (7 of 30 drawn welds without this)."""

    def __init__(self, model: CostModel, proposals: int):
        self.model, self.proposals = model, proposals
        self.reset()

    def reset(self) -> None:
        """A new episode: no configuration visited."""
        self._goal, self._visited = -1, []

    def choose(self, env, obs: np.ndarray, probs: np.ndarray, moving: np.ndarray) -> int:
        """The action for ``env``'s state (``probs``: the policy's probabilities; ``moving``: its masks without
        moves to where the robot stands); records the state as visited."""
        q = env.q
        ranked = ranked_proposals(probs, moving, env.stay_action, self.proposals)
        if self._goal != env.goal_index:
            self._goal, self._visited = env.goal_index, []
        self._visited.append(q.copy())
        targets = [env.target(q, a) for a in ranked]
        new = [k for k, t in enumerate(targets) if not any(np.abs(t - v).max() <= STILL for v in self._visited)]
        if new and len(new) < len(ranked):
            ranked, targets = [ranked[k] for k in new], [targets[k] for k in new]
        if len(ranked) == 1:
            return ranked[0]
        n = len(ranked)
        predicted = self.model.predict(np.repeat(obs[None], n, 0), np.array(ranked), np.array(targets),
                                       np.repeat(q[None], n, 0))
        return ranked[int(np.argmin(predicted))]  # the most probable of the cheapest


@dataclass
class _Step:
    """One simulated env step: its action, ``env.step``'s return and the state after it."""

    action: int
    result: tuple
    after: EnvSnapshot
    cost: float  # the planners' objective for this step: its seconds + its ∫C dt


@dataclass
class _Continuation:
    """Steps from a state to the episode's end (or as far as they got); its cost is inf unless it finished."""

    steps: list[_Step] = field(default_factory=list)
    finished: bool = False

    @property
    def cost(self) -> float:
        return sum(s.cost for s in self.steps) if self.finished else math.inf

    @property
    def first_action(self) -> int | None:
        return self.steps[0].action if self.steps else None


class PolicySearchPlanner(PolicyPlanner):
    """``ppo-search``: a rollout search (policy iteration: a learned cost to go, or simulation) on top of the policy.

    By default (``cost_to_go="none"``; also ``auto`` where the policy ships no model), at every step the
    policy's ``proposals`` most probable allowed moves are each simulated from an env snapshot and continued by the
    policy's most probable actions to the episode's end; each is scored by its finished continuation's cycle time +
    ∫C dt (the planners' objective at time weight 1), and the step of the cheapest is taken. The best continuation
    found so far (the incumbent) is kept and reused, so only new proposals are simulated, and a continuation is
    abandoned as soon as its cost so far passes the incumbent's (every step's cost is positive). The incumbent at
    the start is the policy's own most probable rollout, and each step keeps a continuation at most as dear as the
    one before, so the result never costs more than that rollout (in the env's own simulation: the same physics
    profile the policy trained on).

    With a ``cost_to_go`` model (``auto``: the one shipped beside the policy, where it ships one; a model fit by
    ``dresspack train-cost-model --config cost_to_go``; or the name of one shipped beside the policy) no
    continuation is simulated: each step takes the proposal of least predicted cost to go (:class:`RankedChooser`),
    and the route is the cheaper, in the env's simulation, of that ranked rollout and the policy's most probable one
    (info ``mode``: ``ranked`` or ``argmax``), so never dearer than ``ppo``'s.

    ``proposals=1`` is the ``ppo`` planner's most probable rollout, either way. If the search does not finish the
    task, the ``ppo`` planner's sampled rollouts follow; if none finishes and other routes are asked for
    (``alternatives``), the route starts from OMPL's instead (info ``mode``: ``ompl routes``, with
    ``policy_failure``): a task the policy cannot finish is planned like ``ompl-wear``'s rather than failed. Neither
    the wait nor a move to where the robot stands is proposed.

    Then, leg by leg in path order, ``alternatives`` OMPL routes between the leg's stops (the direct one, then through
    random vias: other route classes than the policy's) compete with the found leg, each scored by an accurate cable
    simulation under ``ompl-wear``'s leg cost (with ``cost_variant`` and ``time_weight``); and the route's vias leave
    the action set's grid: ``refine`` leg-cost queries of the local refiner first try each joint that turns back
    within a leg without its turns, then move the vias without adding turns. A leg is judged with the found legs
    after it (its cable end state is their start) and a change kept only where that sum falls, so the route never
    costs more than the search's in that simulation; waypoints that do not pay for their stop are dropped.
    ``refine=0`` and ``alternatives=0``: the search's route as found.

    """

    name = "ppo-search"
    color = "#0b6e4f"

    def __init__(self, station: Station, robot: int = 0, *, proposals: int = PROPOSALS, refine: int = REFINE,
                 alternatives: int = ALTERNATIVES, cost_to_go: str | Path | None = NONE, cost_variant: str = "thesis",
                 time_weight: float = 1.0, engine: str = DEFAULT_ENGINE, jobs: int = 1, **kwargs):
        proposals, refine = check_proposals(proposals), check_refine(refine)
        alternatives = check_alternatives(alternatives)
        super().__init__(station, robot, **kwargs)
        self.proposals, self.refine = proposals, refine
        # ranks the proposals by predicted cost to go instead of simulating their continuations
        model_file = resolve_cost_to_go(cost_to_go, self.policy_path)
        self.cost_to_go = None if model_file is None else load_cost_to_go(model_file, self.agent.n_actions)
        self._chooser = None if self.cost_to_go is None else RankedChooser(self.cost_to_go, proposals)
        self.refiner = None  # built only if it will be used: its leg cost holds a simulator of its own
        if refine or alternatives:
            # ompl-wear's leg cost, with the wear cost and time weight asked for (the search ranks by the env's
            # objective, the one the policy was trained on)
            leg_cost = LegCost(station, robot, tension_peak_time=TENSION_PEAK_TIME, cost_variant=cost_variant,
                               time_weight=time_weight, engine=engine, jobs=jobs)
            # the refined vias keep the found route's joint turns (free moves of every joint leave small
            # back-and-forth turns that make the motion rougher than the planners'), and a joint's turns within a
            # leg are taken out where the leg then costs less: 2.00 -> 1.76 reversals/s on the drawn welds at the
            # same T + ∫C dt (docs/results_learned.md)
            self.refiner = LocalRefiner(self.validity, leg_cost, keep_turns=True, straighten=True)
        self.alternatives = alternatives
        self.connector = self.routes = None
        if alternatives:
            self.connector = OmplConnector(self.validity, self.name, True)
            # its candidates: the direct route, then routes through random vias, ``alternatives`` in all
            self.routes = ViaRoutes(self.connector, self.validity, self.budget.iterations, alternatives)
        self._simulated = 0  # env steps this plan simulated
        self._incumbent = _Continuation()  # the cheapest known continuation from the current state
        self._network = 0.0  # seconds in the network (proposals and the continuations' actions)
        self._policy_cost: float | None = None  # the policy's own rollout from the start (inf: unfinished)
        self._cost = 0.0  # the steps taken so far

    def _reseed(self) -> None:
        super()._reseed()
        if self.connector is not None:
            self.connector.reseed(self.seed)

    def _plan(self, task: Task) -> tuple[Trajectory, dict]:
        try:
            traj, info = self._policy_route(task)
        except PlanningError as exc:
            if self.routes is None:
                raise
            traj, info = self._ompl_route(task, str(exc))
        if self.refiner is None:
            return traj, info
        t0, cost = time.perf_counter(), self.refiner.cost
        cost.reset()  # a plan never reuses an earlier plan's simulations
        route = refine_legs(self.refiner, cost.start_state(task.start), traj.legs(), self.refine, self.rng,
                            self.allowance, self.routes)
        goals = (*task.weld_names, "home")
        return Trajectory.from_legs(route.legs), {
            **info, "refine_queries": self.refine, "alternatives": self.alternatives,
            "cable_evaluations": cost.evaluations, "cable_simulations_given_up": cost.given_up,
            # the returned route's settles, in the accurate simulation the refinement ranked its legs by
            "unconverged_settles": [g for g, s in zip(goals, route.summaries) if s["unconverged_stops"]],
            "rerouted_legs": [goals[k] for k in route.rerouted],  # legs that start from an OMPL route, by goal
            "waypoints_unrefined": len(traj.waypoints), "leg_cost_unrefined": round(route.cost_given, 6),
            "leg_cost": round(route.cost, 6), "refine_s": round(time.perf_counter() - t0, 3)}

    def _policy_route(self, task: Task) -> tuple[Trajectory, dict]:
        """The route the rest starts from: the search's; with a cost-to-go model, the cheaper (in the env's
        simulation) of the ranked rollout and the policy's own route (``ppo``'s: its most probable rollout, else the
        first of its sampled ones that finishes), so it never costs more than ``ppo``'s."""
        if self.cost_to_go is None:
            return super()._plan(task)
        self._check_ends_at_home(task)
        try:
            traj, info = self._rollout(task, "search")
            ranked = (traj, {**info, "mode": "ranked", "attempts": 1})  # "search" is the simulated search's mode
        except EpisodeFailed as exc:
            ranked, failure = None, f"ranked: {exc}"
        try:
            traj, info = super()._plan(task)  # the policy's own route (_modes: not the ranked rollout)
        except PlanningError as exc:
            if ranked is None:
                raise PlanningError(f"{exc}; {failure}") from None
            traj, info = ranked
        if ranked is not None and ranked[1]["objective"] <= info["objective"]:
            traj, info = ranked
        return traj, {**info, "ranked_objective": None if ranked is None else ranked[1]["objective"]}

    def _ompl_route(self, task: Task, policy_failure: str) -> tuple[Trajectory, dict]:
        """Where the policy does not finish the task: each leg the first of OMPL's routes between its stops (the
        direct one, else one through a random via), for the other routes and the refinement to work on."""
        stops = task.waypoints()
        tries = VIA_TRIES_PER_ROUTE * DEFAULT_ROUTES  # as many vias as ompl-wear's candidates may try
        try:  # the first route found
            legs = [self.routes.candidates(a, b, self.rng, self.allowance, limit=1, via_tries=tries)[0]
                    for a, b in zip(stops[:-1], stops[1:])]
        except PlanningError as exc:
            raise PlanningError(f"{policy_failure}; and {exc}") from None
        # its settles are reported by the refinement's leg simulations, which always follow (routes need a refiner)
        return Trajectory.from_legs(legs), {"policy": str(self.policy_path), "mode": "ompl routes",
                                            "policy_failure": policy_failure}

    def _modes(self) -> list[str]:
        if self.cost_to_go is not None:  # the ranked rollout is tried apart, beside the policy's own (_policy_route)
            return super()._modes()
        return ["search"] if self.deterministic else ["search", *["sample"] * (self.attempts - 1)]

    def _rollout(self, task: Task, mode: str):
        self._simulated, self._incumbent, self._network = 0, _Continuation(), 0.0
        if self._chooser is not None:
            self._chooser.reset()
        self._policy_cost, self._cost = None, 0.0
        traj, info = super()._rollout(task, mode)
        if mode != "search":
            return traj, {**info, "objective": round(self._cost, 6)}
        # the objective in the env's own simulation: the search's path and the policy's most probable rollout
        return traj, {**info, "simulated_steps": self._simulated, "objective": round(self._cost, 6),
                      "ranked_by": "continuations" if self.cost_to_go is None else "cost-to-go model",
                      "policy_objective": _rounded(self._policy_cost),
                      "inference_s": round(info["inference_s"] + self._network, 5)}

    def _step(self, obs, masks, mode: str):
        if mode != "search":
            action, result, seconds = super()._step(obs, masks, mode)
            self._cost += result[4]["step_time"] + result[4]["integral_cost"]
            return action, result, seconds
        if self.cost_to_go is not None:
            return self._ranked_step(obs, masks)
        env = self.env
        t0 = time.perf_counter()
        probs = self.agent.probabilities(obs, masks)
        seconds = time.perf_counter() - t0
        before = env.snapshot()
        moving = self._moving(masks)  # here, before a continuation moves the env on
        if not self._incumbent.steps:  # the policy's own rollout from here
            self._incumbent = self._continue(before, self.agent.predict(obs, moving, deterministic=True), math.inf)
            if self._policy_cost is None:
                self._policy_cost = self._incumbent.cost if self._incumbent.finished else math.inf
        ranked = ranked_proposals(probs, moving, env.stay_action, self.proposals)
        tried = {self._incumbent.first_action: self._incumbent}
        best = self._incumbent
        for a in ranked:
            if a not in tried:
                tried[a] = self._continue(before, a, best.cost)
                if tried[a].cost < best.cost:
                    best = tried[a]
        if not best.finished:  # nothing finishes from here: the most probable move, and search again after it
            best = tried[ranked[0]]
        first = best.steps[0]
        env.restore(first.after)
        self._cost += first.cost
        self._incumbent = _Continuation(best.steps[1:], True) if best.finished else _Continuation()
        return first.action, first.result, seconds

    def _ranked_step(self, obs, masks):
        """The ranked rule's action (:class:`RankedChooser`), taken without simulating any continuation."""
        env = self.env
        t0 = time.perf_counter()
        moving = self._moving(masks)
        action = self._chooser.choose(env, obs, self.agent.probabilities(obs, moving), moving)
        seconds = time.perf_counter() - t0
        result = env.step(action)
        self._simulated += 1
        self._cost += result[4]["step_time"] + result[4]["integral_cost"]
        return action, result, seconds

    def _continue(self, start: EnvSnapshot, action: int, bound: float) -> _Continuation:
        """From ``start``: ``action``, then the policy's most probable actions to the episode's end, abandoned once
        its cost reaches ``bound`` (unfinished)."""
        env, steps, total = self.env, [], 0.0
        env.restore(start)
        while True:
            result = env.step(action)
            self._simulated += 1
            obs, _, terminated, truncated, info = result
            cost = info["step_time"] + info["integral_cost"]
            total += cost
            steps.append(_Step(action, result, env.snapshot(), cost))
            if terminated or truncated or total >= bound:
                return _Continuation(steps, bool(terminated and info["is_success"] and total < bound))
            t0 = time.perf_counter()
            action = self.agent.predict(obs, self._moving(env.action_masks()), deterministic=True)
            self._network += time.perf_counter() - t0


def _rounded(cost: float | None) -> float | None:
    """For the plan's info (JSON): None where the policy's rollout did not finish."""
    return round(cost, 6) if cost is not None and math.isfinite(cost) else None
