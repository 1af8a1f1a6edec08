"""The rod engine on cosseratbench's experiments beside the benchmark's built-in solvers; a JSON summary of the figures.

    .venv/bin/python scripts/studies/rod_cosseratbench.py --out out/cosseratbench \
        --summary docs/data/rod_cosseratbench.json

Each experiment runs at its own default parameters and resolution (capstan also at each overhang it sweeps, as one
overhang says little about friction); trajectories and result.json files go under --out in cosseratbench's layout
(`cosseratbench view -r <out>` shows them). A solver whose backend is not importable is listed as not installed.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
from importlib.metadata import version
from pathlib import Path

from cosseratbench import registry, run
from cosseratbench.variations import Variant

EXPERIMENTS = ("catenary", "cantilever", "twist", "crossing", "capstan")
SOLVERS = ("dresspack_rod", "mujoco", "pyelastica", "dismech")
SWEEPS = {"capstan": "overhang"}


def variants(experiment) -> list[Variant]:
    out = [Variant()]
    if (name := SWEEPS.get(experiment.name)) is not None:
        p = next(p for p in experiment.parameters if p.name == name)
        out += [Variant(parameters={name: v}) for v in p.values if v != p.default]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--experiments", nargs="+", default=list(EXPERIMENTS))
    parser.add_argument("--solvers", nargs="+", default=list(SOLVERS))
    parser.add_argument("--out", type=Path, default=Path("out/cosseratbench"))
    parser.add_argument("--summary", type=Path, default=Path("docs/data/rod_cosseratbench.json"))
    args = parser.parse_args()

    solvers, installed = {}, {}
    for name in args.solvers:
        try:
            solvers[name] = registry.load_solver(name)
            installed[name] = getattr(solvers[name], "backend_version", None)
        except ImportError as error:
            installed[name] = f"not installed ({error.name})"
    rows = []
    for experiment_name in args.experiments:
        experiment = registry.load_experiment(experiment_name)
        for variant in variants(experiment):
            directory = args.out / experiment.name / variant.key
            experiment.save(directory, variant.parameters, variant.varied)
            for name, solver in solvers.items():
                try:
                    result = run(experiment, solver, values=variant.parameters)
                except Exception as error:  # an adapter that breaks on this backend: recorded, the rest go on
                    rows.append({"experiment": experiment.name, "solver": name, "outcome": "crashed",
                                 "values": experiment.values(**variant.parameters),
                                 "failure": f"{type(error).__name__}: {error}"})
                    print(f"{experiment.name:10s} {variant.key:14s} {name:14s} crashed     {rows[-1]['failure']}")
                    continue
                result.save(directory / name)
                summary = result.summary()
                row = {k: summary[k] for k in ("experiment", "solver", "outcome", "n_elements", "n_frames", "values",
                                               "missing", "failure", "diverged_at", "wall_time", "metrics",
                                               "observations", "settings")}
                if result.outcome == "completed" and getattr(solver, "last_run", None):
                    row["newton"] = dict(solver.last_run)
                rows.append(row)
                shown = {k: f"{v:.3g}" for k, v in summary["metrics"].items() if v is not None}
                wall = f"{result.wall_time:.2f} s" if result.wall_time is not None else ""
                why = str(summary["missing"] or summary["failure"] or "") if result.outcome != "completed" else ""
                print(f"{experiment.name:10s} {variant.key:14s} {name:14s} {result.outcome:11s} {wall:9s} {shown}"
                      f"{' ' + why if why else ''}", flush=True)
    args.summary.parent.mkdir(parents=True, exist_ok=True)
    args.summary.write_text(json.dumps({
        "command": "scripts/studies/rod_cosseratbench.py " + " ".join(
            ["--experiments", *args.experiments, "--solvers", *args.solvers]),
        "cosseratbench": version("cosseratbench"),
        "machine": platform.processor() or platform.machine(),
        "pythonpath": os.environ.get("PYTHONPATH"),  # backends installed beside the venv, if any
        "solvers": installed,
        "runs": rows,
    }, indent=1) + "\n")
    print(f"wrote {args.summary}")


if __name__ == "__main__":
    main()
