"""Runs a robustness map over a grid: backends, a resumable results file, the summary and the query API."""

from __future__ import annotations

import csv
import hashlib
import json
import os
from collections.abc import Iterator
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...fields import check_choice
from ...process_pool import spawn_pool
from ...ray_pool import ray_imap_unordered, require_ray
from ...robots.time_law import TIME_LAW
from ...stations.config import StationConfig
from .algorithm import RobustnessEvaluator, RobustnessSettings
from .grid import RobustnessGrid
from .query import RobustnessMap  # noqa: F401  (re-exported: the map API next to the runner)
from .store import (
    META,
    RESULTS,
    columns_for,
    done_indices,
    grid_to_meta,
    load_jammed,
    load_results,
    load_unconverged,
    map_engine,
    read_header,
    repair_last_line,
)

CHUNK = 16  # configurations per work unit with start "ry" (same Ry: its start state is reused inside a unit)
BACKENDS = ("serial", "process", "ray")


def _fingerprint(grid: RobustnessGrid, station_name: str, settings: RobustnessSettings) -> str:
    h = hashlib.sha256()
    for axis in (grid.ry, grid.j4, grid.j5, grid.j6):
        h.update(np.round(axis, 12).tobytes())
    h.update(station_name.encode())
    fields = asdict(settings)
    if fields["engine"] == "dynamic":  # maps made before the engine was chosen keep their fingerprint
        del fields["engine"]
    h.update(json.dumps(fields, sort_keys=True, default=float).encode())
    h.update(TIME_LAW.encode())  # the moves between configurations are timed by it
    return h.hexdigest()[:16]


