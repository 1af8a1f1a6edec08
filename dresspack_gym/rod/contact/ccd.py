"""Continuous collision step bound: the largest fraction of a Newton step that keeps every gap clear of zero."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .primitives import PLANE, bounding_radii
from .segment import lower_bound, segment_gap

CONVERGED = 0.05  # a pair's advancement stops once its gap is within 5 % above its floor
KEEP = 0.1  # the fraction of each gap that a step keeps
MAX_ITER = 64  # advancements per pair


@njit(cache=True)
def _speed(dx, i):
    """Lipschitz constant of the edge's gap in the step fraction: no point of the edge moves faster than its ends."""
    va = math.sqrt(dx[i, 0] ** 2 + dx[i, 1] ** 2 + dx[i, 2] ** 2)
    vb = math.sqrt(dx[i + 1, 0] ** 2 + dx[i + 1, 1] ** 2 + dx[i + 1, 2] ** 2)
    return max(va, vb)


@njit(cache=True)
def _plane_step(a, b, va, vb, r, pos, rot, keep, alpha):
    """Exact for a plane: each end's height is linear in the step fraction and the gap is the lower end's."""
    nz0, nz1, nz2 = rot[0, 2], rot[1, 2], rot[2, 2]
    da = (a[0] - pos[0]) * nz0 + (a[1] - pos[1]) * nz1 + (a[2] - pos[2]) * nz2 - r
    db = (b[0] - pos[0]) * nz0 + (b[1] - pos[1]) * nz1 + (b[2] - pos[2]) * nz2 - r
    g0 = min(da, db)
    if g0 <= 0.0:
        return 0.0
    floor = keep * g0
    sa = va[0] * nz0 + va[1] * nz1 + va[2] * nz2
    sb = vb[0] * nz0 + vb[1] * nz1 + vb[2] * nz2
    if sa < 0.0:
        alpha = min(alpha, (da - floor) / -sa)
    if sb < 0.0:
        alpha = min(alpha, (db - floor) / -sb)
    return alpha


@njit(cache=True)
def max_step(x, dx, r, kind, pos, rot, size, mask, keep, max_iter):
    """Largest alpha in [0, 1] such that along x + s dx, 0 <= s <= alpha, no enabled pair's gap falls below keep
    times its value at s = 0 (so never reaches 0): conservative advancement with the Lipschitz bound above.
    keep in (0, 1), e.g. KEEP; max_iter e.g. MAX_ITER (every argument is passed: numba compiles apart per omission).

    Per pair at most max_iter advancements; a pair whose gap shrinks only slowly (grazing motion) and has not
    settled by then limits alpha to the fraction reached, which is proven safe, so the bound only costs step length.
    Planes are exact (no iteration). Returns 0 if some gap is <= 0 already at x (an infeasible start).
    """
    bound = bounding_radii(kind, size)
    p = np.empty(3)
    n = np.empty(3)
    h = np.empty((3, 3))
    a = np.empty(3)
    b = np.empty(3)
    alpha = 1.0
    for i in range(x.shape[0] - 1):
        speed = _speed(dx, i)
        if speed == 0.0:
            continue
        for j in range(kind.shape[0]):
            if not mask[i, j]:
                continue
            lb = lower_bound(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], bound[j])
            if lb > 0.0 and speed * alpha <= (1.0 - keep) * lb:  # then gap(s) >= g0 - (1 - keep) g0
                continue
            if kind[j] == PLANE:
                alpha = _plane_step(x[i], x[i + 1], dx[i], dx[i + 1], r, pos[j], rot[j], keep, alpha)
                if alpha == 0.0:
                    return 0.0
                continue
            g0, _ = segment_gap(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], p, n, h)
            if g0 <= 0.0:
                return 0.0
            floor = keep * g0
            s = 0.0
            gap = g0
            for it in range(max_iter):
                s += (gap - floor) / speed  # the gap cannot lose more than speed * (step) meanwhile
                if s >= alpha:
                    break
                for k in range(3):
                    a[k] = x[i, k] + s * dx[i, k]
                    b[k] = x[i + 1, k] + s * dx[i + 1, k]
                gap, _ = segment_gap(a, b, r, kind[j], pos[j], rot[j], size[j], p, n, h)
                if gap - floor <= CONVERGED * floor or it == max_iter - 1:
                    alpha = s
                    break
    return alpha
