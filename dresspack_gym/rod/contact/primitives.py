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
def _curved(v0, v1, v2, j00, j11, j22, j01, n, h):
    """Distance |v| to a feature whose closest-point offset is v, dv/dq = jac = [[j00, j01, 0], [j01, j11, 0],
    [0, 0, j22]]: n = v/|v|, H = (jac - n n^T)/|v|.

    Every kind's Hessian has this form with jac PSD and n^T jac = n^T, so H is PSD and H n = 0 (the barrier's
    PSD projection relies on both).
    """
    dc = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if dc < TINY:
        n[0], n[1], n[2] = 0.0, 0.0, 1.0
        zero33(h)
        return dc
    n[0], n[1], n[2] = v0 / dc, v1 / dc, v2 / dc
    for a in range(3):
        for b in range(3):
            h[a, b] = -n[a] * n[b] / dc
    h[0, 0] += j00 / dc
    h[1, 1] += j11 / dc
    h[2, 2] += j22 / dc
    h[0, 1] += j01 / dc
    h[1, 0] += j01 / dc
    return dc


@njit(cache=True)
def _flag(b):
    return 1.0 if b else 0.0


@njit(cache=True)
def _box(q0, q1, q2, hs, n, h):
    c0 = min(max(q0, -hs[0]), hs[0])
    c1 = min(max(q1, -hs[1]), hs[1])
    c2 = min(max(q2, -hs[2]), hs[2])
    if q0 != c0 or q1 != c1 or q2 != c2:  # outside: the offset to the clamped point, moving along clamped axes
        return _curved(q0 - c0, q1 - c1, q2 - c2, _flag(q0 != c0), _flag(q1 != c1),
                       _flag(q2 != c2), 0.0, n, h)
    # inside: the nearest face's plane (the signed distance is a max of planes there)
    d0, d1, d2 = abs(q0) - hs[0], abs(q1) - hs[1], abs(q2) - hs[2]
    n[0], n[1], n[2] = 0.0, 0.0, 0.0
    zero33(h)
    if d0 >= d1 and d0 >= d2:
        n[0] = 1.0 if q0 >= 0.0 else -1.0
        return d0
    if d1 >= d2:
        n[1] = 1.0 if q1 >= 0.0 else -1.0
        return d1
    n[2] = 1.0 if q2 >= 0.0 else -1.0
    return d2


@njit(cache=True)
def _cylinder(q0, q1, q2, radius, half, n, h):
    rho = math.sqrt(q0 * q0 + q1 * q1)
    if rho > TINY:
        u0, u1 = q0 / rho, q1 / rho
    else:
        u0, u1 = 1.0, 0.0
    dr = rho - radius
    dz = abs(q2) - half
    sz = 1.0 if q2 >= 0.0 else -1.0
    if dr > 0.0 and dz > 0.0:  # the rim circle: jac = I - (radius/rho)(I - u u^T) in the xy plane
        k = radius / rho
        return _curved(dr * u0, dr * u1, dz * sz, 1.0 - k * (1.0 - u0 * u0), 1.0 - k * (1.0 - u1 * u1), 1.0,
                       k * u0 * u1, n, h)
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
def _local(kind, size, q0, q1, q2, n, h):
    """Distance, normal and Hessian in the primitive's frame."""
    if kind == PLANE:
        n[0], n[1], n[2] = 0.0, 0.0, 1.0
        zero33(h)
        return q2
    if kind == SPHERE:
        return _curved(q0, q1, q2, 1.0, 1.0, 1.0, 0.0, n, h) - size[0]
    if kind == CAPSULE:
        z = min(max(q2, -size[1]), size[1])
        # on a cap the axis end is a point (jac = I), along the side a line (no motion along it)
        return _curved(q0, q1, q2 - z, 1.0, 1.0, _flag(z != q2), 0.0, n, h) - size[0]
    if kind == BOX:
        return _box(q0, q1, q2, size, n, h)
    return _cylinder(q0, q1, q2, size[0], size[1], n, h)


@njit(cache=True)
def point_distance(kind, pos, rot, size, p, n, h):
    """Signed distance from point p to the primitive's surface (< 0 inside); fills n = grad (unit) and h = Hessian.

    kind, size: one primitive's entries; pos (3,), rot (3, 3) (columns = local axes); n (3,), h (3, 3) are outputs.
    The Hessian is exact off feature boundaries (where the distance is only C1) and zero inside the solid.
    """
    r0, r1, r2 = p[0] - pos[0], p[1] - pos[1], p[2] - pos[2]
    q0 = rot[0, 0] * r0 + rot[1, 0] * r1 + rot[2, 0] * r2
    q1 = rot[0, 1] * r0 + rot[1, 1] * r1 + rot[2, 1] * r2
    q2 = rot[0, 2] * r0 + rot[1, 2] * r1 + rot[2, 2] * r2
    d = _local(kind, size, q0, q1, q2, n, h)
    n0, n1, n2 = n[0], n[1], n[2]
    for a in range(3):
        n[a] = rot[a, 0] * n0 + rot[a, 1] * n1 + rot[a, 2] * n2
    # h <- rot h rot^T in place, through snapshots of its 9 entries
    hl = (h[0, 0], h[0, 1], h[0, 2], h[1, 0], h[1, 1], h[1, 2], h[2, 0], h[2, 1], h[2, 2])
    for a in range(3):
        for b in range(3):
            h[a, b] = rot[a, 0] * hl[b] + rot[a, 1] * hl[3 + b] + rot[a, 2] * hl[6 + b]
    hl = (h[0, 0], h[0, 1], h[0, 2], h[1, 0], h[1, 1], h[1, 2], h[2, 0], h[2, 1], h[2, 2])
    for a in range(3):
        for b in range(3):
            h[a, b] = hl[3 * a] * rot[b, 0] + hl[3 * a + 1] * rot[b, 1] + hl[3 * a + 2] * rot[b, 2]
    return d


@njit(cache=True)
def bounding_radii(kind, size):
    """:func:`bounding_radius` of each primitive (k,)."""
    out = np.empty(kind.shape[0])
    for j in range(kind.shape[0]):
        out[j] = bounding_radius(kind[j], size[j])
    return out
