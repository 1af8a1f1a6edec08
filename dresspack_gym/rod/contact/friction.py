"""Smoothed Coulomb friction lagged as in IPC: the contact set at the solve's start, then a potential on the
tangential displacement of each contact point relative to the primitive's material point."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .assembly import add_edge_block, add_edge_gradient
from .barrier import barrier_d1
from .primitives import bounding_radii
from .segment import MAX_CONTACTS, lower_bound, pair_contacts

# The most times a step's friction is lagged again at its solution and the step solved again (friction_relag).
MAX_RELAGS = 3


@njit(cache=True)
def f0(y, eps):
    """IPC's mollifier: -y^3/(3 eps^2) + y^2/eps + eps/3 below eps, y beyond (C2 at eps; f0(0) = eps/3, a constant
    that no force sees) [m]."""
    if y >= eps:
        return y
    return -y * y * y / (3.0 * eps * eps) + y * y / eps + eps / 3.0


@njit(cache=True)
def f1(y, eps):
    """f0' = 2 y/eps - (y/eps)^2 below eps, 1 beyond: the friction force over mu lam."""
    if y >= eps:
        return 1.0
    s = y / eps
    return 2.0 * s - s * s


@njit(cache=True)
def friction_lag(x_prev, r, kind, pos_prev, rot_prev, size, pos, rot, mask, dhat, kappa):
    """The lagged contact set: the enabled pairs with 0 < d < dhat at x_prev against the primitives' previous poses.

    Returns (edge (m,) int64, t (m,), normal (m, 3), lam (m,) [N], anchor (m, 3)): per pair the edge, its contact
    parameter t*, the normal, the normal force lam = -kappa b'(d) and the anchor p(t*; x_prev) + (the displacement of
    the primitive's material point at the contact from the previous pose to (pos, rot)), so that the tangential
    relative displacement at x is u = (I - n n^T)(p(t*; x) - anchor).
    """
    return _lagged_set(x_prev, x_prev, r, kind, pos_prev, rot_prev, size, pos, rot, mask, dhat, kappa, 1.0)


@njit(cache=True)
def friction_relag(x_prev, x, r, kind, pos_prev, rot_prev, size, pos, rot, mask, dhat, kappa):
    """The contact set lagged again at a step's solution ``x`` (IPC's lagged iterations): the pairs, normals and
    normal forces of x against the primitives' poses now, the anchors still the step's start, p(t*; x_prev) + (the
    displacement of the touched material point from the previous pose to now). At a fixed point (x solved with the
    set relagged at x) friction is mu times the normal force at the step's end, as Coulomb's law asks."""
    return _lagged_set(x, x_prev, r, kind, pos, rot, size, pos_prev, rot_prev, mask, dhat, kappa, -1.0)


@njit(cache=True)
def friction_settled(n_vertices, edge, t, lam, edge_again, t_again, lam_again, mu, force_scale, tolerance):
    """Whether lagging again changes no vertex's friction bound mu lam (its pairs' shares by weights 1 - t*, t*) by
    ``tolerance`` of its ``force_scale`` or more: the solve would then stand (its own tolerance), so it is not
    repeated."""
    change = np.zeros(n_vertices)
    for c in range(edge.shape[0]):
        change[edge[c]] -= (1.0 - t[c]) * lam[c]
        change[edge[c] + 1] -= t[c] * lam[c]
    for c in range(edge_again.shape[0]):
        change[edge_again[c]] += (1.0 - t_again[c]) * lam_again[c]
        change[edge_again[c] + 1] += t_again[c] * lam_again[c]
    for v in range(n_vertices):
        if mu * abs(change[v]) >= tolerance * force_scale[v]:
            return False
    return True


