"""Run every method on the same tasks and seeds, replay each trajectory in the same simulator, keep every row.

Rows go to ``results.jsonl`` as they finish (an interrupted evaluation resumes where it stopped); trajectories
go to ``trajectories/`` so figures can be redrawn from them.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from dresspack.agents.planners.base import PlanningError
from dresspack.agents.planners.budget import DEFAULT_EVALUATIONS, DEFAULT_ITERATIONS, DEFAULT_ROUTES, Budget
from dresspack.agents.planners.leg_cost import check_time_weight
from dresspack.agents.planners.registry import PLANNERS, POLICY_METHODS, WEAR_AWARE, make_planner
from tqdm.auto import tqdm

from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import Replay, Trajectory, replay, smoothness
from dresspack_gym.physics.wear_cost import cost_function
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import Task, closest_branch, make_task, random_start
from dresspack_gym.stations.validity import PLANNER_MARGIN, MotionValidity
from dresspack_gym.stations.weld_sampling import WeldSampler

METRICS = ("cycle_time", "max_curvature", "max_tension", "min_clearance", "max_twist_rate", "cost", "damage",
           "life_cycles", "reversals_per_s", "peak_joint_acceleration", "planning_time")


DRAWN = "drawn_"  # name prefix of welds drawn on the parts
DRAWN_SEED = 1_000_000


@dataclass(frozen=True)
class EvalSpec:
    """What to compare: methods x tasks (weld lists) x seeds on one station."""

    station: str = "default"
    methods: tuple[str, ...] = tuple(PLANNERS)
    tasks: tuple[tuple[str, ...], ...] = (("sill_rear", "roof_rail_top"), ("b_pillar_outer", "sill_front"))
    seeds: tuple[int, ...] = (0, 1)
    iterations: int = DEFAULT_ITERATIONS  # OMPL iterations per connection (work units: reproducible anywhere)
    evaluations: int = DEFAULT_EVALUATIONS  # cable-leg cost queries of the wear-aware refinement per plan
    routes: int = DEFAULT_ROUTES  # candidate routes per leg that ompl-wear samples and scores
    time_budget: float | None = None  # optional wall-time cap per plan [s] (a capped plan depends on load)
    start_noise_deg: float = 0.0  # > 0: each seed starts at its own valid configuration near Home
    cost_variant: str = "thesis"  # the wear cost the wear-aware planners minimise and every replay reports
    # the wear-aware planners' leg cost: time_weight x seconds + ∫C dt (+ peak term); > 1 trades wear for speed
    time_weight: float = 1.0
    policy: str | None = None  # run folder / model / shipped name for ppo (and the random floor's env)
    robot: int = 0
    # > 0: the tasks are this many single welds drawn on the station's parts (weld_sampling), weld k from
    # (drawn_seed, k): seeds of their own, apart from any training's, so every method meets welds no one trained on
    drawn_tasks: int = 0
    drawn_seed: int = DRAWN_SEED

    def __post_init__(self):
        if self.drawn_tasks:
            if not isinstance(self.drawn_tasks, int) or not 1 <= self.drawn_tasks <= 10_000:
                raise ConfigError("drawn_tasks", f"must be an integer in [1, 10000], got {self.drawn_tasks!r}")
            object.__setattr__(self, "tasks", tuple((f"{DRAWN}{k}",) for k in range(self.drawn_tasks)))
        unknown = [m for m in self.methods if m not in PLANNERS]
        if unknown or not self.methods:
            raise ConfigError("methods", f"{unknown or 'none given'}: choose from {list(PLANNERS)}")
        if not self.tasks or not all(self.tasks):
            raise ConfigError("tasks", "give at least one non-empty weld list")
        if not self.seeds:
            raise ConfigError("seeds", "give at least one seed")
        Budget(self.iterations, self.evaluations, self.routes, self.time_budget)  # checks them, naming the field
        cost_function(self.cost_variant)  # names the field if unknown
        check_time_weight(self.time_weight)
        if not 0 <= self.start_noise_deg <= 90:
            raise ConfigError("start_noise_deg", f"must be in [0, 90] deg, got {self.start_noise_deg}")

    def to_dict(self) -> dict:
        return {**asdict(self), "methods": list(self.methods), "tasks": [list(t) for t in self.tasks],
                "seeds": list(self.seeds)}


def task_label(welds) -> str:
    return " → ".join(welds)


def run_key(method: str, welds, seed: int) -> str:
    return f"{method}|{'+'.join(welds)}|{seed}"


def eval_start(station: Station, robot: int, seed: int, noise_deg: float,
               validity: MotionValidity | None = None) -> np.ndarray:
    """The seed's start configuration: Home, or a valid configuration within ``noise_deg`` of it."""
    home = station.config.robots[robot].home.copy()
    if noise_deg <= 0:
        return home
    validity = validity or MotionValidity(station, robot, margin=PLANNER_MARGIN)
    rng = np.random.default_rng([seed, 7919])  # not the training streams
    return random_start(home, math.radians(noise_deg), rng, validity.valid)


