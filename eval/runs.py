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
from dresspack.agents.learned.policy import DEFAULT_POLICY, resolve_policy
from dresspack.agents.learned.search import (
    ALTERNATIVES,
    AUTO,
    NONE,
    PROPOSALS,
    REFINE,
    PolicySearchPlanner,
    check_alternatives,
    check_proposals,
    check_refine,
    resolve_cost_to_go,
)
from dresspack.agents.planners.base import PlanningError
from dresspack.agents.planners.budget import DEFAULT_EVALUATIONS, DEFAULT_ITERATIONS, DEFAULT_ROUTES, Budget
from dresspack.agents.planners.leg_cost import check_time_weight
from dresspack.agents.planners.registry import PLANNERS, POLICY_METHODS, WEAR_AWARE, make_planner
from tqdm.auto import tqdm

from dresspack_gym.cli.common import ctrl_c_remembered as _ctrl_c_remembered
from dresspack_gym.errors import ConfigError, DresspackError
from dresspack_gym.fields import check_choice
from dresspack_gym.io.artefacts import read_json
from dresspack_gym.io.loading import load_station
from dresspack_gym.io.provenance import code_fingerprint, library_versions
from dresspack_gym.physics.profiles import DEFAULT_ENGINE, ENGINES, make_simulator
from dresspack_gym.physics.trajectory import Replay, Trajectory, replay, smoothness
from dresspack_gym.physics.wear_cost import cost_function
from dresspack_gym.process_pool import spawn_pool
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import Task, closest_branch, make_task, random_start
from dresspack_gym.stations.validity import PLANNER_MARGIN, MotionValidity
from dresspack_gym.stations.weld_sampling import WeldSampler

# what an evaluation's rows depend on: the simulation and its configs, the planners and shipped policies, the replay
CODE = ("dresspack_gym", "dresspack_gym.configs", "dresspack.agents", "dresspack.eval")
# the libraries whose arithmetic the rows depend on: the cable physics, the collision checks' and planners' numbers,
# the policy's network and the time law (either MuJoCo distribution; one is not installed)
LIBRARIES = ("mujoco-core", "mujoco", "numpy", "scipy", "ompl", "torch", "stable-baselines3", "sb3-contrib", "ruckig",
             "gymnasium")
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
    proposals: int = PROPOSALS  # ppo-search: the policy's moves tried at every step
    refine: int = REFINE  # ppo-search: leg-cost queries moving the found route's vias
    alternatives: int = ALTERNATIVES  # ppo-search: OMPL via routes per leg scored against the found route's leg
    # ppo-search: what ranks the proposals (search.resolve_cost_to_go): None (stored for "none"): simulated
    # continuations; auto (the model shipped with the policy), a model.pt or a shipped name
    cost_to_go: str | None = None
    policy: str | None = None  # run folder / model / shipped name for ppo (and the random floor's env)
    robot: int = 0
    # > 0: the tasks are this many single welds drawn on the station's parts (weld_sampling), weld k from
    # (drawn_seed, k): seeds of their own, apart from any training's, so every method meets welds no one trained on
    drawn_tasks: int = 0
    drawn_seed: int = DRAWN_SEED
    # the cable engine every method's final trajectory is replayed and measured in (physics.profiles.ENGINES), and
    # the one the wear-aware planners simulate their legs on: plans made on one engine can be judged on the other
    physics: str = DEFAULT_ENGINE
    planner_physics: str = DEFAULT_ENGINE

    def __post_init__(self):
        if self.drawn_tasks:
            if not isinstance(self.drawn_tasks, int) or not 1 <= self.drawn_tasks <= 10_000:
                raise ConfigError("drawn_tasks", f"must be an integer in [1, 10000], got {self.drawn_tasks!r}")
            object.__setattr__(self, "tasks", tuple((f"{DRAWN}{k}",) for k in range(self.drawn_tasks)))
        unknown = [m for m in self.methods if m not in PLANNERS]
        if unknown or not self.methods:
            raise ConfigError("methods", f"{unknown or 'none given'}: choose from {list(PLANNERS)}")
        if self.policy is None and any(m in POLICY_METHODS for m in self.methods):
            # named, not left to a default that may change: a resumed folder's rows all come from one policy
            object.__setattr__(self, "policy", DEFAULT_POLICY)
        if not self.tasks or not all(self.tasks):
            raise ConfigError("tasks", "give at least one non-empty weld list")
        if not self.seeds:
            raise ConfigError("seeds", "give at least one seed")
        Budget(self.iterations, self.evaluations, self.routes, self.time_budget)  # checks them, naming the field
        cost_function(self.cost_variant)  # names the field if unknown
        check_time_weight(self.time_weight)
        check_proposals(self.proposals)
        check_refine(self.refine)
        check_alternatives(self.alternatives)
        if self.cost_to_go == NONE:  # one spelling in spec.json: folders written before the setting hold None
            object.__setattr__(self, "cost_to_go", None)
        if self.cost_to_go not in (None, AUTO):  # named now, not after the other methods' runs
            resolve_cost_to_go(self.cost_to_go, resolve_policy(self.policy)[0])
        check_choice("physics", self.physics, list(ENGINES))
        check_choice("planner_physics", self.planner_physics, list(ENGINES))
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
_ADDED_SETTINGS = {"time_weight": 1.0, "proposals": PROPOSALS, "refine": 0, "alternatives": 0, "cost_to_go": None,
                   "physics": "dynamic", "planner_physics": "dynamic"}


