"""Which code and libraries wrote a result: a hash over the packages' files and the libraries' versions, so no
folder mixes versions."""

from __future__ import annotations

import hashlib
import platform
from functools import cache
from importlib.metadata import PackageNotFoundError, version
from importlib.util import find_spec
from pathlib import Path

from ..errors import ConfigError

FINGERPRINT_DIGITS = 12  # hex digits kept: a chance collision is as likely as one in 2^48


@cache
def code_fingerprint(packages: tuple[str, ...]) -> str:
    """A SHA-256 (its first ``FINGERPRINT_DIGITS`` hex digits) over every file of the named packages, path and
    bytes, compiled caches left out: their sources, configs and shipped models. Any change to them, a comment's
    too, gives another fingerprint. Cached: computed once per process."""
    h = hashlib.sha256()
    for name in packages:
        try:
            spec = find_spec(name)
        except ModuleNotFoundError:  # its parent package is missing
            spec = None
        if spec is None or not spec.submodule_search_locations:
            raise ConfigError("packages", f"{name!r} is no installed package")
        for location in spec.submodule_search_locations:
            root = Path(location)
            for f in sorted(p for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts):
                h.update(f"{name}/{f.relative_to(root).as_posix()}\0".encode())
                h.update(f.read_bytes())
                h.update(b"\0")
    return h.hexdigest()[:FINGERPRINT_DIGITS]


def library_versions(distributions: tuple[str, ...]) -> dict[str, str | None]:
    """Python's version and each named distribution's installed version (None where it is not installed): what a
    result depends on besides the code. The same code, seed and libraries give the same result bit for bit; other
    versions need not (a last-digit difference early in a plan's search can lead it to another route)."""
    out: dict[str, str | None] = {"python": platform.python_version()}
    for name in distributions:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = None
    return out


def file_digest(path: str | Path) -> str:
    """A SHA-256 (its first ``FINGERPRINT_DIGITS`` hex digits) of one file's bytes: a model a result was made with,
    which may live outside the fingerprinted packages."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:FINGERPRINT_DIGITS]