def _work_units(grid: RobustnessGrid, todo: list[int], start: str,
                limit: int | None = None) -> list[tuple[list[int], list[int]]]:
    """(indices to compute, indices to report) per work unit, computing at most ``limit`` configurations.

    "row" start: one unit per grid row holding a pending index, computed from the row's start up to its last
    pending index (each configuration continues from the previous one; only the pending ones are reported).
    "ry": pending indices grouped by Ry (the per-Ry start state is reused inside a unit), in chunks of CHUNK.
    A unit cut by ``limit`` keeps its prefix, whose results equal those of the whole unit.
    """
    units: list[tuple[list[int], list[int]]] = []
    if start == "row":
        n = len(grid.j6)
        wanted = set(todo)
        for r in sorted({i // n for i in todo}):
            last = max(i for i in range(r * n, (r + 1) * n) if i in wanted)
            compute = list(range(r * n, last + 1))
            units.append((compute, [i for i in compute if i in wanted]))
    else:
        per_ry = len(grid) // len(grid.ry)
        by_ry: dict[int, list[int]] = {}
        for i in todo:
            by_ry.setdefault(i // per_ry, []).append(i)
        for _, idx in sorted(by_ry.items()):
            units.extend((idx[k:k + CHUNK], idx[k:k + CHUNK]) for k in range(0, len(idx), CHUNK))
    if limit is None:
        return units
    capped, left = [], limit
    for compute, report in units:
        if left <= 0:
            break
        compute = compute[:left]
        keep = set(compute)
        report = [i for i in report if i in keep]
        left -= len(compute)
        if report:
            capped.append((compute, report))
    return capped


_WORKER: RobustnessEvaluator | None = None


def _init_worker(config: StationConfig, settings: RobustnessSettings) -> None:
    global _WORKER
    _WORKER = RobustnessEvaluator(config, settings)


def _run_unit(args) -> list[tuple]:
    indices, configs, report = args
    if _WORKER.settings.start == "row":
        results = _WORKER.evaluate_row(indices, configs)
    else:
        results = [_WORKER.evaluate(i, v) for i, v in zip(indices, configs)]
    keep = set(report)
    return [(i, r) for i, r in zip(indices, results) if i in keep]


def _iterate(backend: str, workers: int, config, settings, units, configs, ray_address) -> Iterator[list]:
    payload = [(u, configs[u], report) for u, report in units]
    if backend == "serial" or (backend == "process" and workers == 1):
        _init_worker(config, settings)
        for p in payload:
            yield _run_unit(p)
    elif backend == "process":
        with spawn_pool(workers, _init_worker, (config, settings)) as pool:
            yield from pool.imap_unordered(_run_unit, payload)
    else:
        yield from ray_imap_unordered(_init_worker, (config, settings), _run_unit, payload, workers, ray_address)


def run_map(grid: RobustnessGrid, config: StationConfig, out: str | Path, settings: RobustnessSettings, *,
            backend: str = "process", workers: int = 2, ray_address: str | None = None,
            progress: bool = True, limit: int | None = None, indices=None) -> dict:
    """Compute (or resume) the map in ``out``; returns the summary. Finished rows are never recomputed.

    Rows are appended and flushed as work units finish, so an interruption loses at most the units in
    flight. ``limit`` stops after that many new configurations (for trying a grid or benchmarking).
    """
    check_choice("backend", backend, BACKENDS)
    if backend == "ray":
        require_ray()
    if workers < 1:
        raise ConfigError("workers", f"must be at least 1, got {workers}")
    wanted = range(len(grid)) if indices is None else sorted({int(i) for i in indices})
    if indices is not None and wanted and not 0 <= wanted[0] <= wanted[-1] < len(grid):
        raise ConfigError("indices", f"configuration indices must be in [0, {len(grid)})")
    if limit is not None and not (isinstance(limit, int) and limit >= 1):
        raise ConfigError("limit", f"must be a positive number of configurations, got {limit!r}")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ConfigError("out", f"{out} is an existing file: give a folder for the map")
    out.mkdir(parents=True, exist_ok=True)
    fp = _fingerprint(grid, config.name, settings)
    meta_path = out / META
    if meta_path.is_file():
        meta = json.loads(meta_path.read_text())
        if map_engine(meta) != settings.engine:
            raise ConfigError("engine", f"{out} holds a map computed on the {map_engine(meta)!r} engine, not on "
                                        f"{settings.engine!r} (--physics {settings.engine}); resume it with "
                                        f"--physics {map_engine(meta)} or use another --out folder")
        contact = meta.get("settings", {}).get("cable_robot_contact", settings.cable_robot_contact)
        if contact != settings.cable_robot_contact:
            flag = "--cable-robot-contact" if contact else "--no-cable-robot-contact"
            raise ConfigError("cable_robot_contact", f"{out} holds a map computed with cable-robot contact "
                                                     f"{'on' if contact else 'off'}, not "
                                                     f"{'on' if settings.cable_robot_contact else 'off'}; resume it "
                                                     f"with {flag} or use another --out folder")
        if meta.get("fingerprint") != fp:
            raise ConfigError("out", f"{out} holds a map of a different grid, station, settings or time law "
                                     f"({meta.get('grid')}, {meta.get('station')}, "
                                     f"{meta.get('time_law', 'the cubic law of version 0')}); "
                                     f"use another --out folder")
    else:
        meta_path.write_text(json.dumps({"fingerprint": fp, "grid": grid.name, "station": config.name,
                                         "time_law": TIME_LAW, "engine": settings.engine,
                                         "n_configs": len(grid), "settings": asdict(settings),
                                         "grid_axes": grid_to_meta(grid)}, indent=2,
                                        default=float))
    configs = grid.configurations()
    results = out / RESULTS
    new_file = not results.is_file() or results.stat().st_size == 0
    if not new_file:
        repair_last_line(results)  # before reading what is done: the rows counted done are the rows kept
    done = done_indices(out)
    todo = [i for i in wanted if i not in done]
    units = _work_units(grid, todo, settings.start, limit)
    n_report = sum(len(report) for _, report in units)
    bar = None
    if progress and n_report:
        from tqdm import tqdm

        bar = tqdm(total=n_report, unit="config", desc=f"robustness {grid.name}", smoothing=0.05)
    if new_file:
        with results.open("w", newline="") as f:
            csv.writer(f).writerow(columns_for(settings.engine))
    header = read_header(results)
    for rows in _iterate(backend, workers, config, settings, units, configs, ray_address):
        # Opened by path for every unit (a unit takes seconds): a results file replaced while the map runs (a git
        # checkout, stash or pull of a committed map) is appended to, not a deleted file held open since the start.
        with results.open("a", newline="") as f:
            writer = csv.writer(f)
            for i, r in rows:
                v = np.degrees(configs[i])
                dev = max(r.dev_neg, r.dev_pos)
                row = dict(zip(header, [i, *np.round(v, 6), f"{r.dev_neg:.6f}", f"{r.dev_pos:.6f}", f"{dev:.6f}",
                                        int(r.converged), f"{r.dynamic_ratio:.3e}", f"{r.speed_fraction:.6g}"]))
                row.update(jammed=int(r.jammed), robust=int(dev < settings.threshold))
                writer.writerow([row[c] for c in header])
            f.flush()
            os.fsync(f.fileno())
        if bar is not None:
            bar.update(len(rows))
    if bar is not None:
        bar.close()
    return {**summarize(out, grid, settings.threshold), "engine": settings.engine,
            "cable_robot_contact": settings.cable_robot_contact}


def summarize(out: str | Path, grid: RobustnessGrid, threshold: float) -> dict:
    rows = load_results(out)
    unconverged = load_unconverged(out)
    n_unconverged = len(unconverged)
    idx = np.array(sorted(set(rows) - unconverged), dtype=int)  # an unconverged configuration is no sample
    dev = np.array([rows[i][1] for i in idx]) if len(idx) else np.zeros(0)
    non_robust = dev >= threshold
    per_ry_axis = len(grid) // len(grid.ry)
    per_ry = {}
    for k, ry in enumerate(grid.ry):
        sel = (idx // per_ry_axis) == k
        if sel.any():
            per_ry[f"{np.degrees(ry):g}"] = {"n": int(sel.sum()), "n_non_robust": int(non_robust[sel].sum()),
                                            "fraction_non_robust": float(non_robust[sel].mean())}
    summary = {"grid": grid.name, "n_configs": len(idx), "n_grid": len(grid),
               "n_non_robust": int(non_robust.sum()),
               "fraction_non_robust": float(non_robust.mean()) if len(idx) else 0.0,
               "threshold_m": threshold, "n_unconverged": n_unconverged, "per_ry": per_ry}
    jammed = load_jammed(out)
    if jammed is not None:  # a map on the fast engine (MuJoCo's maps keep their summary as it was)
        summary.update(engine="fast", n_jammed=len(jammed))
    return summary