def _extends(stored: dict, new: dict) -> bool:
    """Whether ``new`` is ``stored`` or adds methods to it: the finished rows of the stored methods stay valid
    (same tasks, seeds and settings; the policy may be set only if no stored method used it)."""
    stored = {**_ADDED_SETTINGS, **stored}
    free = {"methods"} | ({"policy"} if not set(stored["methods"]) & set(POLICY_METHODS) else set())
    same = all(stored.get(k) == v for k, v in new.items() if k not in free) and set(stored) == set(new)
    return same and set(stored["methods"]) <= set(new["methods"])


def run_evaluation(spec: EvalSpec, out: str | Path, *, progress: bool = True,
                   jobs: int = 1) -> tuple[list[dict], dict]:
    """Every method x task x seed, on ``jobs`` processes; returns the rows (in spec order) and the replays made in
    this call. Every run is seeded on its own, so the rows do not depend on ``jobs`` (but for wall-clock times)."""
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ConfigError("jobs", f"must be an integer >= 1, got {jobs!r}")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ConfigError("out", f"{out} is an existing file: give a folder for the report")
    spec_file, code, libraries = out / "spec.json", code_fingerprint(CODE), library_versions(LIBRARIES)
    if spec_file.is_file():
        stored = read_json(spec_file, "out", "evaluation spec (spec.json)",
                           recover=f"delete {out} (or give another --out) to start over")
        stored_code = stored.pop("code", None)  # None: written before the code was recorded
        if stored_code != code:
            raise ConfigError("out", f"{out} holds rows of other code (spec.json's code: {stored_code or 'none'}; "
                                     f"this code: {code}): one folder's rows come from one version of the code; "
                                     "choose another folder, or delete it to start over")
        stored_libraries = stored.pop("libraries", None) or {}  # {}: written before the libraries were recorded
        if stored_libraries != libraries:
            changed = sorted(k for k in {*stored_libraries, *libraries} if stored_libraries.get(k) != libraries.get(k))
            raise ConfigError("out", f"{out} holds rows computed with other libraries ("
                                     + "; ".join(f"{k}: {stored_libraries.get(k)} there, {libraries.get(k)} here"
                                                 for k in changed)
                                     + "): one folder's rows come from one set of libraries; choose another "
                                       "folder, or delete it to start over")
        if not _extends(stored, spec.to_dict()):
            raise ConfigError("out", f"{out} holds an evaluation with other settings (spec.json): choose another "
                                     "folder, or delete it to start over (adding methods to it is allowed)")
    # every input is checked before anything is written: a failed start leaves no spec.json behind
    station = Station(load_station(spec.station))
    tasks = build_tasks(station, spec)
    if spec.policy is not None or any(m in POLICY_METHODS for m in spec.methods):
        from dresspack.agents.learned.policy import resolve_policy

        resolve_policy(spec.policy)
    (out / "trajectories").mkdir(parents=True, exist_ok=True)
    spec_file.write_text(json.dumps({**spec.to_dict(), "code": code, "libraries": libraries}, indent=2) + "\n")
    done = _read_rows(out / "results.jsonl")
    # rewrite the log with the complete rows only: a line cut by an interruption would otherwise swallow the
    # next row appended to it
    (out / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in done.values()))
    runs = [(m, w, s) for w in spec.tasks for m in spec.methods for s in spec.seeds]
    todo = [run for run in runs if run_key(*run) not in done]
    replays: dict[str, Replay] = {}
    bar = tqdm(total=len(runs), initial=len(runs) - len(todo), desc="evaluating", unit="run",
               disable=not progress, dynamic_ncols=True)
    try:
        for row, rep in _finished_runs(spec, out, tasks, todo, jobs, bar):
            if rep is not None:
                replays[row["key"]] = rep
            with open(out / "results.jsonl", "a") as f:  # in finishing order; the rows returned are in spec order
                f.write(json.dumps(row) + "\n")
            done[row["key"]] = row
            bar.update(1)
    finally:  # an interrupted bar ends before the interruption's line is printed
        bar.close()
    rows = [done[run_key(*run)] for run in runs]
    return rows, replays


