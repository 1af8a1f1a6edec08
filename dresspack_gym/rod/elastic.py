"""The rod's elastic energy (stretch, bend, quasi-static twist) with its analytic gradient and Hessian blocks.

Discrete elastic rods (Bergou et al. 2008) for an isotropic, straight-at-rest cable:
- stretch of edge e: EA/(2 l0) (l - l0)^2;
- bend at interior vertex i: EI |kb_i|^2 / (2 lv_i), kb = 2 e x f / (|e||f| + e.f), lv the rest Voronoi length;
  with P = |e||f| and s = e.f this is 2 EI/lv (P - s)/(P + s) = 2 EI/lv tan^2(phi/2), whose Hessian follows by the
  chain rule through the two scalars;
- twist: with no twist inertia an isotropic rod's twist is uniform between two clamps that hold its material frame
  (Bergou et al. 2008, section 7), so a span of rest length L holding total twist tau stores GJ tau^2 / (2 L);
  tau = the far clamp's material angle - the near one's + the reference twists between them. Its gradient is
  dense over the span: the solver adds GJ/L grad(tau) grad(tau)^T as a rank-one term, the rest is banded.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .frames import cross3, dot3, norm3, signed_angle, transport

# Half-bandwidth (lower) of the Hessian in coordinates: a bend couples three consecutive vertices (9 coordinates).
KD = 8


@njit(cache=True)
def stretch_edge(e, l0, ea, exact):
    """Energy, gradient (3,) and Hessian (3x3) of one edge vector ``e`` of rest length ``l0``."""
    ln = norm3(e)
    t = e / ln
    k = ea / l0
    energy = 0.5 * k * (ln - l0) ** 2
    grad = k * (ln - l0) * t
    lateral = 1.0 - l0 / ln
    if not exact and lateral < 0.0:  # a compressed edge's lateral term is negative: dropped where PD is needed
        lateral = 0.0
    hess = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            tt = t[a] * t[b]
            hess[a, b] = k * (tt + lateral * ((1.0 if a == b else 0.0) - tt))
    return energy, grad, hess


@njit(cache=True)
def bend_vertex(e, f, coeff, exact):
    """Energy, gradient (6,) over (e, f) and Hessian (6x6) of the bend between edges ``e`` and ``f``:
    coeff (P - s)/(P + s) with coeff = 2 EI / lv. ``exact`` False gives the Gauss-Newton Hessian
    coeff/2 J^T J of |kb|^2 (always positive semi-definite)."""
    le, lf = norm3(e), norm3(f)
    te, tf = e / le, f / lf
    p = le * lf
    s = dot3(e, f)
    q = p + s
    energy = coeff * (p - s) / q
    g_p = 2.0 * coeff * s / (q * q)
    g_s = -2.0 * coeff * p / (q * q)
    dp = np.empty(6)
    ds = np.empty(6)
    for a in range(3):
        dp[a], dp[3 + a] = lf * te[a], le * tf[a]
        ds[a], ds[3 + a] = f[a], e[a]
    grad = g_p * dp + g_s * ds
    hess = np.zeros((6, 6))
    if exact:
        q3 = q * q * q
        g_pp = -4.0 * coeff * s / q3
        g_ss = 4.0 * coeff * p / q3
        g_ps = 2.0 * coeff * (p - s) / q3
        for a in range(6):
            for b in range(6):
                hess[a, b] = (g_pp * dp[a] * dp[b] + g_ss * ds[a] * ds[b]
                              + g_ps * (dp[a] * ds[b] + ds[a] * dp[b]))
        for a in range(3):
            for b in range(3):
                eye = 1.0 if a == b else 0.0
                hess[a, b] += g_p * lf / le * (eye - te[a] * te[b])
                hess[3 + a, 3 + b] += g_p * le / lf * (eye - tf[a] * tf[b])
                cross_term = g_p * te[a] * tf[b] + g_s * eye
                hess[a, 3 + b] += cross_term
                hess[3 + b, a] += cross_term
    else:
        jac = curvature_binormal_jacobian(e, f)  # (3, 6)
        half = 0.5 * coeff  # E = coeff/4 |kb|^2  ->  Gauss-Newton: coeff/2 J^T J
        for a in range(6):
            for b in range(6):
                acc = 0.0
                for c in range(3):
                    acc += jac[c, a] * jac[c, b]
                hess[a, b] = half * acc
    return energy, grad, hess


@njit(cache=True)
def curvature_binormal(e, f):
    return 2.0 * cross3(e, f) / (norm3(e) * norm3(f) + dot3(e, f))


@njit(cache=True)
def _skew(v, a, b) -> float:
    """Entry (a, b) of the cross-product matrix [v]x (so that [v]x w = v x w)."""
    if a == b:
        return 0.0
    c = 3 - a - b
    sign = 1.0 if (b - a) % 3 == 1 else -1.0  # (0,1), (1,2), (2,0): -v_c ; the others +v_c
    return -sign * v[c]


@njit(cache=True)
def curvature_binormal_jacobian(e, f):
    """d kb / d(e, f), shape (3, 6): kb = 2 c / D with c = e x f, D = |e||f| + e.f."""
    le, lf = norm3(e), norm3(f)
    d = le * lf + dot3(e, f)
    kb = 2.0 * cross3(e, f) / d
    dd_e = lf * e / le + f
    dd_f = le * f / lf + e
    jac = np.empty((3, 6))
    # d(e x f)/de = -[f]x, d(e x f)/df = [e]x, written entry by entry ([v]x[a, b] = -eps_abc v_c)
    for a in range(3):
        for b in range(3):
            jac[a, b] = (-2.0 * _skew(f, a, b) - kb[a] * dd_e[b]) / d
            jac[a, 3 + b] = (2.0 * _skew(e, a, b) - kb[a] * dd_f[b]) / d
    return jac


@njit(cache=True)
def twist_vertex(e, f):
    """Gradient (6,) over (e, f) and Hessian (6x6) of the reference twist at the vertex between edges e and f
    (time-parallel reference frames): dm/de = kb/(2|e|), dm/df = kb/(2|f|)."""
    le, lf = norm3(e), norm3(f)
    te, tf = e / le, f / lf
    chi = 1.0 + dot3(te, tf)
    tt = (te + tf) / chi
    kb = 2.0 * cross3(e, f) / (le * lf + dot3(e, f))
    grad = np.empty(6)
    for a in range(3):
        grad[a] = 0.5 * kb[a] / le
        grad[3 + a] = 0.5 * kb[a] / lf
    hess = np.empty((6, 6))
    for a in range(3):
        for b in range(3):
            hess[a, b] = -0.25 / (le * le) * (kb[a] * (te[b] + tt[b]) + (te[a] + tt[a]) * kb[b])
            hess[3 + a, 3 + b] = -0.25 / (lf * lf) * (kb[a] * (tf[b] + tt[b]) + (tf[a] + tt[a]) * kb[b])
    for a in range(3):
        for b in range(3):
            v = 0.5 / (le * lf) * (2.0 / chi * _skew(te, a, b) - kb[a] * tt[b])
            hess[a, 3 + b] = v
            hess[3 + b, a] = v
    return grad, hess


@njit(cache=True)
def edges_to_vertices_grad(g6):
    """(e, f) gradient -> gradient over (x_{i-1}, x_i, x_{i+1}) with e = x_i - x_{i-1}, f = x_{i+1} - x_i."""
    out = np.empty(9)
    for a in range(3):
        out[a] = -g6[a]
        out[3 + a] = g6[a] - g6[3 + a]
        out[6 + a] = g6[3 + a]
    return out


# d(e, f) / d(x_{i-1}, x_i, x_{i+1}) per edge (rows) and vertex (columns): e = x_i - x_{i-1}, f = x_{i+1} - x_i
_EDGE_OF_VERTEX = np.array([[-1.0, 1.0, 0.0], [0.0, -1.0, 1.0]])


@njit(cache=True)
def edges_to_vertices_hess(h6):
    """(e, f) Hessian -> Hessian over (x_{i-1}, x_i, x_{i+1}): J^T H J with J = _EDGE_OF_VERTEX (x) I3, written
    out (a BLAS call per vertex costs more than the arithmetic)."""
    jac = _EDGE_OF_VERTEX
    out = np.zeros((9, 9))
    for va in range(3):
        for vb in range(3):
            for p in range(2):
                ja = jac[p, va]
                if ja == 0.0:
                    continue
                for q in range(2):
                    w = ja * jac[q, vb]
                    if w == 0.0:
                        continue
                    for i in range(3):
                        for j in range(3):
                            out[3 * va + i, 3 * vb + j] += w * h6[3 * p + i, 3 * q + j]
    return out


@njit(cache=True)
def span_twists(x, ref, t, span_edges, span_dirs):
    """Total twist of every clamped span: the far clamp's material angle minus the near one's plus the reference
    twists between them. ``span_edges`` (k, 2) clamp edges; ``span_dirs`` (k, 2, 3) the clamps' material directors."""
    k = span_edges.shape[0]
    tau = np.zeros(k)
    for s in range(k):
        ea, eb = span_edges[s, 0], span_edges[s, 1]
        theta_a = signed_angle(ref[ea], span_dirs[s, 0], t[ea])
        theta_b = signed_angle(ref[eb], span_dirs[s, 1], t[eb])
        acc = theta_b - theta_a
        for i in range(ea + 1, eb + 1):
            acc += reference_twist(ref, t, i)
        tau[s] = acc
    return tau


