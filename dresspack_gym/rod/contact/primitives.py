"""Signed distance from a point to a convex primitive's surface, with its gradient and Hessian in the point."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# kinds, as in the flat primitive arrays (kind, pos, rot, size); sizes follow MuJoCo's geoms
PLANE = 0  # solid below the plane through pos with outward normal rot[:, 2]
SPHERE = 1  # radius size[0]
CAPSULE = 2  # radius size[0], half-length size[1] of its axis along local z
BOX = 3  # half sizes size[0:3]
CYLINDER = 4  # radius size[0], half-length size[1] along local z

TINY = 1e-300  # a core distance below this has no defined normal (a point on a capsule's axis: deep penetration)


@njit(cache=True)
def dot3(u, v):
    """u . v for 3-vectors (numba's @ goes through BLAS: slower to compile and to call at this size)."""
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


@njit(cache=True)
def zero33(h):
    """h[:, :] = 0 (as a loop: numba compiles slice assignment slowly)."""
    for a in range(3):
        for b in range(3):
            h[a, b] = 0.0


@njit(cache=True)
def bounding_radius(kind, size):
    """Radius about the primitive's origin of a ball holding all of it (inf for a plane)."""
    if kind == PLANE:
        return np.inf
    if kind == SPHERE:
        return size[0]
    if kind == CAPSULE:
        return size[0] + size[1]
    if kind == BOX:
        return math.sqrt(size[0] * size[0] + size[1] * size[1] + size[2] * size[2])
    return math.sqrt(size[0] * size[0] + size[1] * size[1])


@njit(cache=True)
def _curved(v0, v1, v2, jac, n, h):
    """Distance |v| to a feature whose closest-point offset is v, dv/dq = jac: n = v/|v|, H = (jac - n n^T)/|v|.

    Every kind's Hessian has this form (n^T jac = n^T, so H n = 0: the distance is flat along its own normal).
    """
    dc = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if dc < TINY:
        n[0], n[1], n[2] = 0.0, 0.0, 1.0
        zero33(h)
        return dc
    n[0], n[1], n[2] = v0 / dc, v1 / dc, v2 / dc
    for a in range(3):
        for b in range(3):
            h[a, b] = (jac[a, b] - n[a] * n[b]) / dc
    return dc


@njit(cache=True)
def _box(q, hs, n, h, jac):
    outside = False
    v = np.empty(3)
    for k in range(3):
        c = min(max(q[k], -hs[k]), hs[k])
        v[k] = q[k] - c
        jac[k, k] = 1.0 if q[k] != c else 0.0
        outside = outside or q[k] != c
    if outside:
        return _curved(v[0], v[1], v[2], jac, n, h)
    # inside: the nearest face's plane (the signed distance is a max of planes there)
    best = -np.inf
    axis = 0
    for k in range(3):
        dk = abs(q[k]) - hs[k]
        if dk > best:
            best = dk
            axis = k
    n[0], n[1], n[2] = 0.0, 0.0, 0.0
    n[axis] = 1.0 if q[axis] >= 0.0 else -1.0
    zero33(h)
    return best


@njit(cache=True)
def _cylinder(q, radius, half, n, h, jac):
    rho = math.sqrt(q[0] * q[0] + q[1] * q[1])
    if rho > TINY:
        u0, u1 = q[0] / rho, q[1] / rho
    else:
        u0, u1 = 1.0, 0.0
    dr = rho - radius
    az = abs(q[2])
    dz = az - half
    sz = 1.0 if q[2] >= 0.0 else -1.0
    if dr > 0.0 and dz > 0.0:  # the rim circle: jac = I - (radius/rho)(I - u u^T) in the xy plane
        k = radius / rho
        jac[0, 0] = 1.0 - k * (1.0 - u0 * u0)
        jac[1, 1] = 1.0 - k * (1.0 - u1 * u1)
        jac[0, 1] = jac[1, 0] = k * u0 * u1
        jac[2, 2] = 1.0
        return _curved(dr * u0, dr * u1, dz * sz, jac, n, h)
    zero33(h)
    if dr > dz:  # the side (outside when dr > 0, else the nearer surface from inside)
        n[0], n[1], n[2] = u0, u1, 0.0
        if dr > 0.0:
            h[0, 0] = (1.0 - u0 * u0) / rho
            h[1, 1] = (1.0 - u1 * u1) / rho
            h[0, 1] = h[1, 0] = -u0 * u1 / rho
        return dr
    n[0], n[1], n[2] = 0.0, 0.0, sz
    return dz


@njit(cache=True)
def _local(kind, size, q, n, h):
    """Distance, normal and Hessian in the primitive's frame."""
    jac = np.zeros((3, 3))
    if kind == PLANE:
        n[0], n[1], n[2] = 0.0, 0.0, 1.0
        zero33(h)
        return q[2]
    if kind == SPHERE:
        jac[0, 0] = jac[1, 1] = jac[2, 2] = 1.0
        return _curved(q[0], q[1], q[2], jac, n, h) - size[0]
    if kind == CAPSULE:
        z = min(max(q[2], -size[1]), size[1])
        jac[0, 0] = jac[1, 1] = 1.0
        jac[2, 2] = 1.0 if z != q[2] else 0.0  # on a cap the axis end is a point, along the side a line
        return _curved(q[0], q[1], q[2] - z, jac, n, h) - size[0]
    if kind == BOX:
        return _box(q, size, n, h, jac)
    return _cylinder(q, size[0], size[1], n, h, jac)


@njit(cache=True)
def point_distance(kind, pos, rot, size, p, n, h):
    """Signed distance from point p to the primitive's surface (< 0 inside); fills n = grad (unit) and h = Hessian.

    kind, size: one primitive's entries; pos (3,), rot (3, 3) (columns = local axes); n (3,), h (3, 3) are outputs.
    The Hessian is exact off feature boundaries (where the distance is only C1) and zero inside the solid.
    """
    q = np.empty(3)
    for a in range(3):
        q[a] = rot[0, a] * (p[0] - pos[0]) + rot[1, a] * (p[1] - pos[1]) + rot[2, a] * (p[2] - pos[2])
    nl = np.empty(3)
    hl = np.empty((3, 3))
    d = _local(kind, size, q, nl, hl)
    for a in range(3):
        n[a] = rot[a, 0] * nl[0] + rot[a, 1] * nl[1] + rot[a, 2] * nl[2]
    tmp = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            tmp[a, b] = rot[a, 0] * hl[0, b] + rot[a, 1] * hl[1, b] + rot[a, 2] * hl[2, b]
    for a in range(3):
        for b in range(3):
            h[a, b] = tmp[a, 0] * rot[b, 0] + tmp[a, 1] * rot[b, 1] + tmp[a, 2] * rot[b, 2]
    return d


@njit(cache=True)
def bounding_radii(kind, size):
    """:func:`bounding_radius` of each primitive (k,)."""
    out = np.empty(kind.shape[0])
    for j in range(kind.shape[0]):
        out[j] = bounding_radius(kind[j], size[j])
    return out
