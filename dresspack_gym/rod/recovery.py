"""Getting a cable out of a primitive it was left inside (a holder drove it there): a quadratic penalty on the gap.

The barrier solve needs a start outside every primitive. When even the last state is inside one (a clamp carried
its edge into an obstacle faster than the cable could be pushed), a Newton solve on the incremental potential with
k/2 (margin - d)^2 for every gap d below ``margin`` (no barrier, defined inside too) moves the free vertices out;
the barrier solve then starts from there. It is reported, never silent (``RodSimulator.recovered_steps``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .contact.assembly import add_edge_block, add_edge_gradient
from .contact.primitives import bounding_radii
from .contact.segment import MAX_CONTACTS, lower_bound, pair_contacts


@njit(cache=True)
def penalty(x, r, kind, pos, rot, size, mask, margin, stiffness, want, g, band):
    """Sum of stiffness/2 (margin - d)^2 over the enabled pairs with gap d < margin; with ``want`` adds its gradient
    to g and its Gauss-Newton Hessian stiffness (grad d)(grad d)^T to the lower band."""
    bound = bounding_radii(kind, size)
    n = np.empty(3)
    dc, tc, wc = np.empty(MAX_CONTACTS), np.empty(MAX_CONTACTS), np.empty(MAX_CONTACTS)
    pc, nc, hc = np.empty((MAX_CONTACTS, 3)), np.empty((MAX_CONTACTS, 3)), np.empty((MAX_CONTACTS, 3, 3))
    gp = np.empty(3)
    hp = np.empty((3, 3))
    energy = 0.0
    for i in range(x.shape[0] - 1):
        for j in range(kind.shape[0]):
            if not mask[i, j] or lower_bound(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], bound[j]) >= margin:
                continue
            count, _ = pair_contacts(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], margin, dc, tc, wc, pc, nc,
                                     hc)
            for c in range(count):
                d, t = dc[c], tc[c]
                if d >= margin:
                    continue
                k_pair = stiffness * max(wc[c], 0.5)  # the closest point pushes out even where the blend omits it
                for k in range(3):
                    n[k] = nc[c, k]
                energy += 0.5 * k_pair * (margin - d) ** 2
                if not want:
                    continue
                for k in range(3):
                    gp[k] = -k_pair * (margin - d) * n[k]
                    for m in range(3):
                        hp[k, m] = k_pair * n[k] * n[m]
                add_edge_gradient(g, i, t, gp)
                add_edge_block(band, i, t, hp)
    return energy
