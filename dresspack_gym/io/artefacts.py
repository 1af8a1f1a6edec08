"""What the commands read back (plans, label shards, policies, cost models, station plans, maps): a damaged or
foreign file is one ConfigError naming the file and what is wrong with it, never a library's traceback."""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import ConfigError, DresspackError


def describe(exc: BaseException) -> str:
    """A library's exception as one short phrase: its type and the first line of its message."""
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return f"{type(exc).__name__}: {text[:200]}" if text else type(exc).__name__


@contextmanager
def reading(path: str | Path, field: str, what: str, recover: str = "") -> Iterator[None]:
    """Read ``path`` (a ``what``, e.g. "MaskablePPO model (.zip)") in the block: whatever its reader raises on a
    damaged, truncated or foreign file (zip, pickle, torch, numpy or JSON errors alike) becomes one ConfigError of
    ``field`` naming the file, what it should be and ``recover`` (how to go on, e.g. for a resume). Errors the
    product raises on purpose pass unchanged."""
    try:
        yield
    except DresspackError:
        raise
    except Exception as exc:  # every reader fails its own way on a bad file: the message says which file it was
        tail = f"; {recover}" if recover else ""
        raise ConfigError(field, f"{path} is not a readable {what} ({describe(exc)}){tail}") from None


def read_json(path: str | Path, field: str, what: str, keys: tuple[str, ...] = (), recover: str = "") -> dict:
    """A JSON object from ``path`` that has ``keys``, or a ConfigError of ``field`` naming the file."""
    path = Path(path)
    with reading(path, field, what, recover):
        data = json.loads(path.read_text())
    if not isinstance(data, dict):
        raise ConfigError(field, f"{path} is not a {what}: it holds a JSON {type(data).__name__}, not an object")
    missing = [k for k in keys if k not in data]
    if missing:
        raise ConfigError(field, f"{path} is not a {what}: it lacks {missing}" + (f"; {recover}" if recover else ""))
    return data


def read_npz(path: str | Path, field: str, what: str, keys: tuple[str, ...] = (), recover: str = "") -> dict:
    """Every array of the .npz ``path`` (no pickles), which must hold ``keys``, or a ConfigError of ``field``
    naming the file."""
    import numpy as np

    path = Path(path)
    with reading(path, field, what, recover):
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    missing = [k for k in keys if k not in arrays]
    if missing:
        raise ConfigError(field, f"{path} is not a {what}: it lacks {missing}" + (f"; {recover}" if recover else ""))
    return arrays
