"""How low the wear of a policy's action set goes: a beam search over the masked actions of the exact env a policy
acts in, for the planners' objective (motion time + ∫C dt), its best sequence replayed as the evaluation replays.

    PYTHONPATH=. .venv/bin/python scripts/studies/action_set_bound.py --policy goal_conditioned --drawn-tasks 30 \
        --tasks 0 1 2 3 --compare ppo=runs/eval/drawn30/results.json --out docs/data/action_set_bound.json

The tasks are `dresspack eval --drawn-tasks N --seeds S --start-noise-deg D`'s (Home-ish start, one weld drawn on
the parts, back Home). The env is the one the `ppo` method rolls out (the policy's training config, the task's own
goals and start). Each leg (to the weld, then Home from the best few weld-leg ends) is searched breadth first with
``DresspackEnv.snapshot``/``restore``: every unmasked action of every kept sequence is tried, and the ``--beam``
sequences with the lowest time + ∫C so far plus the straight-line time still to go (weighted by the wear per second
of the legs finished so far) are kept, until no better leg end comes for ``--patience`` depths or the leg has used
``--leg-steps`` env steps (the work budget: the same answer on any machine). A beam search gives an upper bound on
what the action set can do; what a trained policy does is the evaluation's business. ``--compare`` puts the rows of
other methods (an evaluation's results.json) on the same tasks beside it.
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from dresspack.agents.planners.registry import make_planner
from dresspack.eval.runs import EvalSpec, build_tasks

from dresspack_gym.env.dresspack_env import DresspackEnv
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import Trajectory, replay
from dresspack_gym.stations.station import Station

DEFAULT_WEAR_RATE = 20.0  # ∫C per second assumed for the time still to go until a leg has finished once


@dataclass
class Node:
    actions: tuple[int, ...]
    snap: object
    time: float  # motion seconds so far
    wear: float  # ∫C dt so far (the env's own, in its physics profile)
    waypoints: tuple
    stops: tuple
    goal_index: int
    q: np.ndarray
    done: bool = False

    @property
    def cost(self) -> float:
        return self.time + self.wear


def child(env, parent: Node, action: int) -> tuple[Node, bool]:
    """``action`` taken from ``parent``'s state (the ppo rollout's waypoint and stop bookkeeping)."""
    env.restore(parent.snap)
    before = env.goal_index
    _, _, terminated, truncated, info = env.step(action)
    wps = list(parent.waypoints)
    wps += [q for q in info["moved_through"] if not np.allclose(q, wps[-1], atol=1e-12)]
    stops = parent.stops + ((len(wps) - 1,) if info["goals_reached"] > before else ())
    node = Node(parent.actions + (action,), env.snapshot(), parent.time + info["step_time"],
                parent.wear + info["integral_cost"], tuple(wps), stops, env.goal_index, env.q,
                done=bool(info["is_success"]))
    return node, truncated or terminated


def straight_time(limits, q: np.ndarray, goal: np.ndarray) -> float:
    return float(Trajectory(np.array([q, goal]), ()).segment_durations(limits).sum())


def search_leg(env, root: Node, limits, beam: int, leg_steps: int, patience: int, rates: list[float]) -> list[Node]:
    """The leg's completions (its goal reached), cheapest first."""
    goal_index, goal = root.goal_index, env.goal.copy()
    completions, frontier, visited = [], [root], {root.q.round(6).tobytes()}
    steps, stale, best = 0, 0, math.inf
    while frontier and steps < leg_steps and stale < patience:
        children = {}
        for parent in frontier:
            env.restore(parent.snap)
            if env.steps >= env.max_steps:
                continue
            for a in np.flatnonzero(env.action_masks()):
                if steps >= leg_steps:
                    break
                node, ended = child(env, parent, int(a))
                steps += 1
                if node.goal_index > goal_index:
                    completions.append(node)
                    if node.time > parent.time:
                        rates.append((node.wear - parent.wear) / (node.time - parent.time))
                    continue
                key = node.q.round(6).tobytes()
                if ended or key in visited or (key in children and children[key].cost <= node.cost):
                    continue
                children[key] = node
        visited.update(children)
        rate = float(np.median(rates)) if rates else DEFAULT_WEAR_RATE
        ranked = sorted(children.values(), key=lambda n: n.cost + (1.0 + rate) * straight_time(limits, n.q, goal))
        frontier = ranked[:beam]
        found = min((n.cost for n in completions), default=math.inf)
        if completions:  # patience counts only once the leg can be finished at all
            stale = 0 if found < best - 1e-9 else stale + 1
        best = min(best, found)
    return sorted(completions, key=lambda n: n.cost)


def search_task(env, task, seed: int, limits, args) -> tuple[Node | None, int]:
    env.reset(seed=seed, options={"goals": dict(zip(task.weld_names, task.goals)), "start": task.start})
    return search_episode(env, limits, args)