def _describe(run: tuple) -> str:
    method, welds, seed = run
    return f"{method} on {'+'.join(welds)}, seed {seed}"


# Typical time per run, longest first (the demo: ompl-wear 10-30 s, ppo-search 18-40 s, thesis-local 5-15 s,
# random and ppo 2-10 s, ompl 1-2 s). A pool starts the long runs first, so that no long run is left alone on one
# worker at the end.
SLOWEST_FIRST = ("ompl-wear-fmt", "ompl-wear", "ppo-search", "thesis-local", "random", "ppo", "ompl")


def _slowest_first(runs: list[tuple]) -> list[tuple]:
    rank = {m: i for i, m in enumerate(SLOWEST_FIRST)}
    return sorted(runs, key=lambda run: rank.get(run[0], len(rank)))


def _finished_runs(spec: EvalSpec, out: Path, tasks: dict, todo: list[tuple], jobs: int, bar):
    """(row, replay or None) of every run in ``todo`` as it finishes: here, or on a pool of ``jobs`` processes."""
    if jobs == 1 or len(todo) < 2:
        runner = RunEvaluator(spec, out, tasks)
        with _ctrl_c_remembered() as pressed:
            for run in todo:
                bar.set_postfix_str(_describe(run))
                result = runner.run(*run)
                if pressed():  # a Ctrl-C that the planner swallowed ends the evaluation here, after the run
                    raise KeyboardInterrupt
                yield result
        return
    # the workers never see Ctrl-C: one that lands while a worker writes its result to the pool's pipe can leave the
    # pool's terminate() waiting on it
    with spawn_pool(min(jobs, len(todo)), _init_worker, (spec, out, tasks)) as pool:
        for row, rep, error in pool.imap_unordered(_run_in_worker, _slowest_first(todo)):
            if error is not None:
                raise DresspackError(error)
            bar.set_postfix_str(f"done {_describe((row['method'], row['welds'], row['seed']))}")
            yield row, rep


