"""The cable's clearance to the station's obstacles from the contact kernels' exact capsule-primitive gaps."""

from __future__ import annotations

import numpy as np
from numba import njit

from .contact.primitives import bounding_radii
from .contact.segment import lower_bound, segment_gap


@njit(cache=True)
def nearest_gap(x, r, kind, pos, rot, size, cap):
    """(gap [m], edge, primitive) of the nearest primitive to the cable's edge capsules of radius ``r``; the gap is
    negative by the deepest penetration, (cap, -1, -1) when nothing is nearer than ``cap``. The pairs are taken in
    the order of their gap's lower bound, so the exact gaps stop once no pair left can beat the nearest so far."""
    bound = bounding_radii(kind, size)
    n_edges, k = x.shape[0] - 1, kind.shape[0]
    lb = np.empty(n_edges * k)
    for i in range(n_edges):
        for j in range(k):
            lb[i * k + j] = lower_bound(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], bound[j])
    best, best_edge, best_prim = cap, -1, -1
    p = np.empty(3)
    n = np.empty(3)
    h = np.empty((3, 3))
    for flat in np.argsort(lb):  # nearest bound first: the exact gaps stop at the first bound beyond the best
        if lb[flat] >= best:
            break
        i, j = flat // k, flat % k
        d, _ = segment_gap(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], p, n, h)
        if d < best:
            best, best_edge, best_prim = d, i, j
    return best, best_edge, best_prim
