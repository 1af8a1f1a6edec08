"""The one resolver of shipped files (configs, policies) by name, in a checkout and in an installed wheel."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from .errors import ConfigError

# The YAML configs are package data of ``dresspack_gym.configs`` (the repository's configs/ folder).
CONFIGS = "dresspack_gym.configs"


def shipped_root(package: str = CONFIGS) -> Path:
    """The folder of a package's shipped files (a plain folder in a checkout and in a regular install)."""
    return Path(str(resources.files(package)))


def shipped_names(kind: str, package: str = CONFIGS, suffix: str = ".yaml") -> list[str]:
    """Names of the shipped ``kind`` (``stations``, ``robots``, ...): files with ``suffix``, or folders if ''."""
    folder = shipped_root(package) / kind
    if not folder.is_dir():
        return []
    if suffix:
        return sorted(p.name[:-len(suffix)] for p in folder.iterdir() if p.is_file() and p.name.endswith(suffix))
    return sorted(p.name for p in folder.iterdir() if p.is_dir() and not p.name.startswith("__"))

def find_shipped(ref: str | Path, kind: str, field: str, *, package: str = CONFIGS, suffix: str = ".yaml",
                 base_dir: Path | None = None) -> Path:
    """``ref`` as a path (relative to ``base_dir`` if given), else the name of a shipped file (``suffix``) or
    folder (``suffix=''``) in ``<package>/<kind>/``; a ConfigError naming ``field`` lists the shipped names."""
    path = Path(ref) if base_dir is None else Path(base_dir) / ref
    want_dir = not suffix
    if path.is_dir() if want_dir else path.is_file():
        return path
    folder = shipped_root(package) / kind
    for name in (f"{ref}{suffix}", str(ref)):
        candidate = folder / name
        if candidate.is_dir() if want_dir else candidate.is_file():
            return candidate
    what = kind[:-1] if kind.endswith("s") else f"{kind} config"
    where = f"a {'folder' if want_dir else 'file'}" + (f" next to {base_dir}" if base_dir is not None else "")
    raise ConfigError(field, f"{str(ref)!r} is neither {where} nor a shipped {what}; shipped: "
                             f"{shipped_names(kind, package, suffix)}")
