"""IPC's log barrier on the edge-primitive gaps: energy, gradient and PSD-projected Hessian blocks."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .assembly import add_edge_block, add_edge_gradient
from .primitives import bounding_radii
from .segment import MAX_CONTACTS, lower_bound, pair_contacts


@njit(cache=True)
def barrier(d, dhat):
    """b(d) = -(d - dhat)^2 ln(d / dhat) for 0 < d < dhat, 0 beyond (C2 at dhat) [m^2]."""
    if d >= dhat:
        return 0.0
    return -(d - dhat) ** 2 * math.log(d / dhat)


@njit(cache=True)
def barrier_d1(d, dhat):
    """b'(d) = (dhat - d)(2 ln(d / dhat) - dhat / d + 1) (<= 0) [m]."""
    if d >= dhat:
        return 0.0
    return (dhat - d) * (2.0 * math.log(d / dhat) - dhat / d + 1.0)


@njit(cache=True)
def barrier_d2(d, dhat):
    """b''(d) = (dhat / d + 2) dhat / d - 2 ln(d / dhat) - 3 (>= 0)."""
    if d >= dhat:
        return 0.0
    q = dhat / d
    return (q + 2.0) * q - 2.0 * math.log(d / dhat) - 3.0


@njit(cache=True)
def point_hessian(d, n, h, dhat, kappa, project, out):
    """Hessian of kappa b(d) in the contact point, kappa (b'' n n^T + b' h), or its PSD part if project.

    Every kind's distance Hessian h is PSD with h n = 0 (primitives._curved), so n is an eigenvector with eigenvalue
    kappa b'' >= 0 and the others are kappa b' (<= 0) times h's: clamping the negative eigenvalues to 0 leaves
    exactly kappa b'' n n^T, with no eigen-decomposition.
    """
    d1 = 0.0 if project else kappa * barrier_d1(d, dhat)
    d2 = kappa * barrier_d2(d, dhat)
    for a in range(3):
        for b in range(3):
            out[a, b] = d2 * n[a] * n[b] + d1 * h[a, b]


@njit(cache=True)
def barrier_accumulate(x, r, kind, pos, rot, size, mask, dhat, kappa, g, band, project):
    """Barrier energy sum kappa b(d) [J] over the enabled pairs with d < dhat; adds its gradient to g (n+1, 3) and its
    Hessian to the lower band matrix band (kd+1, 3(n+1)), kd >= 5, the edge blocks PSD-projected if project (the
    solve's choice; False gives the raw Hessian with t* held fixed).

    x (n+1, 3) cable vertices, r cable radius [m]; kind (k,), pos (k, 3), rot (k, 3, 3), size (k, 3) primitives;
    mask (n, k) bool, True where edge i may touch primitive j; dhat [m]; kappa [J/m^2]. Returns inf at the first
    penetrating pair (d <= 0), g and band then hold a partial sum.
    """
    bound = bounding_radii(kind, size)
    d, t, w = np.empty(MAX_CONTACTS), np.empty(MAX_CONTACTS), np.empty(MAX_CONTACTS)
    p, n, h = np.empty((MAX_CONTACTS, 3)), np.empty((MAX_CONTACTS, 3)), np.empty((MAX_CONTACTS, 3, 3))
    hp = np.empty((3, 3))
    gp = np.empty(3)
    energy = 0.0
    for i in range(x.shape[0] - 1):
        for j in range(kind.shape[0]):
            if not mask[i, j] or lower_bound(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], bound[j]) >= dhat:
                continue
            count, m = pair_contacts(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], dhat, d, t, w, p, n, h)
            for c in range(count):
                if d[c] <= 0.0:
                    return np.inf
            for c in range(count):
                if d[c] >= dhat or w[c] == 0.0:
                    continue
                energy += kappa * w[c] * barrier(d[c], dhat)
                d1 = kappa * w[c] * barrier_d1(d[c], dhat)
                for k in range(3):
                    gp[k] = d1 * n[c, k]
                add_edge_gradient(g, i, t[c], gp)
                point_hessian(d[c], n[c], h[c], dhat, kappa * w[c], project, hp)
                add_edge_block(band, i, t[c], hp)
            if m >= 0 and 0.0 < w[2] < 1.0 and d[2] < dhat:
                # the blend's own slope: w = (d_m - d*) / dhat in its ramp, times the closest point's barrier
                coef = kappa * barrier(d[2], dhat) / dhat
                for k in range(3):
                    gp[k] = coef * n[m, k]
                add_edge_gradient(g, i, t[m], gp)
                for k in range(3):
                    gp[k] = -coef * n[2, k]
                add_edge_gradient(g, i, t[2], gp)
    return energy


@njit(cache=True)
def barrier_energy(x, r, kind, pos, rot, size, mask, dhat, kappa):
    """The energy of :func:`barrier_accumulate` alone (for the line search): inf on any penetration."""
    bound = bounding_radii(kind, size)
    d, t, w = np.empty(MAX_CONTACTS), np.empty(MAX_CONTACTS), np.empty(MAX_CONTACTS)
    p, n, h = np.empty((MAX_CONTACTS, 3)), np.empty((MAX_CONTACTS, 3)), np.empty((MAX_CONTACTS, 3, 3))
    energy = 0.0
    for i in range(x.shape[0] - 1):
        for j in range(kind.shape[0]):
            if not mask[i, j] or lower_bound(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], bound[j]) >= dhat:
                continue
            count, _ = pair_contacts(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], dhat, d, t, w, p, n, h)
            for c in range(count):
                if d[c] <= 0.0:
                    return np.inf
                energy += kappa * w[c] * barrier(d[c], dhat)
    return energy
