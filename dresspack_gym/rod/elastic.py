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

from .frames import cross3, dot3, norm3, reference_twist, signed_angle

# Half-bandwidth (lower) of the Hessian in coordinates: a bend couples three consecutive vertices (9 coordinates).
KD = 8


@njit(cache=True)
def stretch_into(e, l0, ea, exact, grad3, hess3):
    """Energy of one edge vector ``e`` of rest length ``l0``; its gradient into ``grad3``, Hessian into ``hess3``."""
    ln = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    k = ea / l0
    lateral = 1.0 - l0 / ln
    if not exact and lateral < 0.0:  # a compressed edge's lateral term is negative: dropped where PD is needed
        lateral = 0.0
    for a in range(3):
        ta = e[a] / ln
        grad3[a] = k * (ln - l0) * ta
        for b in range(3):
            tt = ta * e[b] / ln
            hess3[a, b] = k * (tt + lateral * ((1.0 if a == b else 0.0) - tt))
    return 0.5 * k * (ln - l0) ** 2


@njit(cache=True)
def stretch_edge(e, l0, ea, exact):
    """Energy, gradient (3,) and Hessian (3x3) of one edge vector ``e`` of rest length ``l0``."""
    grad, hess = np.empty(3), np.empty((3, 3))
    energy = stretch_into(e, l0, ea, exact, grad, hess)
    return energy, grad, hess


@njit(cache=True)
def bend_into(e, f, coeff, exact, grad6, hess6, jac):
    """Energy coeff (P - s)/(P + s) of the bend between edges ``e`` and ``f`` (coeff = 2 EI / lv); gradient over
    (e, f) into ``grad6``, Hessian into ``hess6`` (``exact`` False: the Gauss-Newton Hessian coeff/2 J^T J of
    |kb|^2, always positive semi-definite; ``jac`` (3, 6) scratch)."""
    le = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    lf = math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2])
    p = le * lf
    s = e[0] * f[0] + e[1] * f[1] + e[2] * f[2]
    q = p + s
    g_p = 2.0 * coeff * s / (q * q)
    g_s = -2.0 * coeff * p / (q * q)
    # dP/d(e, f) = (|f| e/|e|, |e| f/|f|), ds/d(e, f) = (f, e)
    for a in range(3):
        grad6[a] = g_p * lf * e[a] / le + g_s * f[a]
        grad6[3 + a] = g_p * le * f[a] / lf + g_s * e[a]
    if exact:
        q3 = q * q * q
        g_pp = -4.0 * coeff * s / q3
        g_ss = 4.0 * coeff * p / q3
        g_ps = 2.0 * coeff * (p - s) / q3
        dp = jac[0]  # scratch rows: dP and ds over (e, f)
        ds = jac[1]
        for a in range(3):
            dp[a] = lf * e[a] / le
            dp[3 + a] = le * f[a] / lf
            ds[a] = f[a]
            ds[3 + a] = e[a]
        for a in range(6):
            for b in range(a + 1):
                v = g_pp * dp[a] * dp[b] + g_ss * ds[a] * ds[b] + g_ps * (dp[a] * ds[b] + ds[a] * dp[b])
                hess6[a, b] = v
                hess6[b, a] = v
        ce = g_p * lf / le
        cf = g_p * le / lf
        cx = g_p / (le * lf)
        for a in range(3):
            for b in range(3):
                eye = 1.0 if a == b else 0.0
                hess6[a, b] += ce * (eye - e[a] * e[b] / (le * le))
                hess6[3 + a, 3 + b] += cf * (eye - f[a] * f[b] / (lf * lf))
                cross_term = cx * e[a] * f[b] + g_s * eye
                hess6[a, 3 + b] += cross_term
                hess6[3 + b, a] += cross_term
    else:
        binormal_jacobian_into(e, f, jac)
        half = 0.5 * coeff  # E = coeff/4 |kb|^2  ->  Gauss-Newton: coeff/2 J^T J
        for a in range(6):
            for b in range(6):
                hess6[a, b] = half * (jac[0, a] * jac[0, b] + jac[1, a] * jac[1, b] + jac[2, a] * jac[2, b])
    return coeff * (p - s) / q


