"""Option costing: the wear cost rate of each weld option's settled cable (the robot alone in the station, on the
plan's cable engine, cached and saved), and the options the solver chooses from (nearest Home and cheapest)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from dresspack_gym.multi.tasks import StationTask, WeldOption
from dresspack_gym.physics.profiles import make_simulator
from dresspack_gym.physics.wear_cost import cost_function
from dresspack_gym.stations.station import Station

from .config import no_bar


def _rate_key(robot: int, q: np.ndarray) -> tuple:
    return (int(robot), *(float(x) for x in np.round(q, 9)))


class OptionCosts:
    """Settled-cable cost rates by robot and configuration (``cost_variant``'s C on ``engine``, one of
    physics.profiles.ENGINES), with each settle's verdict, and the robot-alone simulators they come from (shared
    with the legs' cable runs). ``workers`` (a StationWorkers) settles the options of :meth:`choose` in processes."""

    def __init__(self, station: Station, cost_variant: str, engine: str = "dynamic", workers=None):
        self.station, self.cost_variant, self.engine, self.workers = station, cost_variant, engine, workers
        self.rates: dict[tuple, float] = {}
        self.unconverged: set[tuple] = set()  # cost settles that ended above the equilibrium residual (flagged)
        self._sims: dict[int, object] = {}

    def choose(self, task: StationTask, costed_options: int, kept_options: int, bar=no_bar) -> list[WeldOption]:
        """Per weld and robot, the options the solver sees: the nearest Home and the cheapest of those costed."""
        jobs = [(w, r, self.costed(task, w, r, costed_options)) for w in task.weld_names for r in task.candidates(w)]
        bar = bar("costing weld options (settled cable)", sum(len(j[2]) for j in jobs))
        parallel = self.workers is not None and self.workers.parallel
        if parallel:
            todo = list({_rate_key(r, o.q): (r, o.q) for _, r, opts in jobs for o in opts
                         if _rate_key(r, o.q) not in self.rates}.items())
            bar.update(sum(len(j[2]) for j in jobs) - len(todo))
            # in the order the loop below would settle them: the saved file reads the same at any number of jobs
            for (key, _), (rate, converged) in zip(todo, self.workers.map("settle", [x for _, x in todo], bar)):
                self.rates[key] = rate
                if not converged:
                    self.unconverged.add(key)
        kept = []
        for w, r, opts in jobs:
            rates = []
            for o in opts:
                rates.append(self.rate(r, o.q))
                if not parallel:
                    bar.update(1)
            near = list(range(min(len(opts), (kept_options + 1) // 2)))
            cheap = [int(i) for i in np.argsort(rates, kind="stable") if int(i) not in near]
            for i in sorted(near + cheap[:kept_options - len(near)]):
                kept.append(opts[i])
        bar.close()
        return kept

    @staticmethod
    def costed(task: StationTask, weld: str, robot: int, costed_options: int) -> list[WeldOption]:
        """The options of ``weld`` by ``robot`` whose settled cable is costed: the first ``costed_options``
        (nearest Home first)."""
        return [o for o in task.options[weld] if o.robot == robot][:costed_options]

    def rate(self, robot: int, q: np.ndarray) -> float:
        """The wear cost rate C of robot ``robot``'s cable settled at ``q`` (the robot alone in the station)."""
        key = _rate_key(robot, q)
        if key not in self.rates:
            sim = self.alone(robot)
            sim.reset(np.asarray(q)[None])
            if not sim.last_settle.converged:
                self.unconverged.add(key)
            self.rates[key] = cost_function(self.cost_variant)(sim.measures(), self.station.config.wear_cost).total
        return self.rates[key]

    def converged(self, robot: int, q: np.ndarray) -> bool:
        """Whether the settle behind :meth:`rate` of ``q`` reached the equilibrium residual."""
        return _rate_key(robot, q) not in self.unconverged

    def alone(self, robot: int):
        """A simulator (on ``engine``) of the station with robot ``robot`` alone (the other robots and their
        cables removed)."""
        sim = self._sims.get(robot)
        if sim is None:
            cfg = self.station.config
            alone = replace(cfg, robots=(cfg.robots[robot],), weld_points=())
            sim = self._sims[robot] = make_simulator(Station(alone), self.engine)
        return sim

    def load(self, path: Path) -> None:
        """Costs saved by :meth:`save` with this engine and cost variant (a file of others, or one that does not
        name them, is left to be overwritten: its rates measure something else)."""
        if not path.is_file():
            return
        data = json.loads(path.read_text())
        if not isinstance(data, dict) or (data.get("engine"), data.get("cost_variant")) != (self.engine,
                                                                                            self.cost_variant):
            return
        for row in data["rates"]:
            key = tuple(row["key"])
            self.rates[key] = row["rate"]
            if not row["converged"]:
                self.unconverged.add(key)

    def save(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"engine": self.engine, "cost_variant": self.cost_variant,
                                    "rates": [{"key": list(k), "rate": v, "converged": k not in self.unconverged}
                                              for k, v in self.rates.items()]}))

    def unconverged_options(self, options: list[WeldOption]) -> list[str]:
        """The welds among ``options`` whose option's cost comes from a settle that did not reach equilibrium."""
        return sorted({o.weld for o in options if _rate_key(o.robot, o.q) in self.unconverged})

    def cheapest_weld_wear(self, task: StationTask, costed_options: int) -> float:
        """Σ over the welds of weld time x the lowest settled cost rate among its costed options: what the welding
        alone would wear with every weld at its cheapest option (a reference for a plan's welding wear)."""
        return float(sum(task.weld_time * min(self.rate(r, o.q) for r in task.candidates(w)
                                              for o in self.costed(task, w, r, costed_options))
                         for w in task.weld_names))
