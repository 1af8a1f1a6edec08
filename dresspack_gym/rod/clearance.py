"""The cable's clearance to the station's obstacles from the contact kernels' exact capsule-primitive gaps."""

from __future__ import annotations

import numpy as np
from numba import njit

from .contact.primitives import bounding_radii
from .contact.segment import lower_bound, segment_gap


@njit(cache=True)
def nearest_gap(x, r, kind, pos, rot, size, cap):
    """(gap [m], edge, primitive) of the nearest primitive to the cable's edge capsules of radius ``r``; the gap is
    negative by the deepest penetration, (cap, -1, -1) when nothing is nearer than ``cap``. Bounding balls prune the
    pairs that cannot beat the nearest so far."""
    bound = bounding_radii(kind, size)
    best, best_edge, best_prim = cap, -1, -1
    p = np.empty(3)
    n = np.empty(3)
    h = np.empty((3, 3))
    for j in range(kind.shape[0]):
        for i in range(x.shape[0] - 1):
            if lower_bound(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], bound[j]) >= best:
                continue
            d, _ = segment_gap(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], p, n, h)
            if d < best:
                best, best_edge, best_prim = d, i, j
    return best, best_edge, best_prim
