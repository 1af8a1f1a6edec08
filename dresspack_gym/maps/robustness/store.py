"""The on-disk form of a robustness map: ``results.csv`` (one row per configuration) and ``meta.json``."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from .grid import RobustnessGrid

RESULTS = "results.csv"
META = "meta.json"
# "robust" stays last: a row torn by an interruption never has it. "converged": every stored shape was a
# proven equilibrium; an unconverged configuration is an error, never counted as robust.
COLUMNS = ["index", "ry_deg", "j4_deg", "j5_deg", "j6_deg", "dev_neg_m", "dev_pos_m", "max_dev_m",
           "converged", "dynamic_ratio", "speed_fraction", "robust"]
# A map on the fast (rod) engine also says per configuration whether a link jammed against the cable ("jammed", such
# a configuration is also unconverged); a map on MuJoCo keeps the columns above (a jam shows only as no equilibrium).
FAST_COLUMNS = COLUMNS[:-1] + ["jammed", COLUMNS[-1]]


def columns_for(engine: str) -> list[str]:
    """The results.csv columns of a new map on ``engine``."""
    return FAST_COLUMNS if engine == "fast" else COLUMNS


def read_header(path: Path) -> list[str]:
    """The column names of an existing results.csv (its first line)."""
    with Path(path).open(newline="") as f:
        return next(csv.reader(f), [])


def map_engine(meta: dict) -> str:
    """The engine a map was computed on (maps made before engines were chosen: MuJoCo's, "dynamic")."""
    return meta.get("engine", "dynamic")


def grid_to_meta(grid: RobustnessGrid) -> dict:
    """The grid's axes in degrees, so a map folder can be queried without its grid YAML."""
    return {"name": grid.name, **{k: np.round(np.degrees(a), 9).tolist()
                                  for k, a in zip(("ry", "j4", "j5", "j6"), (grid.ry, grid.j4, grid.j5, grid.j6))}}


def grid_from_meta(meta: dict) -> RobustnessGrid:
    g = meta["grid_axes"]
    return RobustnessGrid(g["name"], *(np.radians(np.asarray(g[k], dtype=float)) for k in ("ry", "j4", "j5", "j6")))


def read_meta(out: str | Path, field: str = "robustness_map") -> dict:
    path = Path(out) / META
    if not path.is_file():
        raise ConfigError(field, f"{Path(out)} is not a robustness map folder (no {META}); "
                                 f"create one with `dresspack robustness-map --out {out} ...`")
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ConfigError(field, f"{path} is damaged (not JSON: {exc}); recreate the map folder") from None
    missing = [k for k in ("grid_axes", "settings") if not isinstance(meta, dict) or k not in meta]
    if missing:
        raise ConfigError(field, f"{path} lacks {missing}: not a map written by `dresspack robustness-map`")
    return meta


def done_indices(out: Path) -> set[int]:
    """Indices already in the results file (a partly written last line from an interruption is ignored)."""
    return set(load_results(out)) if (Path(out) / RESULTS).is_file() else set()


def load_results(out: str | Path) -> dict[int, tuple[np.ndarray, float, bool]]:
    """index -> (v [rad], max deviation [m], robust) for every complete row (unconverged = not robust)."""
    return {i: (v, dev, robust and converged) for i, (v, dev, robust, converged) in _rows(out).items()}


def load_jammed(out: str | Path) -> set[int] | None:
    """Indices where a link jammed against the cable; None for a map without the column (MuJoCo's)."""
    path = Path(out) / RESULTS
    if not path.is_file() or "jammed" not in read_header(path):
        return None
    with path.open() as f:
        return {int(r["index"]) for r in csv.DictReader(f) if r.get("robust") in ("0", "1") and r["jammed"] == "1"}


def load_unconverged(out: str | Path) -> set[int]:
    """Indices whose stored shapes did not all reach equilibrium (maps made before v2 have none)."""
    return {i for i, (_, _, _, converged) in _rows(out).items() if not converged}


def _rows(out: str | Path) -> dict[int, tuple[np.ndarray, float, bool, bool]]:
    rows = {}
    if not (Path(out) / RESULTS).is_file():  # a map begun but with no finished row yet
        return rows
    with (Path(out) / RESULTS).open() as f:
        for r in csv.DictReader(f):
            if r.get("robust") not in ("0", "1"):  # a torn last line never has its final column
                continue
            try:
                v = np.radians([float(r[k]) for k in ("ry_deg", "j4_deg", "j5_deg", "j6_deg")])
                rows[int(r["index"])] = (v, float(r["max_dev_m"]), r["robust"] == "1", r.get("converged", "1") == "1")
            except (TypeError, ValueError, KeyError):
                continue
    return rows


def repair_last_line(path: Path) -> None:
    """End the file on a line break after a hard interruption: a last line that holds a whole row (every column,
    "robust" last) only lost its line break and is kept; a torn one is dropped (recomputed on resume)."""
    data = path.read_bytes()
    if not data or data.endswith(b"\n"):
        return
    cut = data.rfind(b"\n") + 1
    fields = data[cut:].decode(errors="replace").split(",")
    header = data[:data.find(b"\n")].decode(errors="replace").split(",") if cut else COLUMNS
    if cut and len(fields) == len(header) and fields[-1].strip() in ("0", "1"):
        path.write_bytes(data + b"\n")
    else:
        path.write_bytes(data[:cut])
