"""Small vector kernels of the rod engine: cross products, parallel transport and signed angles about an axis."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def cross3(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@njit(cache=True)
def dot3(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def norm3(a) -> float:
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@njit(cache=True)
def transport(v, t0, t1):
    """Parallel transport of ``v`` from unit tangent ``t0`` to unit tangent ``t1``: the rotation about t0 x t1
    taking t0 to t1 (Rodrigues). Antiparallel tangents have no unique transport; the rod never turns an edge by
    pi within one Newton step, so that case keeps ``v`` made orthogonal to t1."""
    b = cross3(t0, t1)
    s = norm3(b)
    c = dot3(t0, t1)
    if s < 1e-14:
        if c > 0.0:
            return v.copy()
        w = v - dot3(v, t1) * t1
        return w / max(norm3(w), 1e-300)
    k = b / s
    return v * c + cross3(k, v) * s + k * dot3(k, v) * (1.0 - c)


@njit(cache=True)
def signed_angle(u, v, axis) -> float:
    """Angle from ``u`` to ``v`` about ``axis`` (right-handed), both taken perpendicular to the unit axis."""
    return math.atan2(dot3(cross3(u, v), axis), dot3(u, v))


@njit(cache=True)
def unit_tangents(x):
    """(n, 3) unit edge tangents and (n,) lengths of the polyline ``x`` (n+1, 3)."""
    n = x.shape[0] - 1
    t = np.empty((n, 3))
    lengths = np.empty(n)
    for e in range(n):
        d = x[e + 1] - x[e]
        ln = norm3(d)
        lengths[e] = ln
        t[e] = d / max(ln, 1e-300)
    return t, lengths


@njit(cache=True)
def transport_frames(ref, t_old, t_new):
    """Each edge's reference director carried in time from its old tangent to its new one (time-parallel)."""
    out = np.empty_like(ref)
    for e in range(ref.shape[0]):
        out[e] = transport(ref[e], t_old[e], t_new[e])
    return out


@njit(cache=True)
def reference_twist(ref, t, i) -> float:
    """The angle about t_i from edge i-1's director, transported in space onto edge i, to edge i's director."""
    a0, a1, a2 = t[i - 1, 0], t[i - 1, 1], t[i - 1, 2]
    b0, b1, b2 = t[i, 0], t[i, 1], t[i, 2]
    v0, v1, v2 = ref[i - 1, 0], ref[i - 1, 1], ref[i - 1, 2]
    k0, k1, k2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0  # t_{i-1} x t_i
    sn = math.sqrt(k0 * k0 + k1 * k1 + k2 * k2)
    cs = a0 * b0 + a1 * b1 + a2 * b2
    if sn > 1e-14:  # Rodrigues about the unit axis k by the angle between the tangents
        k0, k1, k2 = k0 / sn, k1 / sn, k2 / sn
        kv = k0 * v0 + k1 * v1 + k2 * v2
        c0, c1, c2 = k1 * v2 - k2 * v1, k2 * v0 - k0 * v2, k0 * v1 - k1 * v0
        v0, v1, v2 = v0 * cs + c0 * sn + k0 * kv * (1 - cs), v1 * cs + c1 * sn + k1 * kv * (1 - cs), \
            v2 * cs + c2 * sn + k2 * kv * (1 - cs)
    w0, w1, w2 = ref[i, 0], ref[i, 1], ref[i, 2]
    x0, x1, x2 = v1 * w2 - v2 * w1, v2 * w0 - v0 * w2, v0 * w1 - v1 * w0
    return math.atan2(x0 * b0 + x1 * b1 + x2 * b2, v0 * w0 + v1 * w1 + v2 * w2)


@njit(cache=True)
def reference_twists(ref, t):
    """Reference twist m_i at every interior vertex i (1..n-1), 0 at the ends (see :func:`reference_twist`)."""
    n = t.shape[0]
    m = np.zeros(n + 1)
    for i in range(1, n):
        m[i] = reference_twist(ref, t, i)
    return m