@njit(cache=True)
def _lagged_set(x_eval, x_anchor, r, kind, pos_eval, rot_eval, size, pos_other, rot_other, mask, dhat, kappa,
                toward):
    """The contact set of the pairs with 0 < d < dhat at ``x_eval`` against the primitives at (pos_eval, rot_eval), with
    anchors taken from ``x_anchor``: per pair p(t*; x_anchor) + ``toward`` x (the touched material point's place at
    (pos_other, rot_other) - its place now). See :func:`friction_lag` (toward +1) and :func:`friction_relag` (-1)."""
    n_e = x_eval.shape[0] - 1
    n_prims = kind.shape[0]
    bound = bounding_radii(kind, size)
    pairs = 0
    for i in range(n_e):
        for j in range(n_prims):
            pairs += mask[i, j]
    # every enabled pair's contacts (segment.pair_contacts): sized by the pairs the mask leaves (a broad phase's
    # handful), not all of them, so the arrays stay small
    most = MAX_CONTACTS * pairs
    edge = np.empty(most, np.int64)
    tpar = np.empty(most)
    normal = np.empty((most, 3))
    lam = np.empty(most)
    anchor = np.empty((most, 3))
    dc, tc, wc = np.empty(MAX_CONTACTS), np.empty(MAX_CONTACTS), np.empty(MAX_CONTACTS)
    pc, nc, hc = np.empty((MAX_CONTACTS, 3)), np.empty((MAX_CONTACTS, 3)), np.empty((MAX_CONTACTS, 3, 3))
    p = np.empty(3)
    n = np.empty(3)
    s = np.empty(3)
    local = np.empty(3)
    m = 0
    for i in range(n_e):
        for j in range(n_prims):
            if not mask[i, j] or lower_bound(x_eval[i], x_eval[i + 1], r, kind[j], pos_eval[j], rot_eval[j], size[j],
                                             bound[j]) >= dhat:
                continue
            count, _ = pair_contacts(x_eval[i], x_eval[i + 1], r, kind[j], pos_eval[j], rot_eval[j], size[j], dhat,
                                     dc, tc, wc, pc, nc, hc)
            for c in range(count):
                d, t = dc[c], tc[c]
                if not 0.0 < d < dhat or wc[c] == 0.0:
                    continue
                for k in range(3):
                    p[k], n[k] = pc[c, k], nc[c, k]
                # the primitive's surface point under the contact, carried rigidly to its other pose
                for k in range(3):
                    s[k] = p[k] - (d + r) * n[k]
                for k in range(3):
                    local[k] = 0.0
                    for m2 in range(3):
                        local[k] += rot_eval[j, m2, k] * (s[m2] - pos_eval[j, m2])
                for k in range(3):
                    moved = (pos_other[j, k] + rot_other[j, k, 0] * local[0] + rot_other[j, k, 1] * local[1]
                             + rot_other[j, k, 2] * local[2])
                    anchor[m, k] = (1.0 - t) * x_anchor[i, k] + t * x_anchor[i + 1, k] + toward * (moved - s[k])
                    normal[m, k] = n[k]
                edge[m] = i
                tpar[m] = t
                lam[m] = -kappa * wc[c] * barrier_d1(d, dhat)
                m += 1
    return edge[:m].copy(), tpar[:m].copy(), normal[:m].copy(), lam[:m].copy(), anchor[:m].copy()


@njit(cache=True)
def _tangential(x, i, t, nrm, anchor, u):
    """u = (I - n n^T)(p(t; x) - anchor); returns |u|."""
    for k in range(3):
        u[k] = (1.0 - t) * x[i, k] + t * x[i + 1, k] - anchor[k]
    un = u[0] * nrm[0] + u[1] * nrm[1] + u[2] * nrm[2]
    for k in range(3):
        u[k] -= un * nrm[k]
    return math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])


@njit(cache=True)
def _f1_over_y(y, eps):
    return 2.0 / eps - y / (eps * eps) if y < eps else 1.0 / y


@njit(cache=True)
def friction_accumulate(x, edge, t, normal, lam, anchor, mu, eps, g, band):
    """Friction potential sum mu lam f0(|u|) [J] over the lagged set (see :func:`friction_lag`); adds its gradient to
    g and its Hessian blocks to the lower band matrix (as barrier_accumulate). eps [m]: the tangential displacement
    below which friction is smoothed (IPC's eps_v h).

    The blocks are PSD without projection: in the point, H = mu lam (f1/y P_T + (f1' - f1/y) u u^T / y^2) has the
    eigenvalues mu lam f1/y (tangent, across u), mu lam f1' (along u) and 0 (normal), all >= 0 for this f0.
    """
    u = np.empty(3)
    gp = np.empty(3)
    hp = np.empty((3, 3))
    energy = 0.0
    for c in range(edge.shape[0]):
        i = edge[c]
        y = _tangential(x, i, t[c], normal[c], anchor[c], u)
        s = mu * lam[c]
        energy += s * f0(y, eps)
        a = s * _f1_over_y(y, eps)
        # (f1' - f1/y)/y^2: -1/(eps^2 y) below eps, -1/y^3 beyond; times u u^T it stays bounded as y -> 0
        if y == 0.0:
            b = 0.0
        elif y < eps:
            b = -s / (eps * eps * y)
        else:
            b = -s / (y * y * y)
        nrm = normal[c]
        for k in range(3):
            gp[k] = a * u[k]
        for k in range(3):
            for m2 in range(3):
                delta = 1.0 if k == m2 else 0.0
                hp[k, m2] = a * (delta - nrm[k] * nrm[m2]) + b * u[k] * u[m2]
        add_edge_gradient(g, i, t[c], gp)
        add_edge_block(band, i, t[c], hp)
    return energy


@njit(cache=True)
def friction_energy(x, edge, t, normal, lam, anchor, mu, eps):
    """The energy of :func:`friction_accumulate` alone (for the line search)."""
    u = np.empty(3)
    energy = 0.0
    for c in range(edge.shape[0]):
        y = _tangential(x, edge[c], t[c], normal[c], anchor[c], u)
        energy += mu * lam[c] * f0(y, eps)
    return energy


@njit(cache=True)
def friction_force(x, edge, t, normal, lam, anchor, mu, eps):
    """Per lagged pair the friction force magnitude mu lam f1(|u|) [N] at x."""
    u = np.empty(3)
    out = np.empty(edge.shape[0])
    for c in range(edge.shape[0]):
        y = _tangential(x, edge[c], t[c], normal[c], anchor[c], u)
        out[c] = mu * lam[c] * f1(y, eps)
    return out
