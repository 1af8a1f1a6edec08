"""Aggregate evaluation rows: success rate over all runs, metrics as mean ± std over the successful ones."""

from __future__ import annotations

import csv
import io
import math

import numpy as np

from .runs import METRICS

JSON_KEYS = ("success_rate", "cycle_time", "max_curvature", "max_tension", "min_clearance", "cost", "damage",
             "reversals_per_s", "peak_joint_acceleration",
             "life_cycles", "planning_time", "inference_time")
OPTIONAL = ("inference_time",)  # only a learned planner's rows carry it: the network's share of planning_time
CSV_FIELDS = ("method", "task", "seed", "success", *METRICS, "weakest_segment_m", "unconverged_stops", *OPTIONAL,
              "cost_curvature",
              "cost_tension",
              "cost_distance", "waypoints", "start_deg", "error")


def aggregate(rows: list[dict]) -> dict:
    """``{"n_runs", "n_success", "success_rate", metric: {"mean", "std", "n"} | None}`` for a group of rows."""
    ok = [r for r in rows if r["success"]]
    out = {"n_runs": len(rows), "n_success": len(ok), "success_rate": len(ok) / len(rows) if rows else 0.0}
    for m in (*METRICS, *OPTIONAL):
        values = np.array([r[m] for r in ok if r.get(m) is not None], dtype=float)  # rows older than a metric lack it
        out[m] = ({"mean": float(values.mean()), "std": float(values.std()), "n": len(values)} if len(values)
                  else None)
    return out


def by_method(rows: list[dict], methods) -> dict[str, dict]:
    return {m: aggregate([r for r in rows if r["method"] == m]) for m in methods}


def by_task(rows: list[dict], methods) -> dict[str, dict[str, dict]]:
    tasks = list(dict.fromkeys(r["task"] for r in rows))
    return {t: by_method([r for r in rows if r["task"] == t], methods) for t in tasks}


def json_summary(rows: list[dict], methods) -> dict[str, dict]:
    """Per method: success_rate and the mean of each headline metric over its successful runs (None if none)."""
    agg = by_method(rows, methods)
    return {m: {k: (a[k] if k == "success_rate" else (a[k]["mean"] if a[k] else None)) for k in JSON_KEYS}
            | {"n_runs": a["n_runs"], "n_success": a["n_success"]} for m, a in agg.items()}


def fmt(stat: dict | None, digits: int = 3) -> str:
    """``mean ± std`` with ``digits`` significant digits; the mean alone for one run (its spread is unknown, not
    0); "failed" when no run succeeded."""
    if stat is None:
        return "failed"
    if stat.get("n") == 1:
        return significant(stat["mean"], digits)
    std = stat["std"] if stat["std"] > 1e-9 * abs(stat["mean"]) else 0.0  # round-off of equal values: no spread
    return f"{significant(stat['mean'], digits)} ± {significant(std, 2)}"


def significant(x: float, digits: int) -> str:
    """``x`` to ``digits`` significant digits (numbers of more integer digits keep them all)."""
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    if abs(x) < 1e-3:
        return f"{x:.{digits - 1}e}"
    return f"{x:.{max(0, digits - 1 - int(math.floor(math.log10(abs(x)))))}f}" if abs(x) < 10 ** digits else f"{x:.0f}"


def rows_to_csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=CSV_FIELDS, extrasaction="ignore")
    w.writeheader()
    for r in rows:
        terms = r.get("cost_terms") or {}
        w.writerow({**r, "cost_curvature": terms.get("curvature"), "cost_tension": terms.get("tension"),
                    "cost_distance": terms.get("distance"), "start_deg": " ".join(map(str, r.get("start_deg", [])))})
    return buf.getvalue()