@njit(cache=True)
def bend_vertex(e, f, coeff, exact):
    """Energy, gradient (6,) over (e, f) and Hessian (6x6) of :func:`bend_into`."""
    grad, hess, jac = np.empty(6), np.empty((6, 6)), np.empty((3, 6))
    energy = bend_into(e, f, coeff, exact, grad, hess, jac)
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
def binormal_jacobian_into(e, f, jac):
    """d kb / d(e, f) into ``jac`` (3, 6): kb = 2 c / D with c = e x f, D = |e||f| + e.f."""
    le = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    lf = math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2])
    d = le * lf + e[0] * f[0] + e[1] * f[1] + e[2] * f[2]
    c0, c1, c2 = e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0]
    for a in range(3):
        kb = 2.0 * (c0 if a == 0 else (c1 if a == 1 else c2)) / d
        for b in range(3):
            # d(e x f)/de = -[f]x, d(e x f)/df = [e]x
            jac[a, b] = (-2.0 * _skew(f, a, b) - kb * (lf * e[b] / le + f[b])) / d
            jac[a, 3 + b] = (2.0 * _skew(e, a, b) - kb * (le * f[b] / lf + e[b])) / d


@njit(cache=True)
def curvature_binormal_jacobian(e, f):
    jac = np.empty((3, 6))
    binormal_jacobian_into(e, f, jac)
    return jac


@njit(cache=True)
def twist_into(e, f, grad6, hess6):
    """Gradient over (e, f) into ``grad6`` and Hessian into ``hess6`` of the reference twist at the vertex between
    edges e and f (time-parallel reference frames): dm/de = kb/(2|e|), dm/df = kb/(2|f|)."""
    le = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    lf = math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2])
    dot = e[0] * f[0] + e[1] * f[1] + e[2] * f[2]
    chi = 1.0 + dot / (le * lf)
    d = le * lf + dot
    c = (e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0])
    kb = (2.0 * c[0] / d, 2.0 * c[1] / d, 2.0 * c[2] / d)
    te = (e[0] / le, e[1] / le, e[2] / le)
    tf = (f[0] / lf, f[1] / lf, f[2] / lf)
    tt = ((te[0] + tf[0]) / chi, (te[1] + tf[1]) / chi, (te[2] + tf[2]) / chi)
    see, sff, sef, sx = -0.25 / (le * le), -0.25 / (lf * lf), 0.5 / (le * lf), 2.0 / (chi * le)
    for a in range(3):
        grad6[a] = 0.5 * kb[a] / le
        grad6[3 + a] = 0.5 * kb[a] / lf
        for b in range(3):
            hess6[a, b] = see * (kb[a] * (te[b] + tt[b]) + (te[a] + tt[a]) * kb[b])
            hess6[3 + a, 3 + b] = sff * (kb[a] * (tf[b] + tt[b]) + (tf[a] + tt[a]) * kb[b])
            v = sef * (sx * _skew(e, a, b) - kb[a] * tt[b])
            hess6[a, 3 + b] = v
            hess6[3 + b, a] = v


@njit(cache=True)
def twist_vertex(e, f):
    grad, hess = np.empty(6), np.empty((6, 6))
    twist_into(e, f, grad, hess)
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


@njit(cache=True)
def vertex_block(h6, va, vb, i, j) -> float:
    """Entry (3 va + i, 3 vb + j) of the Hessian over (x_{i-1}, x_i, x_{i+1}) from the (e, f) Hessian ``h6``:
    J^T H J with e = x_i - x_{i-1}, f = x_{i+1} - x_i, written out per vertex pair."""
    ee, ef, fe, ff = h6[i, j], h6[i, 3 + j], h6[3 + i, j], h6[3 + i, 3 + j]
    if va == 0:
        return ee if vb == 0 else (-ee + ef if vb == 1 else -ef)
    if va == 1:
        return -ee + fe if vb == 0 else (ee - ef - fe + ff if vb == 1 else ef - ff)
    return -fe if vb == 0 else (fe - ff if vb == 1 else ff)


@njit(cache=True)
def edges_to_vertices_hess(h6):
    """(e, f) Hessian -> Hessian over (x_{i-1}, x_i, x_{i+1})."""
    out = np.empty((9, 9))
    for va in range(3):
        for vb in range(3):
            for i in range(3):
                for j in range(3):
                    out[3 * va + i, 3 * vb + j] = vertex_block(h6, va, vb, i, j)
    return out


