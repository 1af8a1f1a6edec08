"""Gap between a capsule edge of the cable and a primitive: the closest parameter t* on the edge, then the point."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .primitives import BOX, CAPSULE, CYLINDER, PLANE, SPHERE, point_distance

LINE_ITERS = 64  # bound on the 1-D search (each halves the bracket at worst: 2^-64 of the edge, far below rounding)


@njit(cache=True)
def _clamp01(v):
    return min(max(v, 0.0), 1.0)


@njit(cache=True)
def _segment_axis(a, b, pos, rot, half):
    """Parameter on [a, b] of a closest pair between [a, b] and the axis pos +- half rot[:, 2] (Ericson, RTCD
    5.1.9)."""
    aa = ee = ff = c = bb = 0.0
    for k in range(3):
        d1 = b[k] - a[k]
        d2 = 2.0 * half * rot[k, 2]
        rr = a[k] - pos[k] + half * rot[k, 2]
        aa += d1 * d1
        ee += d2 * d2
        ff += d2 * rr
        c += d1 * rr
        bb += d1 * d2
    if aa <= 1e-300:
        return 0.0
    if ee <= 1e-300:
        return _clamp01(-c / aa)
    denom = aa * ee - bb * bb
    s = _clamp01((bb * ff - c * ee) / denom) if denom > 0.0 else 0.0  # parallel: any s is a closest one
    t = (bb * s + ff) / ee
    if t < 0.0:
        s = _clamp01(-c / aa)
    elif t > 1.0:
        s = _clamp01((bb - c) / aa)
    return s


@njit(cache=True)
def _slope(a, b, t, kind, pos, rot, size, p, n, h):
    """f'(t) = n . e and f''(t) = e^T H e of f(t) = dist(a + t e), e = b - a."""
    for k in range(3):
        p[k] = a[k] + t * (b[k] - a[k])
    point_distance(kind, pos, rot, size, p, n, h)
    slope = curv = 0.0
    for k in range(3):
        ek = b[k] - a[k]
        slope += n[k] * ek
        curv += ek * (h[k, 0] * (b[0] - a[0]) + h[k, 1] * (b[1] - a[1]) + h[k, 2] * (b[2] - a[2]))
    return slope, curv


@njit(cache=True)
def _convex_line_min(a, b, kind, pos, rot, size, p, n, h):
    """Minimiser on [0, 1] of f(t) = dist(a + t (b - a)): f is convex (a convex set's signed distance is convex along
    a line), so a bracket on the sign of f' with safeguarded Newton steps converges."""
    g0, _ = _slope(a, b, 0.0, kind, pos, rot, size, p, n, h)
    if g0 >= 0.0:
        return 0.0
    g1, _ = _slope(a, b, 1.0, kind, pos, rot, size, p, n, h)
    if g1 <= 0.0:
        return 1.0
    lo, hi = 0.0, 1.0
    t = g0 / (g0 - g1)  # the zero of f' interpolated linearly
    for _ in range(LINE_ITERS):
        g, curv = _slope(a, b, t, kind, pos, rot, size, p, n, h)
        if g > 0.0:
            hi = t
        elif g < 0.0:
            lo = t
        else:
            return t
        if hi - lo <= 1e-13:
            break
        step = -g / curv if curv > 0.0 else np.inf
        if abs(step) <= 1e-13:
            return min(max(t + step, lo), hi)
        t_new = t + step
        t = t_new if lo < t_new < hi else 0.5 * (lo + hi)
    return 0.5 * (lo + hi)


@njit(cache=True)
def segment_closest(a, b, kind, pos, rot, size, p, n, h):
    """Parameter t* in [0, 1] of the point of edge [a, b] nearest to the primitive (p, n, h: scratch (3,), (3,),
    (3, 3)). Closed forms for plane, sphere and capsule; a convex 1-D search for box and cylinder."""
    if kind == PLANE:
        nz0, nz1, nz2 = rot[0, 2], rot[1, 2], rot[2, 2]
        da = (a[0] - pos[0]) * nz0 + (a[1] - pos[1]) * nz1 + (a[2] - pos[2]) * nz2
        db = (b[0] - pos[0]) * nz0 + (b[1] - pos[1]) * nz1 + (b[2] - pos[2]) * nz2
        return 0.0 if da <= db else 1.0  # linear along the edge: an end (the first one on a tie)
    if kind == SPHERE:
        e0, e1, e2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
        ee = e0 * e0 + e1 * e1 + e2 * e2
        if ee <= 1e-300:
            return 0.0
        return _clamp01(((pos[0] - a[0]) * e0 + (pos[1] - a[1]) * e1 + (pos[2] - a[2]) * e2) / ee)
    if kind == CAPSULE:
        return _segment_axis(a, b, pos, rot, size[1])
    return _convex_line_min(a, b, kind, pos, rot, size, p, n, h)


