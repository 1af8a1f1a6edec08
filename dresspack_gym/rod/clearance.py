"""The cable's clearance to the station's obstacles from the contact kernels' exact capsule-primitive gaps."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .contact.primitives import bounding_radii
from .contact.segment import lower_bound, segment_gap

# Edges per block whose bounding ball bounds the gaps of all its edges at once.
CLEARANCE_BLOCK = 8


@njit(cache=True)
def nearest_gap(x, r, kind, pos, rot, size, cap):
    """(gap [m], edge, primitive) of the nearest primitive to the cable's edge capsules of radius ``r``; the gap is
    negative by the deepest penetration, (cap, -1, -1) when nothing is nearer than ``cap``. Branch and bound: blocks
    of CLEARANCE_BLOCK edges against each primitive by their bounding balls (a plane: the block's lowest vertex),
    against an upper bound, then the remaining edges' own bounds, and exact gaps in the order of those until no bound
    left can beat the nearest so far."""
    bound = bounding_radii(kind, size)
    n_edges, k = x.shape[0] - 1, kind.shape[0]
    n_blocks = (n_edges + CLEARANCE_BLOCK - 1) // CLEARANCE_BLOCK
    block_lb = np.empty(n_blocks * k)
    # an upper bound of the nearest gap: a block's first vertex to a primitive's centre, which lies in it (a plane:
    # the vertex's height above it)
    upper = cap
    for blk in range(n_blocks):
        lo, hi = blk * CLEARANCE_BLOCK, min(blk * CLEARANCE_BLOCK + CLEARANCE_BLOCK, n_edges)
        c0, c1, c2 = 0.5 * (x[lo, 0] + x[hi, 0]), 0.5 * (x[lo, 1] + x[hi, 1]), 0.5 * (x[lo, 2] + x[hi, 2])
        spread = 0.0
        for v in range(lo, hi + 1):
            spread = max(spread, math.sqrt((x[v, 0] - c0) ** 2 + (x[v, 1] - c1) ** 2 + (x[v, 2] - c2) ** 2))
        for j in range(k):
            if kind[j] == 0:  # a plane: the block's lowest vertex above it
                low = np.inf
                for v in range(lo, hi + 1):
                    low = min(low, (x[v, 0] - pos[j, 0]) * rot[j, 0, 2] + (x[v, 1] - pos[j, 1]) * rot[j, 1, 2]
                              + (x[v, 2] - pos[j, 2]) * rot[j, 2, 2])
                block_lb[blk * k + j] = low - r
                upper = min(upper, (x[lo, 0] - pos[j, 0]) * rot[j, 0, 2] + (x[lo, 1] - pos[j, 1]) * rot[j, 1, 2]
                            + (x[lo, 2] - pos[j, 2]) * rot[j, 2, 2] - r)
            else:
                upper = min(upper, math.sqrt((x[lo, 0] - pos[j, 0]) ** 2 + (x[lo, 1] - pos[j, 1]) ** 2
                                             + (x[lo, 2] - pos[j, 2]) ** 2) - r)
                block_lb[blk * k + j] = math.sqrt((pos[j, 0] - c0) ** 2 + (pos[j, 1] - c1) ** 2
                                                  + (pos[j, 2] - c2) ** 2) - spread - bound[j] - r
    best, best_edge, best_prim = cap, -1, -1
    p = np.empty(3)
    n = np.empty(3)
    h = np.empty((3, 3))
    lb = np.empty(n_edges * k)
    count = 0
    flat = np.empty(n_edges * k, np.int64)
    for blk in range(n_blocks):
        for j in range(k):
            if block_lb[blk * k + j] >= upper:
                continue
            for i in range(blk * CLEARANCE_BLOCK, min(blk * CLEARANCE_BLOCK + CLEARANCE_BLOCK, n_edges)):
                b = lower_bound(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], bound[j])
                if b < upper:
                    lb[count] = b
                    flat[count] = i * k + j
                    count += 1
    order = np.argsort(lb[:count])  # nearest bound first: the exact gaps stop at the first bound beyond the best
    for c in order:
        if lb[c] >= best:
            break
        i, j = flat[c] // k, flat[c] % k
        d, _ = segment_gap(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], p, n, h)
        if d < best:
            best, best_edge, best_prim = d, i, j
    return best, best_edge, best_prim