class RunEvaluator:
    """One process's share of an evaluation: runs (method, welds, seed), each planned, replayed and measured.

    Holds the station, its simulator and one planner per (method, seed), built on first use: a planner restarts
    every random stream from its seed at each plan, so a run's row does not depend on the runs before it."""

    def __init__(self, spec: EvalSpec, out: Path, tasks: dict):
        self.spec, self.out, self.tasks = spec, out, tasks
        self.station = Station(load_station(spec.station))
        self.sim = make_simulator(self.station, spec.physics)
        self.limits = self.station.config.robots[spec.robot].robot.joint_motion_limits.at_speed(
            self.station.config.simulation.speed_fraction)  # every method's motions timed by the one law
        self.planners: dict[tuple[str, int], object] = {}

    def planner(self, method: str, seed: int):
        spec = self.spec
        if (method, seed) not in self.planners:  # loading a policy or building a validity checker once
            kwargs = {"policy": spec.policy} if method in POLICY_METHODS else {}
            if method in WEAR_AWARE:
                kwargs["cost_variant"] = spec.cost_variant
                kwargs["time_weight"] = spec.time_weight
                kwargs["engine"] = spec.planner_physics
            if method == PolicySearchPlanner.name:
                kwargs.update(proposals=spec.proposals, refine=spec.refine, alternatives=spec.alternatives,
                              cost_to_go=spec.cost_to_go)
            self.planners[(method, seed)] = make_planner(method, self.station, spec.robot, seed=seed,
                                                         iterations=spec.iterations, evaluations=spec.evaluations,
                                                         routes=spec.routes, time_budget=spec.time_budget, **kwargs)
        return self.planners[(method, seed)]

    def run(self, method: str, welds, seed: int) -> tuple[dict, Replay | None]:
        """The run's row and replay (None if planning failed); its trajectory is saved before the row is returned,
        so a row in the log means its trajectory is on disk."""
        spec, key = self.spec, run_key(method, welds, seed)
        planner = self.planner(method, seed)
        task = self.tasks[(tuple(welds), seed)]
        row = {"key": key, "method": method, "task": task_label(welds), "welds": list(welds), "seed": seed,
               "start_deg": np.round(np.degrees(task.start), 3).tolist()}
        try:
            result = planner.plan(task)
        except PlanningError as exc:
            row.update(success=False, error=str(exc), **dict.fromkeys(METRICS))
            return row, None
        # positions kept: the report draws its videos and worst moments from them without simulating again
        rep = replay(self.sim, result.trajectory, robot=spec.robot, cost_variant=spec.cost_variant, record_qpos=True)
        s = {**rep.summary(), **smoothness(result.trajectory, self.limits)}
        row.update(success=True, error=None, planning_time=round(result.planning_time, 4),
                   waypoints=len(result.trajectory.waypoints),
                   **{k: s[k] for k in METRICS if k != "planning_time"},
                   cost_terms=s["cost_terms"], max_cost=s["max_cost"], weakest_segment_m=s["weakest_segment_m"],
                   weakest_cause=s["weakest_cause"], weakest_strain_amplitude=s["weakest_strain_amplitude"],
                   unconverged_stops=s["unconverged_stops"])  # settles that missed the residual: flagged
        if "inference_s" in result.info:  # a policy: the network's share of its planning time
            row["inference_time"] = result.info["inference_s"]
        np.savez(_trajectory_path(self.out, key), waypoints=result.trajectory.waypoints,
                 stops=np.array(result.trajectory.stops))
        return row, rep


_WORKER: dict = {}  # a pool worker's evaluation: its arguments, then its RunEvaluator (built by the first run)


def _init_worker(spec: EvalSpec, out: Path, tasks: dict) -> None:
    """Nothing that can fail runs here: a failing initializer makes the pool start workers forever."""
    _WORKER.update(args=(spec, out, tasks))


def _run_in_worker(run: tuple) -> tuple[dict | None, Replay | None, str | None]:
    try:
        if "evaluator" not in _WORKER:
            spec = _WORKER["args"][0]
            if any(m in POLICY_METHODS for m in spec.methods):
                import torch

                # one thread per process: torch's intra-op pool would otherwise take every core in every worker
                # (MuJoCo steps single-threaded: nothing here gives it a thread pool)
                torch.set_num_threads(1)
            _WORKER["evaluator"] = RunEvaluator(*_WORKER["args"])
        return (*_WORKER["evaluator"].run(*run), None)
    except DresspackError as exc:  # sent back as its message: a ConfigError's arguments do not survive pickling
        return None, None, str(exc)


def _read_rows(path: Path) -> dict[str, dict]:
    rows = {}
    if path.is_file():
        for line in path.read_text().splitlines():
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue  # a line cut by an interruption: that run is simply done again
            if isinstance(row, dict) and isinstance(row.get("key"), str):
                rows[row["key"]] = row
    return rows
