"""What the commands write: every output path checked before any work, every file written whole or not at all."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import ConfigError

FIGURE_SUFFIXES = (".png", ".pdf", ".svg")  # what matplotlib's savefig writes (chosen by the suffix)
PICTURE_SUFFIXES = (".png",)  # the renderer's pictures (plt.imsave)


def nearest_existing(path: Path) -> Path:
    """The folder a missing ``path`` would be made in: its nearest ancestor that exists."""
    for parent in path.absolute().parents:
        if parent.exists():
            return parent
    return Path(path.anchor or "/")


def output_problem(path: Path, *, folder: bool = False, suffixes: Iterable[str] | None = None) -> str | None:
    """Why ``path`` cannot be written as a file (``folder``: made as a folder), or None: an existing thing of the
    other kind, a file where a folder must be made, a suffix the writer does not write, or a folder on the way that
    refuses new files (read-only or virtual file systems, permissions)."""
    if folder and path.exists() and not path.is_dir():
        return "is an existing file: give a folder path"
    if not folder and path.is_dir():
        return "is an existing folder: give a file path"
    suffixes = tuple(suffixes or ())
    if suffixes and path.suffix.lower() not in suffixes:
        return f"the file type is chosen by the suffix, one of {list(suffixes)} (got {path.suffix or 'none'!r})"
    base = path if folder and path.is_dir() else nearest_existing(path)
    if not base.is_dir():
        return f"{str(base)!r} is a file, not a folder"
    return _not_writable(base)


def _not_writable(folder: Path) -> str | None:
    """Why no file can be made in ``folder`` (a probe file made and removed at once), or None. A probe, not
    os.access: root passes every permission check, and virtual file systems (/proc, /sys) refuse only the attempt."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".dresspack-probe-", dir=folder)
    except OSError as exc:
        return f"{str(folder)!r} does not take new files ({exc.strerror or exc})"
    os.close(fd)
    os.unlink(probe)
    return None


def same_file(a: Path, b: Path) -> bool:
    """``a`` and ``b`` name one file (links and relative spellings seen through); False if either is missing."""
    try:
        return a.resolve() == b.resolve() or os.path.samefile(a, b)
    except OSError:
        return False


def check_not_an_input(outputs: Iterable[tuple[str, Path]], inputs: Iterable[tuple[str, Path]]) -> None:
    """Refuse an output that is one of the inputs (the command would overwrite or write into what it reads) or
    that another output names too; ``outputs`` and ``inputs`` are (flag, path) pairs."""
    inputs = list(inputs)
    seen: list[tuple[str, Path]] = []
    for flag, out in outputs:
        for name, path in inputs:
            if same_file(out, path):
                raise ConfigError(flag, f"{out} is the input {name}: writing it would destroy what the command "
                                        "reads; give another path")
        for other, path in seen:
            if out.absolute() == path.absolute() or same_file(out, path):
                raise ConfigError(flag, f"{out} is also {other}: give each output its own path")
        seen.append((flag, out))


def _make_folders(folder: Path) -> list[Path]:
    """Make ``folder`` and its missing parents; the ones made, outermost first."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()][::-1]
    folder.mkdir(parents=True, exist_ok=True)
    return missing


def _remove_empty(folders: list[Path]) -> None:
    for f in reversed(folders):
        try:
            f.rmdir()
        except OSError:
            break  # not empty: something else lives there now


@contextmanager
def replacing(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` (the same suffix: writers that choose the format by it still do) for the
    caller to write; on success it replaces ``path`` in one rename, on any failure or interrupt it is removed with
    the folders made for it, so ``path`` is the old file or the whole new one, never half of one."""
    path = Path(path)
    made = _make_folders(path.parent)
    tmp = path.with_name(f".{path.stem}.part-{os.getpid()}-{os.urandom(3).hex()}{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        _remove_empty(made)
        raise


def write_text(path: str | Path, text: str) -> Path:
    """``text`` into ``path`` atomically (:func:`replacing`)."""
    with replacing(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    """``data`` into ``path`` atomically (:func:`replacing`)."""
    with replacing(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


@contextmanager
def output_folder(path: str | Path, *, keep_on_interrupt: bool = True) -> Iterator[Path]:
    """``path`` as a folder to write in: made if missing, and if this call made it, removed again when the command
    is refused (a DresspackError) or fails, and on an interrupt unless ``keep_on_interrupt`` (a resumable command's
    partial results are what it resumes from) or it is still empty."""
    path = Path(path)
    made = _make_folders(path)
    try:
        yield path
    except KeyboardInterrupt:
        if made and (not keep_on_interrupt or not any(path.iterdir())):
            shutil.rmtree(made[0], ignore_errors=True)
        raise
    except Exception:  # a refusal (DresspackError) or a failure: a folder the command made goes with it
        if made:
            shutil.rmtree(made[0], ignore_errors=True)
        raise
