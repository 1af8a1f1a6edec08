"""The rod engine's per-vertex SegmentState (bend, twist, strain, contact), as MuJoCo's SegmentStateReader gives it."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..physics.segment_state import SegmentState
from .contact.friction import friction_relag
from .contact.report import contact_report
from .frames import reference_twist, signed_angle, unit_tangents
from .measuring import menger_curvature
from .newton import broad_phase
from .rod import Rod
from .scene import Primitives


@njit(cache=True)
def material_angles(ref, t, span_edges, span_dirs, tau):
    """Material angle theta_e of every edge (m1_e = ref_e turned by theta_e about t_e, right-handed).

    A span's vertices ea < i <= eb each carry its twist tau/(eb - ea) (uniform, as the energy assumes), so
    theta_e - theta_(e-1) = tau/(eb - ea) - m_e with m_e the reference twist; elsewhere the frame is twist-free
    (theta_e - theta_(e-1) = -m_e). The constant is fixed by the nearest clamp edge's angle (ref -> clamp director);
    within a span both clamps give the same one, since span_twists' tau is exactly that sum. With no clamp the
    frame is the twist-free one starting from edge 0's reference director.
    """
    n = t.shape[0]
    rate = np.zeros(n)  # per vertex i (1..n-1; rate[0] unused): material twist between edges i-1 and i
    for s in range(span_edges.shape[0]):
        ea, eb = span_edges[s, 0], span_edges[s, 1]
        for i in range(ea + 1, eb + 1):
            rate[i] = tau[s] / (eb - ea)
    phi = np.zeros(n)  # theta up to a constant
    for e in range(1, n):
        phi[e] = phi[e - 1] + rate[e] - reference_twist(ref, t, e)
    k = span_edges.shape[0]
    if k == 0:
        return phi
    clamp_edge = np.empty(2 * k, np.int64)
    offset = np.empty(2 * k)  # theta - phi at each clamp edge
    for s in range(k):
        for j in range(2):
            c = span_edges[s, j]
            clamp_edge[2 * s + j] = c
            offset[2 * s + j] = signed_angle(ref[c], span_dirs[s, j], t[c]) - phi[c]
    theta = np.empty(n)
    for e in range(n):
        best = 0
        for c in range(1, 2 * k):
            if abs(clamp_edge[c] - e) < abs(clamp_edge[best] - e):
                best = c
        theta[e] = phi[e] + offset[best]
    return theta


@njit(cache=True)
def material_frames(ref, t, span_edges, span_dirs, tau):
    """(n, 3) material director m1 of every edge: ref turned by its material angle (see :func:`material_angles`)
    about t, the Rodrigues turn of a director perpendicular to t, as MuJoCo's reader builds its d1."""
    theta = material_angles(ref, t, span_edges, span_dirs, tau)
    m1 = np.empty_like(ref)
    for e in range(ref.shape[0]):
        c, s = math.cos(theta[e]), math.sin(theta[e])
        t0, t1, t2, r0, r1, r2 = t[e, 0], t[e, 1], t[e, 2], ref[e, 0], ref[e, 1], ref[e, 2]
        m1[e, 0] = c * r0 + s * (t1 * r2 - t2 * r1)
        m1[e, 1] = c * r1 + s * (t2 * r0 - t0 * r2)
        m1[e, 2] = c * r2 + s * (t0 * r1 - t1 * r0)
    return m1


def material_directors(rod: Rod) -> np.ndarray:
    """(n, 3) material director m1 of every edge of ``rod`` (see :func:`material_frames`)."""
    t, _ = unit_tangents(rod.x)
    return material_frames(rod.ref, t, rod.model.span_edges, rod.clamp_directors, rod.twists())


@njit(cache=True)
def vertex_curvatures(x):
    """(n+1,) Menger curvature 2 |e x f| / (|e| |f| |e + f|) of every interior vertex (exact on an arc), 0 at the
    ends, as physics.measures.vertex_curvatures."""
    out = np.zeros(x.shape[0])
    for i in range(1, x.shape[0] - 1):
        out[i] = menger_curvature(x, i)
    return out


