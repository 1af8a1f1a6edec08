"""Bounds of any plan over a station's options, on straight-move times: the makespan's (analytic and CP-SAT's
relaxation) and the wear objective's least wear estimate within its cap (each solved once, cached)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .solver import RoutingProblem, lower_bound, relaxation_bound, wear_relaxation_bound


class Bounds:
    """The relaxation bounds of one station, cached by problem (the same for every objective: solved once).
    ``workers`` (a StationWorkers): a bound started early (:meth:`start_makespan`, :meth:`start_wear`) is solved in
    a worker while the rounds run; it depends only on its problem, so it is the bound solved here."""

    def __init__(self, workers=None):
        self.workers = workers
        self._relaxations: dict[bytes, object] = {}  # a bound, or a Pending one

    def start_makespan(self, problem: RoutingProblem, straight: np.ndarray, work: float, seed: int) -> None:
        """:meth:`makespan`'s relaxation started in a worker (nothing without parallel workers)."""
        key = self._makespan_key(problem, straight, work)
        if self.workers is not None and self.workers.parallel and key not in self._relaxations:
            self._relaxations[key] = self.workers.submit("makespan_bound", (replace(problem, travel=straight), work,
                                                                            seed))

    def start_wear(self, problem: RoutingProblem, straight: np.ndarray, cap: float, work: float, seed: int) -> None:
        """:meth:`wear` started in a worker (nothing without parallel workers)."""
        key = self._wear_key(problem, straight, cap, work)
        if self.workers is not None and self.workers.parallel and key not in self._relaxations:
            self._relaxations[key] = self.workers.submit("wear_bound", (replace(problem, travel=straight), cap, work,
                                                                        seed))

    def _get(self, key: bytes) -> dict:
        got = self._relaxations[key]
        if not isinstance(got, dict):
            got = self._relaxations[key] = got.get()
        return got

    @staticmethod
    def _makespan_key(problem: RoutingProblem, straight: np.ndarray, work: float) -> bytes:
        return straight.tobytes() + problem.node_robot.tobytes() + problem.node_weld.tobytes() + \
            np.float64(problem.weld_time).tobytes() + np.float64(work).tobytes()

    @staticmethod
    def _wear_key(problem: RoutingProblem, straight: np.ndarray, cap: float, work: float) -> bytes:
        return (straight.tobytes() + problem.node_robot.tobytes() + problem.node_weld.tobytes()
                + problem.cost_rate.tobytes() + np.array([problem.weld_time, cap, work]).tobytes())

    def makespan(self, problem: RoutingProblem, straight: np.ndarray, solver_bound: float, work: float,
                 seed: int) -> dict:
        """Makespan lower bounds of any plan over these options, all on the straight-move times (not the planned
        legs' times: a planned path is one way, not the fastest): the analytic ones (solver.lower_bound), CP-SAT's
        bound on the routes without conflicts (``relaxation``, solver.relaxation_bound, ``work`` deterministic
        seconds), and the rounds' (``solver``: CP-SAT's bound, from rounds whose every leg time was a straight
        move)."""
        relaxed = replace(problem, travel=straight)
        b = lower_bound(relaxed)
        key = self._makespan_key(problem, straight, work)
        if key not in self._relaxations:
            self._relaxations[key] = relaxation_bound(relaxed, work=work, seed=seed)
        b.update(self._get(key), solver=solver_bound)
        b["bound"] = max(b["bound"], solver_bound, b["relaxation"] or 0.0)
        return b

    def wear(self, problem: RoutingProblem, straight: np.ndarray, cap: float, work: float, seed: int) -> dict:
        """The least wear estimate of any routes over these options within ``cap`` [s], on straight-move times
        (solver.wear_relaxation_bound). An estimate's bound, not the replay's: the estimate charges a move its
        ends' mean settled rate, and on side_framing_4r it reads 0.7 % (wear plan) and 5.4 % (time plan) below
        their replays."""
        key = self._wear_key(problem, straight, cap, work)
        if key not in self._relaxations:
            self._relaxations[key] = wear_relaxation_bound(replace(problem, travel=straight), cap, work=work,
                                                           seed=seed)
        return self._get(key)