@njit(cache=True)
def segment_gap(a, b, r, kind, pos, rot, size, p, n, h):
    """Gap d between the capsule edge [a, b] of radius r and the primitive (< 0: penetration), and t*.

    On return p = (1 - t*) a + t* b, n = the distance's gradient at p (the contact normal, out of the primitive) and
    h its Hessian at p, so that with t* held fixed dd/dx_i = (1 - t*) n, dd/dx_{i+1} = t* n (exact, by the envelope
    theorem) and d2d/dx2 = w w^T (x) h with w = (1 - t*, t*) (t* held fixed: the true Hessian of the minimum over t
    is smaller by a rank-one term when 0 < t* < 1).
    """
    t = segment_closest(a, b, kind, pos, rot, size, p, n, h)
    for k in range(3):
        p[k] = (1.0 - t) * a[k] + t * b[k]
    d = point_distance(kind, pos, rot, size, p, n, h) - r
    return d, t


@njit(cache=True)
def lower_bound(a, b, r, kind, pos, rot, size, bound):
    """A lower bound of the gap of the edge [a, b] to the primitive, cheap enough to prune every pair with.

    Every point of the edge lies within half its length of its middle m, and a distance is 1-Lipschitz, so the
    primitive's distance at m less that half bounds it; the balls' bound (the primitive's about pos) holds for all
    kinds, and boxes, capsules and cylinders get their own distance at m (a big box's ball bounds nothing near it);
    a plane's is exact (the nearer end's height).
    """
    m0 = 0.5 * (a[0] + b[0]) - pos[0]
    m1 = 0.5 * (a[1] + b[1]) - pos[1]
    m2 = 0.5 * (a[2] + b[2]) - pos[2]
    e0, e1, e2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    half = 0.5 * math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    if kind == PLANE:
        nz0, nz1, nz2 = rot[0, 2], rot[1, 2], rot[2, 2]
        ha = (a[0] - pos[0]) * nz0 + (a[1] - pos[1]) * nz1 + (a[2] - pos[2]) * nz2
        hb = (b[0] - pos[0]) * nz0 + (b[1] - pos[1]) * nz1 + (b[2] - pos[2]) * nz2
        return min(ha, hb) - r
    ball = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2) - half - bound - r
    # the middle in the primitive's frame
    l0 = rot[0, 0] * m0 + rot[1, 0] * m1 + rot[2, 0] * m2
    l1 = rot[0, 1] * m0 + rot[1, 1] * m1 + rot[2, 1] * m2
    l2 = rot[0, 2] * m0 + rot[1, 2] * m1 + rot[2, 2] * m2
    if kind == BOX:
        o0 = max(abs(l0) - size[0], 0.0)
        o1 = max(abs(l1) - size[1], 0.0)
        o2 = max(abs(l2) - size[2], 0.0)
        return max(ball, math.sqrt(o0 * o0 + o1 * o1 + o2 * o2) - half - r)
    if kind == CAPSULE:
        z = min(max(l2, -size[1]), size[1])
        return max(ball, math.sqrt(l0 * l0 + l1 * l1 + (l2 - z) ** 2) - size[0] - half - r)
    if kind == CYLINDER:
        radial = max(math.sqrt(l0 * l0 + l1 * l1) - size[0], 0.0)
        axial = max(abs(l2) - size[1], 0.0)
        return max(ball, math.sqrt(radial * radial + axial * axial) - half - r)
    return ball


# Contacts one (edge, primitive) pair can make (see pair_contacts).
MAX_CONTACTS = 3


@njit(cache=True)
def pair_contacts(a, b, r, kind, pos, rot, size, blend, d, t, w, p, n, h):
    """The contacts of the edge [a, b] with one primitive: their gaps d, edge parameters t and weights w, and each
    one's point p, normal n and distance Hessian h (rows of the (MAX_CONTACTS, ...) arrays given). Returns
    (count, m): m is the end whose gap is the smaller (the blend below needs it), -1 where there is no blend.

    A sphere or capsule touches the edge at its closest point. Flat faces have no closest point to speak of when
    an edge lies flat on them: taken at one end, the contact would jump between the two and a cable resting there
    would never settle. So a plane touches the edge at both ends, each vertex its own contact weighted 1/2 (a
    vertex between two edges counts once); a box or cylinder too, plus the edge's closest point, weighted by how
    far it lies below the nearer end: w = clip((min(d_a, d_b) - d*) / blend, 0, 1). That is 0 where the edge lies
    on a face (d* is an end's gap) and 1 where it hangs over the primitive's edge or rim (the ends away from it),
    continuous in between; the barrier of the three stays infinite at any penetration.
    """
    if kind == PLANE or kind == BOX or kind == CYLINDER:
        for end in range(2):
            for k in range(3):
                p[end, k] = b[k] if end == 1 else a[k]
            d[end] = point_distance(kind, pos, rot, size, p[end], n[end], h[end]) - r
            t[end] = float(end)
            w[end] = 0.5
        if kind == PLANE:  # a plane's distance is linear along the edge: its ends are all of it
            return 2, -1
        d[2], t[2] = segment_gap(a, b, r, kind, pos, rot, size, p[2], n[2], h[2])
        m = 0 if d[0] <= d[1] else 1
        w[2] = min(max((d[m] - d[2]) / blend, 0.0), 1.0)
        return 3, m
    d[0], t[0] = segment_gap(a, b, r, kind, pos, rot, size, p[0], n[0], h[0])
    w[0] = 1.0
    return 1, -1