@njit(cache=True)
def reference_twist(ref, t, i):
    carried = transport(ref[i - 1], t[i - 1], t[i])
    return signed_angle(carried, ref[i], t[i])


@njit(cache=True)
def add_block(band, c0, block):
    """Add a symmetric block whose first coordinate is ``c0`` into the lower band matrix."""
    m = block.shape[0]
    for a in range(m):
        for b in range(a + 1):
            band[a - b, c0 + b] += block[a, b]


@njit(cache=True)
def elastic(x, ref, t, lengths, rest, voronoi, ea, ei, gj, span_edges, span_dirs, span_len,
            want_derivatives, exact, grad, band, twist_dirs):
    """Stretch + bend + twist energy of ``x``; with ``want_derivatives`` adds the gradient to ``grad`` (n+1, 3),
    the banded Hessian to ``band`` and writes each span's d tau / dx into ``twist_dirs`` (k, n+1, 3).
    Returns (energy, tau per span)."""
    n = x.shape[0] - 1
    energy = 0.0
    for e in range(n):
        d = x[e + 1] - x[e]
        en, g3, h3 = stretch_edge(d, rest[e], ea, exact)
        energy += en
        if want_derivatives:
            for a in range(3):
                grad[e, a] -= g3[a]
                grad[e + 1, a] += g3[a]
            blk = np.empty((6, 6))
            for a in range(3):
                for b in range(3):
                    blk[a, b] = h3[a, b]
                    blk[3 + a, 3 + b] = h3[a, b]
                    blk[a, 3 + b] = -h3[a, b]
                    blk[3 + a, b] = -h3[a, b]
            add_block(band, 3 * e, blk)
    k = span_edges.shape[0]
    tau = span_twists(x, ref, t, span_edges, span_dirs)
    span_of = np.full(n + 1, -1)  # the span whose twist each interior vertex carries (clamps bound the spans)
    for s in range(k):
        energy += 0.5 * gj * tau[s] ** 2 / span_len[s]
        for i in range(span_edges[s, 0] + 1, span_edges[s, 1] + 1):
            span_of[i] = s
    for i in range(1, n):
        e_vec = x[i] - x[i - 1]
        f_vec = x[i + 1] - x[i]
        en, g6, h6 = bend_vertex(e_vec, f_vec, 2.0 * ei / voronoi[i], exact)
        energy += en
        if not want_derivatives:
            continue
        s = span_of[i]
        if s >= 0:
            weight = gj * tau[s] / span_len[s]
            tg6, th6 = twist_vertex(e_vec, f_vec)
            for a in range(6):
                g6[a] += weight * tg6[a]
                if exact:
                    for b in range(6):
                        h6[a, b] += weight * th6[a, b]
            tv = edges_to_vertices_grad(tg6)
            for a in range(9):
                twist_dirs[s, i - 1 + a // 3, a % 3] += tv[a]
        gv = edges_to_vertices_grad(g6)
        for a in range(9):
            grad[i - 1 + a // 3, a % 3] += gv[a]
        add_block(band, 3 * (i - 1), edges_to_vertices_hess(h6))
    return energy, tau
