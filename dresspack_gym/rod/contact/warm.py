"""Compile (or load from numba's disk cache) every contact kernel once, one process at a time."""

from __future__ import annotations

import os
import tempfile

import numpy as np

try:
    import fcntl
except ImportError:  # not POSIX: no lock, every process compiles for itself
    fcntl = None

LOCK = os.path.join(tempfile.gettempdir(), "dresspack_gym_rod_contact.lock")


def _call_all():
    from .barrier import barrier_accumulate, barrier_energy
    from .ccd import KEEP, MAX_ITER, max_step
    from .friction import friction_accumulate, friction_energy, friction_lag
    from .motion import pose_displacements
    from .primitives import bounding_radii
    from .report import CAP, contact_report

    kind = np.arange(5, dtype=np.int64)
    pos = np.zeros((5, 3))
    pos[:, 0] = np.arange(5) * 2.0
    rot = np.repeat(np.eye(3)[None], 5, axis=0)
    size = np.full((5, 3), 0.2)
    x = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]])
    mask = np.ones((1, 5), dtype=bool)
    g = np.zeros_like(x)
    band = np.zeros((6, 6))
    barrier_accumulate(x, 0.01, kind, pos, rot, size, mask, 0.1, 1.0, g, band, True)
    barrier_energy(x, 0.01, kind, pos, rot, size, mask, 0.1, 1.0)
    max_step(x, g, 0.01, kind, pos, rot, size, mask, KEEP, MAX_ITER)
    lagged = friction_lag(x, 0.01, kind, pos, rot, size, pos, rot, mask, 0.1, 1.0)
    friction_accumulate(x, *lagged, 0.5, 1e-4, g, band)
    friction_energy(x, *lagged, 0.5, 1e-4)
    contact_report(x, x, 0.01, kind, pos, rot, size, pos, rot, mask, 0.1, 1.0, 0.5, 1e-4, CAP)
    pose_displacements(pos, rot, pos, rot, bounding_radii(kind, size))


def compile_kernels():
    """Call every kernel on a tiny scene so that later calls run compiled code; processes started together (test
    workers, a pool) take turns, so the first compiles and fills the disk cache and the others load from it."""
    if fcntl is None:
        _call_all()
        return
    with open(LOCK, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            _call_all()
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
