"""Adding an edge pair's gradient and 6x6 Hessian block to the cable's arrays, and PSD projection of 3x3 blocks."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

JACOBI_SWEEPS = 16  # cyclic Jacobi on 3x3 converges quadratically: a handful of sweeps reach rounding


@njit(cache=True)
def add_edge_gradient(g, i, t, gp):
    """g[i] += (1 - t) gp, g[i + 1] += t gp: a gradient gp in the contact point p = (1 - t) x_i + t x_{i+1}."""
    for k in range(3):
        g[i, k] += (1.0 - t) * gp[k]
        g[i + 1, k] += t * gp[k]


@njit(cache=True)
def add_edge_block(band, i, t, hp):
    """Add the 6x6 block (w w^T) (x) hp, w = (1 - t, t), over coordinates 3i..3i+5 of the LOWER band matrix
    (band[d, c] += H[c + d, c], unknowns ordered x[0, 0], x[0, 1], x[0, 2], x[1, 0], ...)."""
    base = 3 * i
    for a in range(6):
        wa = 1.0 - t if a < 3 else t
        for b in range(a + 1):
            wb = 1.0 - t if b < 3 else t
            band[a - b, base + b] += wa * wb * hp[a % 3, b % 3]


@njit(cache=True)
def psd_project3(m, out):
    """out = m with negative eigenvalues set to 0 (m symmetric 3x3; cyclic Jacobi eigen-decomposition).

    The 6x6 block (w w^T) (x) m has the eigenvalues |w|^2 lambda_k(m) and zeros, so projecting m projects the block.
    """
    a = m.copy()
    v = np.eye(3)
    scale = abs(a[0, 0]) + abs(a[1, 1]) + abs(a[2, 2]) + abs(a[0, 1]) + abs(a[0, 2]) + abs(a[1, 2])
    for _ in range(JACOBI_SWEEPS):
        off = abs(a[0, 1]) + abs(a[0, 2]) + abs(a[1, 2])
        if off <= 1e-15 * scale:
            break
        for p, q in ((0, 1), (0, 2), (1, 2)):
            apq = a[p, q]
            if apq == 0.0:
                continue
            theta = (a[q, q] - a[p, p]) / (2.0 * apq)
            tt = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
            c = 1.0 / math.sqrt(tt * tt + 1.0)
            s = tt * c
            for k in range(3):  # a <- a J (columns p, q)
                akp, akq = a[k, p], a[k, q]
                a[k, p] = c * akp - s * akq
                a[k, q] = s * akp + c * akq
            for k in range(3):  # a <- J^T a (rows p, q)
                apk, aqk = a[p, k], a[q, k]
                a[p, k] = c * apk - s * aqk
                a[q, k] = s * apk + c * aqk
            for k in range(3):
                vkp, vkq = v[k, p], v[k, q]
                v[k, p] = c * vkp - s * vkq
                v[k, q] = s * vkp + c * vkq
    for r in range(3):
        for c2 in range(3):
            acc = 0.0
            for k in range(3):
                lam = a[k, k]
                if lam > 0.0:
                    acc += lam * v[r, k] * v[c2, k]
            out[r, c2] = acc
