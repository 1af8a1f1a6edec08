"""Every move of a station's robots planned up front, in worker processes, resumable from a cache file.

The station planner plans legs lazily: the solver times unplanned moves by an estimate and only the moves its
answers choose are planned. Planning every robot's moves between its Home and its options instead gives the real
time of every move (``LegBook.plan_every_move``), and so a bound of the plans over the planner's own legs
(``scripts/studies/station_leg_bound.py``). A leg depends only on its ends, the station, the leg planner and its seed
(the planners re-seed per plan), so which worker plans it, and in which order, changes nothing."""

from __future__ import annotations

import hashlib
import json
import pickle
from pathlib import Path

import numpy as np

from dresspack_gym.fields import check_integer
from dresspack_gym.process_pool import spawn_pool
from dresspack_gym.stations.tasks import Task

from ..planners.base import PlanningError

CHUNK = 16  # moves per work unit sent to a worker (and per append to the cache file)

_PLANNERS: list = []  # a worker's leg planner per robot (built once per process by _init_worker)


def plan_leg(planner, robot: int, qa: np.ndarray, qb: np.ndarray) -> np.ndarray | None:
    """``planner``'s collision-free path (waypoints) for robot ``robot`` from ``qa`` to ``qb``; None if it finds
    none within its iterations."""
    try:
        return planner.plan(Task(robot, qa, (), np.zeros((0, 6)), qb)).trajectory.waypoints
    except PlanningError:
        return None


def own_moves(node_robot: np.ndarray, node_weld: np.ndarray) -> list[tuple[int, int, int]]:
    """Every (robot, i, j), i < j, of a robot's own nodes (its Home and options) whose ends are not two options of
    one weld: one direction of each move (the reverse leg is the same path backwards, of the same time)."""
    return [(int(node_robot[i]), i, j) for i in range(len(node_robot)) for j in range(i + 1, len(node_robot))
            if node_robot[i] == node_robot[j] and not (node_weld[i] >= 0 and node_weld[i] == node_weld[j])]


def fingerprint(station_config, leg_planner: type, iterations: int, seed: int) -> str:
    """What a leg depends on besides its ends, as a short hash: a cache written for other settings is ignored."""
    what = pickle.dumps((station_config, leg_planner.__module__, leg_planner.__qualname__, int(iterations), int(seed)))
    return hashlib.sha256(what).hexdigest()[:16]


def plan_moves(station_config, leg_planner: type, iterations: int, seed: int,
               moves: list[tuple[int, np.ndarray, np.ndarray]], *, workers: int = 1, cache: Path | None = None,
               progress=None) -> list[np.ndarray | None]:
    """The legs of ``moves`` (robot, start, end), in order, planned by ``leg_planner(station, robot, iterations=,
    seed=)`` in ``workers`` processes. With ``cache`` (a JSON-lines file), legs planned before with the same
    settings are read from it (a file written with other settings is started afresh) and every finished work
    unit is appended to it, so an interrupted run loses at most the units in flight."""
    check_integer(workers, "workers", lo=1, hi=256)
    key = fingerprint(station_config, leg_planner, iterations, seed)
    done = _read_cache(cache, key) if cache is not None else {}
    out: list = [done.get(move_key(*m), False) for m in moves]
    todo = [k for k, leg in enumerate(out) if leg is False]
    if progress is not None:
        progress.update(len(moves) - len(todo))
    units = [[(k, *moves[k]) for k in todo[s:s + CHUNK]] for s in range(0, len(todo), CHUNK)]
    writer = None
    if cache is not None and units:
        cache.parent.mkdir(parents=True, exist_ok=True)
        fresh = not cache.is_file() or not done
        torn = not fresh and not cache.read_bytes().endswith(b"\n")  # an interrupted write's partial line
        writer = cache.open("w" if fresh else "a")
        if fresh:
            writer.write(json.dumps({"fingerprint": key}) + "\n")
        elif torn:
            writer.write("\n")
    try:
        for result in _run(units, workers, (station_config, leg_planner, iterations, seed)):
            for k, leg in result:
                out[k] = leg
                if writer is not None:
                    r, qa, qb = moves[k]
                    writer.write(json.dumps({"robot": int(r), "from": np.asarray(qa, float).tolist(),
                                             "to": np.asarray(qb, float).tolist(),
                                             "leg": None if leg is None else np.asarray(leg).tolist()}) + "\n")
            if writer is not None:
                writer.flush()
            if progress is not None:
                progress.update(len(result))
    finally:
        if writer is not None:
            writer.close()
    return out


def _run(units, workers: int, settings):
    if not units:  # everything was in the cache: no planners to build
        return
    if workers == 1 or len(units) <= 1:
        _init_worker(*settings)
        yield from map(_plan_unit, units)
        return
    with spawn_pool(workers, _init_worker, settings) as pool:
        yield from pool.imap_unordered(_plan_unit, units)


def _init_worker(station_config, leg_planner: type, iterations: int, seed: int) -> None:
    from dresspack_gym.stations.station import Station

    station = Station(station_config)
    _PLANNERS[:] = [leg_planner(station, r, iterations=iterations, seed=seed) for r in range(station.n_robots)]


def _plan_unit(unit) -> list[tuple[int, np.ndarray | None]]:
    return [(k, plan_leg(_PLANNERS[r], r, qa, qb)) for k, r, qa, qb in unit]


def move_key(robot: int, qa: np.ndarray, qb: np.ndarray) -> tuple:
    """A move as a dictionary key: its robot and the exact bytes of its two configurations."""
    return int(robot), np.asarray(qa, dtype=float).tobytes(), np.asarray(qb, dtype=float).tobytes()


def _read_cache(path: Path, key: str) -> dict:
    """The legs a cache file holds, if it was written with the settings ``key``; a torn last line (an interrupted
    write) is skipped."""
    if not path.is_file():
        return {}
    legs = {}
    with path.open() as f:
        lines = f.read().splitlines()
    try:
        if not lines or json.loads(lines[0]).get("fingerprint") != key:
            return {}
    except json.JSONDecodeError:
        return {}
    for line in lines[1:]:
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        leg = None if row["leg"] is None else np.array(row["leg"], dtype=float)
        legs[move_key(row["robot"], np.array(row["from"]), np.array(row["to"]))] = leg
    return legs