@njit(cache=True)
def vertex_bend(x, m1, kappa):
    """(n+1, 2) curvature binormal (direction e_(i-1) x e_i, length the Menger curvature) in each interior
    vertex's material frame (d1, d2 = t_v x d1); 0 at the ends.

    The vertex frame: the mean of the two edges' m1 made perpendicular to the vertex tangent t_v (the sum of the
    edge tangents), so both edges count alike and the binormal, perpendicular to both edges, lies in its plane:
    |bend| = curvature exactly. MuJoCo's reader uses the incoming edge's frame instead; the two differ by half the
    twist increment of the vertex and O(bend angle^2), both vanishing as the resolution grows. A degenerate frame
    (a straight or folded vertex) gives no bend rather than NaN.
    """
    n1 = x.shape[0]
    bend = np.zeros((n1, 2))
    for i in range(1, n1 - 1):
        e0, e1, e2 = x[i, 0] - x[i - 1, 0], x[i, 1] - x[i - 1, 1], x[i, 2] - x[i - 1, 2]
        f0, f1, f2 = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
        le = max(math.sqrt(e0 * e0 + e1 * e1 + e2 * e2), 1e-300)
        lf = max(math.sqrt(f0 * f0 + f1 * f1 + f2 * f2), 1e-300)
        t0, t1, t2 = e0 / le + f0 / lf, e1 / le + f1 / lf, e2 / le + f2 / lf
        ltv = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        b0, b1, b2 = e1 * f2 - e2 * f1, e2 * f0 - e0 * f2, e0 * f1 - e1 * f0
        lb = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
        if ltv < 1e-15 or lb < 1e-15:
            continue
        t0, t1, t2 = t0 / ltv, t1 / ltv, t2 / ltv
        d0, d1, d2 = m1[i - 1, 0] + m1[i, 0], m1[i - 1, 1] + m1[i, 1], m1[i - 1, 2] + m1[i, 2]
        along = d0 * t0 + d1 * t1 + d2 * t2
        d0, d1, d2 = d0 - along * t0, d1 - along * t1, d2 - along * t2
        ld1 = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if ld1 < 1e-15:
            continue
        d0, d1, d2 = d0 / ld1, d1 / ld1, d2 / ld1
        # d2 = t_v x d1
        c0, c1, c2 = t1 * d2 - t2 * d1, t2 * d0 - t0 * d2, t0 * d1 - t1 * d0
        bend[i, 0] = kappa[i] * (b0 * d0 + b1 * d1 + b2 * d2) / lb
        bend[i, 1] = kappa[i] * (b0 * c0 + b1 * c1 + b2 * c2) / lb
    return bend


@njit(cache=True)
def vertex_twist_rates(n1, span_edges, tau, span_len):
    """Twist per length [rad/m] at every vertex: its span's tau/L (``tau`` each span's total twist, L its rest
    length, as Rod.twist_rates) on the span's vertices ea < i <= eb (where the twist lives: between the clamp
    edges), 0 at the others (free ends carry no twist)."""
    out = np.zeros(n1)
    for s in range(span_edges.shape[0]):
        for i in range(span_edges[s, 0] + 1, span_edges[s, 1] + 1):
            out[i] = tau[s] / span_len[s]
    return out


@njit(cache=True)
def vertex_strains(x, rest, held):
    """Axial strain per vertex: each edge's tension/EA split half and half onto its two vertices, the end vertices
    taking their one edge's whole; an edge whose two vertices are both ``held`` (a clamp's own edge) counts as 0,
    as MuJoCo's reader fills a rigid clamp edge's missing tension with 0 (it is set by the holder, not the cable)."""
    n1 = x.shape[0]
    strain = np.zeros(n1)
    for e in range(n1 - 1):
        if held[e] and held[e + 1]:
            continue
        d0, d1, d2 = x[e + 1, 0] - x[e, 0], x[e + 1, 1] - x[e, 1], x[e + 1, 2] - x[e, 2]
        eps = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) / rest[e] - 1.0
        strain[e] += (1.0 if e == 0 else 0.5) * eps
        strain[e + 1] += (1.0 if e == n1 - 2 else 0.5) * eps
    return strain