@njit(cache=True)
def add_vertex_hess(band, c0, h6):
    """Add the vertex-space Hessian of the (e, f) Hessian ``h6`` (first coordinate ``c0``) into the lower band:
    J^T H J with e = x_i - x_{i-1}, f = x_{i+1} - x_i, block by block (vertex_block's entries, written out)."""
    for i in range(3):
        for j in range(3):
            ee, ef, fe, ff = h6[i, j], h6[i, 3 + j], h6[3 + i, j], h6[3 + i, 3 + j]
            # (va, vb) blocks of the lower triangle: (0,0) ee; (1,0) fe - ee; (1,1) ee - ef - fe + ff; (2,0) -fe;
            # (2,1) fe - ff; (2,2) ff
            if i >= j:
                band[i - j, c0 + j] += ee
                band[i - j, c0 + 3 + j] += ee - ef - fe + ff
                band[i - j, c0 + 6 + j] += ff
            band[3 + i - j, c0 + j] += fe - ee
            band[6 + i - j, c0 + j] -= fe
            band[3 + i - j, c0 + 3 + j] += fe - ff


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
def elastic(x, ref, t, lengths, rest, voronoi, ea, ei, gj, span_edges, span_dirs, span_len,
            want_derivatives, exact, grad, band, twist_dirs):
    """Stretch + bend + twist energy of ``x``; with ``want_derivatives`` adds the gradient to ``grad`` (n+1, 3),
    the banded Hessian to ``band`` and writes each span's d tau / dx into ``twist_dirs`` (k, n+1, 3).
    Returns (energy, tau per span)."""
    n = x.shape[0] - 1
    energy = 0.0
    e_vec = np.empty(3)
    f_vec = np.empty(3)
    g3 = np.empty(3)
    h3 = np.empty((3, 3))
    g6 = np.empty(6)
    h6 = np.empty((6, 6))
    tg6 = np.empty(6)
    th6 = np.empty((6, 6))
    jac = np.empty((3, 6))
    for e in range(n):
        for a in range(3):
            e_vec[a] = x[e + 1, a] - x[e, a]
        energy += stretch_into(e_vec, rest[e], ea, exact, g3, h3)
        if want_derivatives:
            c0 = 3 * e
            for a in range(3):
                grad[e, a] -= g3[a]
                grad[e + 1, a] += g3[a]
                for b in range(a + 1):  # the block [[H, -H], [-H, H]], lower part
                    band[a - b, c0 + b] += h3[a, b]
                    band[a - b, c0 + 3 + b] += h3[a, b]
                for b in range(3):
                    band[3 + a - b, c0 + b] -= h3[a, b]
    k = span_edges.shape[0]
    tau = span_twists(x, ref, t, span_edges, span_dirs)
    span_of = np.full(n + 1, -1)  # the span whose twist each interior vertex carries (clamps bound the spans)
    for s in range(k):
        energy += 0.5 * gj * tau[s] ** 2 / span_len[s]
        for i in range(span_edges[s, 0] + 1, span_edges[s, 1] + 1):
            span_of[i] = s
    for i in range(1, n):
        for a in range(3):
            e_vec[a] = x[i, a] - x[i - 1, a]
            f_vec[a] = x[i + 1, a] - x[i, a]
        if not want_derivatives:  # the line search's energy alone: coeff (P - s) / (P + s)
            p = math.sqrt(e_vec @ e_vec) * math.sqrt(f_vec @ f_vec)
            s_dot = e_vec @ f_vec
            energy += 2.0 * ei / voronoi[i] * (p - s_dot) / (p + s_dot)
            continue
        energy += bend_into(e_vec, f_vec, 2.0 * ei / voronoi[i], exact, g6, h6, jac)
        s = span_of[i]
        if s >= 0:
            weight = gj * tau[s] / span_len[s]
            twist_into(e_vec, f_vec, tg6, th6)
            for a in range(6):
                g6[a] += weight * tg6[a]
                if exact:
                    for b in range(6):
                        h6[a, b] += weight * th6[a, b]
            for a in range(3):
                twist_dirs[s, i - 1, a] -= tg6[a]
                twist_dirs[s, i, a] += tg6[a] - tg6[3 + a]
                twist_dirs[s, i + 1, a] += tg6[3 + a]
        for a in range(3):
            grad[i - 1, a] -= g6[a]
            grad[i, a] += g6[a] - g6[3 + a]
            grad[i + 1, a] += g6[3 + a]
        add_vertex_hess(band, 3 * (i - 1), h6)
    return energy, tau
