"""Banded Cholesky factorisation and solves (lower band storage), and low-rank updates by Woodbury's identity.

Storage as LAPACK's lower band: ``band[d, c] = A[c + d, c]`` for 0 <= d <= kd. One cable's Hessian is banded with
kd = 8 (a bend couples three vertices); a twisted span adds a rank-one term, handled by Woodbury so that the
factorisation stays banded.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def cholesky(band):
    """(ok, L): the Cholesky factor of the lower band matrix ``band`` (A = L L^T), column by column: L[c, d] is the
    factor's entry (c + d, c). ok is False if A is not positive definite.

    Right-looking on the column-major copy: each column's band is contiguous, so the trailing update reads memory
    in order (the row-major storage read across its rows took three times as long)."""
    kd1, n = band.shape
    kd = kd1 - 1
    col = np.ascontiguousarray(band.T)
    for j in range(n):
        pivot = col[j, 0]
        if not pivot > 0.0:
            return False, col
        ljj = math.sqrt(pivot)
        col[j, 0] = ljj
        width = min(kd, n - 1 - j)
        for d in range(1, width + 1):
            col[j, d] /= ljj
        for d1 in range(1, width + 1):  # A[j+d2, j+d1] -= L[j+d1, j] L[j+d2, j], d2 >= d1
            l1 = col[j, d1]
            for d2 in range(d1, width + 1):
                col[j + d1, d2 - d1] -= l1 * col[j, d2]
    return True, col


@njit(cache=True)
def solve(factor, rhs):
    """Solve A y = rhs with the factor L from :func:`cholesky` (returns a new vector)."""
    n, kd1 = factor.shape
    kd = kd1 - 1
    y = rhs.copy()
    for i in range(n):  # L z = rhs, column by column
        y[i] /= factor[i, 0]
        yi = y[i]
        for d in range(1, min(kd, n - 1 - i) + 1):
            y[i + d] -= factor[i, d] * yi
    for i in range(n - 1, -1, -1):  # L^T y = z
        acc = y[i]
        for d in range(1, min(kd, n - 1 - i) + 1):
            acc -= factor[i, d] * y[i + d]
        y[i] = acc / factor[i, 0]
    return y


@njit(cache=True)
def solve_low_rank(factor, weights, vectors, rhs):
    """Solve (A + sum_k w_k u_k u_k^T) y = rhs, A given by its band factor, u_k the rows of ``vectors``."""
    k = weights.shape[0]
    y = solve(factor, rhs)
    if k == 0:
        return y
    z = np.empty((k, rhs.shape[0]))
    for a in range(k):
        z[a] = solve(factor, vectors[a])
    # (W^-1 + U^T A^-1 U) c = U^T A^-1 rhs ; y -= A^-1 U c
    small = np.empty((k, k))
    rhs_small = np.empty(k)
    for a in range(k):
        rhs_small[a] = vectors[a] @ y
        for b in range(k):
            small[a, b] = vectors[a] @ z[b]
        small[a, a] += 1.0 / weights[a]
    c = np.linalg.solve(small, rhs_small)
    for a in range(k):
        y -= c[a] * z[a]
    return y


@njit(cache=True)
def band_matvec(band, v):
    """A v for a symmetric A in lower band storage (for tests and residual checks)."""
    kd1, n = band.shape
    out = np.zeros(n)
    for c in range(n):
        out[c] += band[0, c] * v[c]
        for d in range(1, kd1):
            r = c + d
            if r >= n:
                break
            out[r] += band[d, c] * v[c]
            out[c] += band[d, c] * v[r]
    return out


@njit(cache=True)
def pin(band, coords):
    """Replace the rows and columns of ``coords`` by the identity (held coordinates: no unknown there)."""
    kd1, n = band.shape
    for c in coords:
        for d in range(kd1):
            if c + d < n:
                band[d, c] = 0.0
            if c - d >= 0:
                band[d, c - d] = 0.0
        band[0, c] = 1.0
