"""Beyond the thesis (its §5.2): how often the 2-path test and a K random-path test disagree."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...stations.config import StationConfig
from .algorithm import RobustnessSettings
from .grid import RobustnessGrid
from .runner import run_map
from .store import load_results


def sample_indices(grid: RobustnessGrid, n: int, seed: int) -> np.ndarray:
    if not 1 <= n <= len(grid):
        raise ConfigError("sample", f"must be in [1, {len(grid)}], got {n}")
    return np.sort(np.random.default_rng(seed).choice(len(grid), n, replace=False))


def compare_paths(grid: RobustnessGrid, config: StationConfig, out: str | Path, settings: RobustnessSettings,
                  k_paths: int, n_sample: int, seed: int = 0, **run_kwargs) -> dict:
    """Map a random sample of ``grid`` with the thesis's two paths and with K random paths; report agreement.

    Both runs are ordinary (resumable) maps in ``out/two_path`` and ``out/k_path``.
    """
    if k_paths < 1:
        raise ConfigError("k_paths", f"must be at least 1, got {k_paths}")
    out = Path(out)
    idx = sample_indices(grid, n_sample, seed)
    # A sample maps configurations on their own (start "ry"): a row start would compute whole rows.
    two = replace(settings, n_paths=0, start="ry")
    many = replace(settings, n_paths=k_paths, seed=seed, start="ry")
    run_map(grid, config, out / "two_path", two, indices=idx, **run_kwargs)
    run_map(grid, config, out / "k_path", many, indices=idx, **run_kwargs)
    a, b = load_results(out / "two_path"), load_results(out / "k_path")
    common = [i for i in idx if i in a and i in b]
    d2 = np.array([a[i][1] for i in common])
    dk = np.array([b[i][1] for i in common])
    r2, rk = d2 < settings.threshold, dk < settings.threshold
    report = {
        "grid": grid.name, "n_compared": len(common), "k_paths": k_paths, "seed": seed,
        "threshold_m": settings.threshold,
        "agreement": float(np.mean(r2 == rk)) if common else 0.0,
        "both_robust": int(np.sum(r2 & rk)), "both_non_robust": int(np.sum(~r2 & ~rk)),
        "only_k_path_non_robust": int(np.sum(r2 & ~rk)),  # the 2-path test missed these
        "only_two_path_non_robust": int(np.sum(~r2 & rk)),
        "fraction_non_robust_two_path": float(np.mean(~r2)) if common else 0.0,
        "fraction_non_robust_k_path": float(np.mean(~rk)) if common else 0.0,
    }
    (out / "paths_report.json").write_text(json.dumps(report, indent=2))
    if common:
        report["plot"] = _plot(out / "paths_agreement.png", d2, dk, settings.threshold, k_paths)
    return report


def _plot(path: Path, d2: np.ndarray, dk: np.ndarray, threshold: float, k: int) -> str:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 5))
    ax.scatter(1000 * d2, 1000 * dk, s=10, alpha=0.6)
    t = 1000 * threshold
    ax.axvline(t, color="r", lw=1)
    ax.axhline(t, color="r", lw=1)
    hi = 1000 * max(d2.max(), dk.max(), threshold) * 1.05
    ax.plot([0, hi], [0, hi], "k:", lw=0.8)
    ax.set(xlim=(0, hi), ylim=(0, hi), xlabel="max deviation, thesis 2-path test [mm]",
           ylabel=f"max deviation, {k} random paths [mm]", title="2-path vs K-path robustness test")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return str(path)
