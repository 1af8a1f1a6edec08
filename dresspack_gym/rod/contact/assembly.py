"""Adding an edge pair's gradient and 6x6 Hessian block (w w^T) (x) H_point to the cable's arrays."""

from __future__ import annotations

from numba import njit


@njit(cache=True)
def add_edge_gradient(g, i, t, gp):
    """g[i] += (1 - t) gp, g[i + 1] += t gp: a gradient gp in the contact point p = (1 - t) x_i + t x_{i+1}."""
    for k in range(3):
        g[i, k] += (1.0 - t) * gp[k]
        g[i + 1, k] += t * gp[k]


@njit(cache=True)
def add_edge_block(band, i, t, hp):
    """Add the 6x6 block (w w^T) (x) hp, w = (1 - t, t), over coordinates 3i..3i+5 of the LOWER band matrix
    (band[d, c] += H[c + d, c], unknowns ordered x[0, 0], x[0, 1], x[0, 2], x[1, 0], ...).

    The block's eigenvalues are |w|^2 times hp's and zeros, so the block is PSD exactly when hp is.
    """
    base = 3 * i
    for a in range(6):
        wa = 1.0 - t if a < 3 else t
        for b in range(a + 1):
            wb = 1.0 - t if b < 3 else t
            band[a - b, base + b] += wa * wb * hp[a % 3, b % 3]