def search_episode(env, limits, args) -> tuple[Node | None, int]:
    """The cheapest finished sequence of the episode ``env`` was just reset to (None if none), and how many legs
    finished (the wear-rate samples)."""
    root = Node((), env.snapshot(), 0.0, 0.0, (env.q,), (), env.goal_index, env.q)
    rates: list[float] = []
    finished = []
    legs = [root]
    for _ in range(env.task.n_goals):  # weld(s), then Home: each leg from the best few ends of the one before
        ends = []
        for start in legs[:args.leg_starts]:
            ends += search_leg(env, start, limits, args.beam, args.leg_steps, args.patience, rates)
        finished += [n for n in ends if n.done]
        legs = sorted((n for n in ends if not n.done), key=lambda n: n.cost)
    best = min(finished, key=lambda n: n.cost, default=None)
    return best, len(rates)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--station", default="default")
    ap.add_argument("--policy", default="goal_conditioned", help="the policy whose env (action set, physics) is searched")
    ap.add_argument("--drawn-tasks", type=int, default=30)
    ap.add_argument("--tasks", type=int, nargs="+", help="indices k of drawn_k (default: all)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--start-noise-deg", type=float, default=10.0)
    ap.add_argument("--beam", type=int, default=5)
    ap.add_argument("--leg-steps", type=int, default=600, help="env steps a leg's search may take (work budget)")
    ap.add_argument("--leg-starts", type=int, default=2, help="ends of one leg from which the next is searched")
    ap.add_argument("--patience", type=int, default=2, help="depths without a cheaper leg end before a leg stops")
    ap.add_argument("--compare", nargs="*", default=[], metavar="METHOD=RESULTS_JSON",
                    help="put that method's rows of an evaluation's results.json beside the search's")
    ap.add_argument("--env-kwargs", type=json.loads, default={}, metavar="JSON",
                    help='changes to the policy\'s env, e.g. \'{"via_postures_deg": [[-93, -46, -108, 52, 14, 223]]}\' '
                         "(what a changed action set could do)")
    ap.add_argument("--out", default="docs/data/action_set_bound.json")
    args = ap.parse_args()

    spec = EvalSpec(methods=("ppo",), station=args.station, drawn_tasks=args.drawn_tasks, seeds=(args.seed,),
                    start_noise_deg=args.start_noise_deg, policy=args.policy)
    station = Station(load_station(args.station))
    tasks = build_tasks(station, spec)
    env = make_planner("ppo", station, 0, seed=args.seed, policy=args.policy).env
    if args.env_kwargs:
        env = DresspackEnv(**{**env._kwargs, **args.env_kwargs})
    limits = station.config.robots[0].robot.joint_motion_limits.at_speed(station.config.simulation.speed_fraction)
    judge = CableSimulator(station)  # the evaluation's replay, at the station's own (accurate) physics
    compare = {}
    for item in args.compare:
        label, path = item.split("=", 1)
        compare[label] = {(r["task"], r["seed"]): r for r in json.loads(Path(path).read_text())["rows"]
                          if r["method"] == label}  # an evaluation's rows of that method
    out = Path(args.out)
    done = {}
    if out.is_file():  # resumable: finished tasks are kept, if they were searched in the same env and tasks
        before = json.loads(out.read_text())
        same = ("station", "policy", "drawn_tasks", "seed", "start_noise_deg", "env_kwargs")
        changed = [k for k in same if before["args"].get(k, {} if k == "env_kwargs" else None) != vars(args)[k]]
        if changed:
            raise SystemExit(f"{out} holds a search with other {', '.join(changed)}: give another --out")
        done = before["tasks"]
    names = [f"drawn_{k}" for k in (args.tasks if args.tasks is not None else range(args.drawn_tasks))]
    for name in names:
        if name in done:
            continue
        best, _ = search_task(env, tasks[((name,), args.seed)], args.seed, limits, args)
        row = {"task": name, "seed": args.seed, "found": best is not None}
        if best is not None:
            traj = Trajectory(np.array(best.waypoints), best.stops)
            rep = replay(judge, traj, robot=0).summary()
            row.update(actions=[env.describe_action(a) for a in best.actions], env_time=round(best.time, 3),
                       env_wear=round(best.wear, 2), cycle_time=round(float(rep["cycle_time"]), 3),
                       cost=round(float(rep["cost"]), 2), cost_terms=rep["cost_terms"])
        for label, rows in compare.items():
            r = rows.get((name, args.seed))
            if r is not None:
                row[label] = {"success": r["success"], "cost": r["cost"], "cycle_time": r["cycle_time"]}
        done[name] = row
        print(json.dumps({k: row[k] for k in row if k not in ("actions", "cost_terms")}), flush=True)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({"args": vars(args), "tasks": done}, indent=1) + "\n")
    shared = [r for r in done.values() if r["found"] and all(r.get(k, {}).get("success") for k in compare)]
    for label in compare:
        ratio = sum(r["cost"] for r in shared) / max(sum(r[label]["cost"] for r in shared), 1e-12)
        print(f"{len(shared)} tasks every method finished: search ∫C / {label} ∫C = {ratio:.2f}")


if __name__ == "__main__":
    main()