def build_tasks(station: Station, spec: EvalSpec) -> dict[tuple[tuple[str, ...], int], Task]:
    validity = MotionValidity(station, spec.robot, margin=PLANNER_MARGIN)
    tasks = {}
    sampler = WeldSampler(station, spec.robot, validity.checker.collides) if spec.drawn_tasks else None
    for welds in spec.tasks:
        if sampler is not None:  # one drawn weld per task, the goal chosen as for named welds
            k = int(welds[0][len(DRAWN):])
            drawn = sampler.sample(np.random.default_rng([spec.drawn_seed, k]), welds[0])
            home = station.config.robots[spec.robot].home
            base = Task(spec.robot, home.copy(), tuple(welds), closest_branch(drawn.configurations, home)[None],
                        home.copy())
        else:
            base = make_task(station, spec.robot, validity.checker.collides, list(welds), field="tasks")
        for seed in spec.seeds:
            start = eval_start(station, spec.robot, seed, spec.start_noise_deg, validity)
            tasks[(tuple(welds), seed)] = Task(base.robot, start, base.weld_names, base.goals, base.end)
    return tasks


def _trajectory_path(out: Path, key: str) -> Path:
    return out / "trajectories" / (key.replace("|", "__").replace("+", "-") + ".npz")


def load_trajectory(out: Path, row: dict) -> Trajectory | None:
    path = _trajectory_path(out, row["key"])
    if not row["success"] or not path.is_file():
        return None
    data = np.load(path)
    return Trajectory(data["waypoints"], tuple(int(i) for i in data["stops"]))


# settings added after evaluations were already stored, with the value those evaluations used
_ADDED_SETTINGS = {"time_weight": 1.0}


def _extends(stored: dict, new: dict) -> bool:
    """Whether ``new`` is ``stored`` or adds methods to it: the finished rows of the stored methods stay valid
    (same tasks, seeds and settings; the policy may be set only if no stored method used it)."""
    stored = {**_ADDED_SETTINGS, **stored}
    free = {"methods"} | ({"policy"} if not set(stored["methods"]) & set(POLICY_METHODS) else set())
    same = all(stored.get(k) == v for k, v in new.items() if k not in free) and set(stored) == set(new)
    return same and set(stored["methods"]) <= set(new["methods"])


