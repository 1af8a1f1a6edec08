"""Contact forces per vertex and clearances per edge, for the cable's measures and damage model."""

from __future__ import annotations

import numpy as np
from numba import njit

from .barrier import barrier_d1
from .friction import friction_force, friction_relag
from .primitives import bounding_radii
from .segment import MAX_CONTACTS, lower_bound, pair_contacts

CAP = 10.0  # [m] beyond which clearances are not resolved


@njit(cache=True)
def contact_report(x, x_prev, r, kind, pos, rot, size, pos_prev, rot_prev, mask, dhat, kappa, mu, eps, cap=CAP):
    """Per vertex the normal and friction force magnitudes [N], per edge the smallest gap [m] and nearest primitive.

    The normal force of a pair, -kappa b'(d) at x, and its friction force mu lam f1(|u|) (the contact set lagged
    again at x, its anchors at x_prev and the primitives' previous poses, as the solve's last lag) go to the edge's
    vertices by weights 1 - t* and t*; a vertex sums the magnitudes of its pairs. Gaps are exact below cap; an edge
    with no enabled primitive nearer than cap [m] reports gap cap and index -1. A penetrating pair reports an
    infinite normal force.
    Returns (normal (n+1,), friction (n+1,), gap (n,), nearest (n,) int64).
    """
    n_v = x.shape[0]
    bound = bounding_radii(kind, size)
    normal = np.zeros(n_v)
    fric = np.zeros(n_v)
    gap = np.empty(n_v - 1)
    nearest = np.empty(n_v - 1, np.int64)
    for i in range(n_v - 1):
        gap[i] = cap
        nearest[i] = -1
    dc, tc, wc = np.empty(MAX_CONTACTS), np.empty(MAX_CONTACTS), np.empty(MAX_CONTACTS)
    pc, nc, hc = np.empty((MAX_CONTACTS, 3)), np.empty((MAX_CONTACTS, 3)), np.empty((MAX_CONTACTS, 3, 3))
    for i in range(n_v - 1):
        for j in range(kind.shape[0]):
            reach = max(gap[i], dhat)
            if not mask[i, j] or lower_bound(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], bound[j]) >= reach:
                continue  # neither nearer than the best so far (nor cap) nor pushing
            count, _ = pair_contacts(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], dhat, dc, tc, wc, pc, nc,
                                     hc)
            for c in range(count):
                d, t = dc[c], tc[c]
                if d < gap[i]:
                    gap[i] = d
                    nearest[i] = j
                if d < dhat and wc[c] > 0.0:
                    f = -kappa * wc[c] * barrier_d1(d, dhat) if d > 0.0 else np.inf
                    normal[i] += (1.0 - t) * f
                    normal[i + 1] += t * f
    edge, tpar, nrm, lam, anchor = friction_relag(x_prev, x, r, kind, pos_prev, rot_prev, size, pos, rot, mask, dhat,
                                                  kappa)
    force = friction_force(x, edge, tpar, nrm, lam, anchor, mu, eps)
    for c in range(edge.shape[0]):
        fric[edge[c]] += (1.0 - tpar[c]) * force[c]
        fric[edge[c] + 1] += tpar[c] * force[c]
    return normal, fric, gap, nearest
