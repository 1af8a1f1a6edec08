"""Cable-evaluation speed of this tree against an earlier commit, both in one process, interleaved.

The earlier commit's ``dresspack_gym`` (and ``agents``) are exported with ``git archive`` into a temporary folder and
imported under other names (``dresspack_gym_then``, ``agents_then``), so both versions run side by side in one
process on the same paths, alternating which goes first: machine load shifts both alike. Prints CPU seconds and
the ratio then/now for replays of fixed weld cycles, env steps (accurate joint steps and the goal-conditioned
training setup) and, with --plan, one ompl-wear plan, and checks that both versions give the same results.

Usage, from the repository root: .venv/bin/python scripts/studies/bench_versus_commit.py 039d8f7 [--plan] [--paths 12]
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tarfile
import tempfile
import time
from importlib import import_module
from io import BytesIO
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
NOW, THEN = "dresspack_gym", "dresspack_gym_then"


def export(commit: str, into: Path) -> None:
    """The commit's dresspack_gym and agents under the names THEN and agents_then (imports renamed)."""
    blob = subprocess.run(["git", "archive", commit, "dresspack_gym", "agents"], cwd=ROOT, check=True,
                          capture_output=True).stdout
    with tarfile.open(fileobj=BytesIO(blob)) as tar:
        tar.extractall(into, filter="data")
    (into / "dresspack_gym").rename(into / THEN)
    (into / "agents").rename(into / "agents_then")
    (into / THEN / "configs").symlink_to(ROOT / "configs")  # the package data (shipped YAML) of both versions
    for path in list((into / THEN).rglob("*.py")) + list((into / "agents_then").rglob("*.py")):
        text = re.sub(r"\bdresspack_gym\b", THEN, path.read_text())
        path.write_text(re.sub(r"\bdresspack\.agents\b", "agents_then", text))


def interleaved(runs: dict, work, rounds: int) -> tuple[dict, dict]:
    """CPU seconds of ``work(version, k)`` per version over ``rounds`` x its items, alternating which goes first;
    and each version's results."""
    cpu, out = {v: 0.0 for v in runs}, {v: [] for v in runs}
    order = list(runs)
    for r in range(rounds):
        for k in range(len(next(iter(runs.values())))):
            for v in (order if (r + k) % 2 == 0 else order[::-1]):
                c = time.process_time()
                out[v].append(work(v, k))
                cpu[v] += time.process_time() - c
    return cpu, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("commit")
    parser.add_argument("--paths", type=int, default=12, help="weld cycles replayed (random_paths, seed 0)")
    parser.add_argument("--plan", action="store_true", help="also one ompl-wear plan of sill_front per version")
    args = parser.parse_args()
    report = {"then": args.commit, "now": subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                                                          capture_output=True, text=True).stdout.strip()}
    with tempfile.TemporaryDirectory() as tmp:
        export(args.commit, Path(tmp))
        sys.path.insert(0, tmp)
        versions = {"then": THEN, "now": NOW}

        def mod(version: str, name: str):
            return import_module(f"{versions[version]}.{name}")

        sims = {}
        for v in versions:
            station = mod(v, "stations.station").Station(mod(v, "io.loading").load_station("default"))
            validity = mod(v, "stations.validity").MotionValidity(station, 0, 0.005)
            paths = mod(v, "physics.profiles").random_paths(station, 0, validity, args.paths, seed=0)
            sims[v] = (mod(v, "physics.simulation").CableSimulator(station), paths)

        def replay(v, k):
            sim, paths = sims[v]
            rep = mod(v, "physics.trajectory").replay(sim, paths[k], record_states=True)
            return float(np.trapezoid(rep.cost, rep.time)), rep.cycle_time

        cpu, out = interleaved({v: sims[v][1] for v in versions}, replay, rounds=2)
        motion = sum(t for _, t in out["now"])
        report["replays"] = {"cpu_s": {v: round(c, 2) for v, c in cpu.items()}, "motion_s": round(motion, 2),
                             "then_over_now": round(cpu["then"] / cpu["now"], 3), "same": out["then"] == out["now"]}

        for label, kwargs, steps in (("env_accurate", {"physics_profile": "accurate"}, 40),
                                     ("env_training_setup", None, 15)):
            envs = {}
            for v in versions:
                kw = kwargs or mod(v, "cli.bench")._training_env_kwargs("goal_conditioned")
                envs[v] = mod(v, "env.dresspack_env").DresspackEnv(station="default", **kw)

            def episode(v, k, envs=envs, steps=steps):
                env, rng = envs[v], np.random.default_rng(k)
                env.reset(seed=k)
                rewards = []
                for _ in range(steps):
                    _, reward, terminated, truncated, _ = env.step(int(rng.choice(np.flatnonzero(env.action_masks()))))
                    rewards.append(reward)
                    if terminated or truncated:
                        env.reset(seed=k + 100)
                return rewards

            cpu, out = interleaved({v: range(4) for v in versions}, episode, rounds=1)
            report[label] = {"steps_per_cpu_s": {v: round(4 * steps / c, 2) for v, c in cpu.items()},
                             "then_over_now": round(cpu["then"] / cpu["now"], 3), "same": out["then"] == out["now"]}

        if args.plan:
            planners = {}
            for v, agents in (("then", "agents_then"), ("now", "dresspack.agents")):
                station = mod(v, "stations.station").Station(mod(v, "io.loading").load_station("default"))
                planner = import_module(f"{agents}.planners.registry").PLANNERS["ompl-wear"](station, 0)
                task = mod(v, "stations.tasks").make_task(station, 0, planner.validity.checker.collides,
                                                          ["sill_front"])
                planners[v] = (planner, [task])

            def plan(v, k):
                planner, tasks = planners[v]
                return round(float(planner.plan(tasks[k]).info["objective"]), 9)

            cpu, out = interleaved({v: planners[v][1] for v in versions}, plan, rounds=2)
            report["ompl_wear_sill_front"] = {"cpu_s_per_plan": {v: round(c / 2, 2) for v, c in cpu.items()},
                                              "then_over_now": round(cpu["then"] / cpu["now"], 3),
                                              "same": out["then"] == out["now"]}
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