def run_evaluation(spec: EvalSpec, out: str | Path, *, progress: bool = True) -> tuple[list[dict], dict]:
    """Every method x task x seed; returns the rows (in spec order) and the replays made in this call."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ConfigError("out", f"{out} is an existing file: give a folder for the report")
    spec_file = out / "spec.json"
    if spec_file.is_file() and not _extends(json.loads(spec_file.read_text()), spec.to_dict()):
        raise ConfigError("out", f"{out} holds an evaluation with other settings (spec.json): choose another "
                                 "folder, or delete it to start over (adding methods to it is allowed)")
    # every input is checked before anything is written: a failed start leaves no spec.json behind
    station = Station(load_station(spec.station))
    tasks = build_tasks(station, spec)
    if spec.policy is not None or any(m in POLICY_METHODS for m in spec.methods):
        from dresspack.agents.learned.policy import resolve_policy

        resolve_policy(spec.policy)
    (out / "trajectories").mkdir(parents=True, exist_ok=True)
    spec_file.write_text(json.dumps(spec.to_dict(), indent=2) + "\n")
    done = _read_rows(out / "results.jsonl")
    # rewrite the log with the complete rows only: a line cut by an interruption would otherwise swallow the
    # next row appended to it
    (out / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in done.values()))
    sim = CableSimulator(station)
    limits = station.config.robots[spec.robot].robot.joint_motion_limits.at_speed(
        station.config.simulation.speed_fraction)  # every method's motions timed by the one law
    planners: dict[tuple[str, int], object] = {}
    replays: dict[str, Replay] = {}
    todo = [(m, w, s) for w in spec.tasks for m in spec.methods for s in spec.seeds]
    bar = tqdm(todo, desc="evaluating", unit="run", disable=not progress, dynamic_ncols=True)
    for method, welds, seed in bar:
        key = run_key(method, welds, seed)
        if key in done:
            continue
        bar.set_postfix_str(f"{method} on {'+'.join(welds)}, seed {seed}")
        kwargs = {"policy": spec.policy} if method in POLICY_METHODS else {}
        if method in WEAR_AWARE:
            kwargs["cost_variant"] = spec.cost_variant
            kwargs["time_weight"] = spec.time_weight
        if (method, seed) not in planners:  # loading a policy or building a validity checker once per seed
            planners[(method, seed)] = make_planner(method, station, spec.robot, seed=seed,
                                                    iterations=spec.iterations, evaluations=spec.evaluations,
                                                    routes=spec.routes,
                                                    time_budget=spec.time_budget, **kwargs)
        planner = planners[(method, seed)]
        task = tasks[(tuple(welds), seed)]
        row = {"key": key, "method": method, "task": task_label(welds), "welds": list(welds), "seed": seed,
               "start_deg": np.round(np.degrees(task.start), 3).tolist()}
        try:
            result = planner.plan(task)
        except PlanningError as exc:
            row.update(success=False, error=str(exc), **dict.fromkeys(METRICS))
        else:
            rep = replay(sim, result.trajectory, robot=spec.robot, cost_variant=spec.cost_variant)
            replays[key] = rep
            s = {**rep.summary(), **smoothness(result.trajectory, limits)}
            row.update(success=True, error=None, planning_time=round(result.planning_time, 4),
                       waypoints=len(result.trajectory.waypoints),
                       **{k: s[k] for k in METRICS if k != "planning_time"},
                       cost_terms=s["cost_terms"], max_cost=s["max_cost"], weakest_segment_m=s["weakest_segment_m"],
                       unconverged_stops=s["unconverged_stops"])  # settles that missed the residual: flagged
            if "inference_s" in result.info:  # a policy: the network's share of its planning time
                row["inference_time"] = result.info["inference_s"]
            np.savez(_trajectory_path(out, key), waypoints=result.trajectory.waypoints,
                     stops=np.array(result.trajectory.stops))
        with open(out / "results.jsonl", "a") as f:
            f.write(json.dumps(row) + "\n")
        done[key] = row
    bar.close()
    rows = [done[run_key(m, w, s)] for w in spec.tasks for m in spec.methods for s in spec.seeds]
    return rows, replays


def _read_rows(path: Path) -> dict[str, dict]:
    rows = {}
    if path.is_file():
        for line in path.read_text().splitlines():
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue  # a line cut by an interruption: that run is simply done again
            rows[row["key"]] = row
    return rows