@njit(cache=True)
def vertex_slip(x, edge, tpar, normal, anchor, h):
    """Per vertex the largest tangential speed |u|/h of the lagged contact pairs it shares (by weight 1 - t*, t*,
    a zero share left out), u the contact point's displacement relative to the touched surface's material point
    over the step (friction_relag's anchor); 0 where nothing touches (MuJoCo's reader: the max over a vertex's
    contacts)."""
    slip = np.zeros(x.shape[0])
    u = np.empty(3)
    for c in range(edge.shape[0]):
        i, t = edge[c], tpar[c]
        for a in range(3):
            u[a] = (1.0 - t) * x[i, a] + t * x[i + 1, a] - anchor[c, a]
        un = u[0] * normal[c, 0] + u[1] * normal[c, 1] + u[2] * normal[c, 2]
        speed = 0.0
        for a in range(3):
            speed += (u[a] - un * normal[c, a]) ** 2
        speed = math.sqrt(speed) / h
        if t < 1.0:
            slip[i] = max(slip[i], speed)
        if t > 0.0:
            slip[i + 1] = max(slip[i + 1], speed)
    return slip


@njit(cache=True)
def segment_arrays(x, x_prev, h, ref, span_edges, span_dirs, span_len, tau, held, rest, r, kind, pos, rot, size,
                   mask, pos_prev, rot_prev, dhat, kappa, mu, eps):
    """:class:`SegmentState`'s arrays in one pass (see :func:`segment_state`; ``h`` 0: no sliding speeds, and
    ``held`` a per-vertex flag)."""
    n1 = x.shape[0]
    curvature = vertex_curvatures(x)
    t, _ = unit_tangents(x)
    bend = vertex_bend(x, material_frames(ref, t, span_edges, span_dirs, tau), curvature)
    twist = vertex_twist_rates(n1, span_edges, tau, span_len)
    strain = vertex_strains(x, rest, held)
    normal, friction, slip = np.zeros(n1), np.zeros(n1), np.zeros(n1)
    if kind.shape[0]:
        # only the pairs within the barrier's reach now carry force (friction too: its set is lagged again at x):
        # the others are left out before the per-pair work
        near = broad_phase(x, (r, kind, pos, rot, size, mask), dhat)[5]
        normal, friction, _, _ = contact_report(x, x_prev, r, kind, pos, rot, size, pos_prev, rot_prev, near, dhat,
                                                kappa, mu, eps)
        if h > 0.0:
            edge, tpar, nrm, _, anchor = friction_relag(x_prev, x, r, kind, pos_prev, rot_prev, size, pos, rot, near,
                                                        dhat, kappa)
            slip = vertex_slip(x, edge, tpar, nrm, anchor, h)
    return curvature, bend, twist, strain, normal, friction, slip


def segment_state(rod: Rod, previous_x: np.ndarray | None, h: float | None, *,
                  previous_primitives: Primitives | None = None) -> SegmentState:
    """The :class:`SegmentState` of ``rod`` now, the engine's counterpart of ``SegmentStateReader.state``.

    ``previous_x`` is the shape at the step's start and ``h`` its length [s]: friction and sliding are those of the
    step from there to ``rod.x`` (the contact set lagged again at ``rod.x``, as the solve's last lag), against the
    primitives moving from ``previous_primitives`` (default: where they are now, ``rod.primitives``: a still scene;
    the rod does not keep its previous primitives, so a caller stepping moving links passes them) to
    ``rod.primitives``. With ``previous_x`` None the step is taken as none: no friction, no sliding (a rest
    state); with ``h`` None friction is reported but sliding speeds are 0.
    """
    prims = rod.primitives
    # primitives of another set (none before the first solve) stand still: a step against them cannot be read
    before = prims if previous_primitives is None or len(previous_primitives) != len(prims) else previous_primitives
    x_prev = rod.x if previous_x is None else np.ascontiguousarray(previous_x, dtype=float)
    sliding = previous_x is not None and h is not None and h > 0 and math.isfinite(h)
    held_vertices, rest, *_, span_edges, span_len, _ = rod.step_constants
    held = np.zeros(len(rod.x), dtype=np.bool_)
    held[held_vertices] = True
    c = rod.contact
    return SegmentState(*segment_arrays(
        rod.x, x_prev, float(h) if sliding else 0.0, rod.ref, span_edges, rod.clamp_directors, span_len,
        rod.twists(), held, rest, rod.radius, prims.kind, prims.pos, prims.rot, prims.size, prims.mask, before.pos,
        before.rot, c.activation, c.stiffness, c.friction, c.slip))
