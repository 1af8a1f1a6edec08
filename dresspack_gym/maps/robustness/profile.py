"""Where a robustness map's time goes on the rod engine: ``python -m dresspack_gym.maps.robustness.profile``."""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter

from ...io.loading import load_station, read_yaml
from ...shipped import find_shipped
from .algorithm import RobustnessEvaluator, RobustnessSettings
from .grid import RobustnessGrid


def profile_rows(grid_name: str, station: str, rows: list[int]) -> dict:
    """Map whole grid rows in this process on the fast engine (the map's defaults) and count, through wrappers of
    the engine's entry points: samples (0.05 s motion steps, the time in them including everything below but the
    rest solves), their compiled solves and Newton iterations, the sub-step solves of samples whose start was not
    outside every link, the misses (solves that ended short of their tolerance), the rest solves, and the wall time
    in each; attempts redone slower count too."""
    from ...rod import rod as rod_module
    from ...rod import simulator as sim_module

    grid = RobustnessGrid.from_dict(read_yaml(find_shipped(grid_name, "grids", "grid"), "grid"))
    evaluator = RobustnessEvaluator(load_station(station), RobustnessSettings())
    seconds, counts = Counter(), Counter()
    originals = (sim_module.carried_step, rod_module.Rod.step, sim_module.RodSimulator.settle,
                 sim_module.RodSimulator._advance)

    def advance(self, *args):
        t = time.perf_counter()
        originals[3](self, *args)
        seconds["samples"] += time.perf_counter() - t
        counts["samples"] += 1

    def carried(*args):
        t = time.perf_counter()
        out = originals[0](*args)
        seconds["compiled steps"] += time.perf_counter() - t
        counts["compiled steps"] += bool(out[0])
        counts["compiled step iterations"] += int(out[3])
        counts["compiled step misses"] += bool(out[0]) and not out[5]
        return out

    def step(self, *args, **kwargs):
        t = time.perf_counter()
        out = originals[1](self, *args, **kwargs)
        seconds["sub-step solves"] += time.perf_counter() - t
        counts["sub-step solves"] += 1
        counts["sub-step misses"] += not out.converged
        return out

    def settle(self):
        t = time.perf_counter()
        out = originals[2](self)
        seconds["rest solves"] += time.perf_counter() - t
        counts["rest solves"] += 1
        counts["rest misses"] += not out.converged
        return out

    (sim_module.carried_step, rod_module.Rod.step, sim_module.RodSimulator.settle,
     sim_module.RodSimulator._advance) = carried, step, settle, advance
    try:
        configs = grid.configurations()
        n = len(grid.j6)
        t0 = time.perf_counter()
        results = []
        for r in rows:
            idx = list(range(r * n, (r + 1) * n))
            results += evaluator.evaluate_row(idx, configs[idx])
        wall = time.perf_counter() - t0
    finally:
        (sim_module.carried_step, rod_module.Rod.step, sim_module.RodSimulator.settle,
         sim_module.RodSimulator._advance) = originals
    sim = evaluator.sim
    return {"grid": grid.name, "rows": rows, "configurations": len(results), "wall_s": round(wall, 1),
            "configurations_per_s": round(len(results) / wall, 4),
            **dict(counts),
            "seconds": {k: round(v, 1) for k, v in seconds.items()},
            "jammed_samples_all_attempts": sim.jammed_samples, "speed_fractions": dict(Counter(
                r.speed_fraction for r in results)),
            "unconverged": sum(not r.converged for r in results), "jammed": sum(r.jammed for r in results)}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--grid", default="thesis_24336")
    p.add_argument("--station", default="default")
    p.add_argument("--rows", type=int, nargs="+", default=[0, 79])
    a = p.parse_args(argv)
    print(json.dumps(profile_rows(a.grid, a.station, a.rows), indent=2))


if __name__ == "__main__":
    main()
