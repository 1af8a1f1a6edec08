"""Which edge-primitive pairs may touch: all, less the cable stretches held on a primitive's own link."""

from __future__ import annotations

import numpy as np


def pair_mask(n_edges, n_prims, excluded=()):
    """Bool (n_edges, n_prims) mask, True where edge i may touch primitive j.

    excluded: rows (first_edge, stop_edge, prim), the edges first_edge..stop_edge-1 never touch prim (a clamp's edges
    and the link that carries it); prim = -1 excludes every primitive.
    """
    mask = np.ones((n_edges, n_prims), dtype=bool)
    for first, stop, prim in excluded:
        if prim < 0:
            mask[first:stop, :] = False
        else:
            mask[first:stop, prim] = False
    return mask
