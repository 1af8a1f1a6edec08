"""The rod engine's per-vertex SegmentState (bend, twist, strain, contact), as MuJoCo's SegmentStateReader gives it."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..physics.measures import cross, vertex_curvatures
from ..physics.segment_state import SegmentState
from .contact.friction import friction_lag
from .contact.report import contact_report
from .frames import reference_twist, signed_angle, unit_tangents
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


def _unit(v: np.ndarray) -> np.ndarray:
    """Rows of ``v`` normalised (a zero row stays zero: a degenerate frame gives no bend rather than NaN)."""
    norm = np.linalg.norm(v, axis=1, keepdims=True)
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 1e-15)


def _twists(rod: Rod) -> tuple[np.ndarray, np.ndarray]:
    """(unit edge tangents, each span's total twist, as Rod.twists gives it)."""
    t, _ = unit_tangents(rod.x)
    return t, rod.twists()


def material_directors(rod: Rod, twists: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """(n, 3) material director m1 of every edge (see :func:`material_angles`); ``twists``: :func:`_twists`."""
    t, tau = _twists(rod) if twists is None else twists
    theta = material_angles(rod.ref, t, rod.model.span_edges, rod.clamp_directors, tau)
    # the Rodrigues turn about t of a director perpendicular to t, as MuJoCo's reader builds its d1
    return np.cos(theta)[:, None] * rod.ref + np.sin(theta)[:, None] * cross(t, rod.ref)


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
        e = x[i] - x[i - 1]
        f = x[i + 1] - x[i]
        le, lf = math.sqrt(e @ e), math.sqrt(f @ f)
        tv = e / max(le, 1e-300) + f / max(lf, 1e-300)
        ltv = math.sqrt(tv @ tv)
        b = np.array([e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0]])
        lb = math.sqrt(b @ b)
        if ltv < 1e-15 or lb < 1e-15:
            continue
        tv /= ltv
        d1 = m1[i - 1] + m1[i]
        d1 = d1 - (d1 @ tv) * tv
        ld1 = math.sqrt(d1 @ d1)
        if ld1 < 1e-15:
            continue
        d1 /= ld1
        d2 = np.array([tv[1] * d1[2] - tv[2] * d1[1], tv[2] * d1[0] - tv[0] * d1[2], tv[0] * d1[1] - tv[1] * d1[0]])
        bend[i, 0] = kappa[i] * (b @ d1) / lb
        bend[i, 1] = kappa[i] * (b @ d2) / lb
    return bend


def vertex_twist_rates(rod: Rod, tau: np.ndarray) -> np.ndarray:
    """Twist per length [rad/m] at every vertex: its span's tau/L (``tau`` each span's total twist, L its rest
    length, as Rod.twist_rates) on the span's vertices ea < i <= eb (where the twist lives: between the clamp
    edges), 0 at the others (free ends carry no twist)."""
    out = np.zeros(len(rod.x))
    spans = rod.model.span_edges
    if len(spans):
        for (ea, eb), rate in zip(spans, tau / rod.model.span_lengths):  # a loop over spans, not vertices
            out[ea + 1:eb + 1] = rate
    return out


def vertex_strains(rod: Rod) -> np.ndarray:
    """Axial strain per vertex: each edge's tension/EA split half and half onto its two vertices, the end vertices
    taking their one edge's whole; an edge whose two vertices are both held (a clamp's own edge) counts as 0, as
    MuJoCo's reader fills a rigid clamp edge's missing tension with 0 (it is set by the holder, not the cable)."""
    model = rod.model
    edge = rod.tensions() / model.tensile_stiffness
    held = np.zeros(len(rod.x), dtype=bool)
    held[model.held_array] = True
    edge = np.where(held[:-1] & held[1:], 0.0, edge)
    strain = np.zeros(len(rod.x))
    strain[:-1] += 0.5 * edge
    strain[1:] += 0.5 * edge
    strain[[0, -1]] *= 2.0
    return strain


def vertex_slip(x: np.ndarray, lag: tuple, h: float) -> np.ndarray:
    """Per vertex the largest tangential speed |u|/h of the lagged contact pairs it shares (by weight 1 - t*, t*,
    a zero share left out), u the contact point's displacement relative to the touched surface's material point
    over the step (friction_lag's anchor); 0 where nothing touches."""
    edge, tpar, normal, _, anchor = lag
    slip = np.zeros(len(x))
    if not len(edge):
        return slip
    u = (1.0 - tpar)[:, None] * x[edge] + tpar[:, None] * x[edge + 1] - anchor
    u -= np.einsum("ij,ij->i", u, normal)[:, None] * normal
    speed = np.linalg.norm(u, axis=1) / h
    # a pair's speed goes to the vertices that carry its force (MuJoCo's reader: the max over a vertex's contacts)
    np.maximum.at(slip, edge, np.where(tpar < 1.0, speed, 0.0))
    np.maximum.at(slip, edge + 1, np.where(tpar > 0.0, speed, 0.0))
    return slip


def segment_state(rod: Rod, previous_x: np.ndarray | None, h: float | None, *,
                  previous_primitives: Primitives | None = None) -> SegmentState:
    """The :class:`SegmentState` of ``rod`` now, the engine's counterpart of ``SegmentStateReader.state``.

    ``previous_x`` is the shape at the step's start and ``h`` its length [s]: friction and sliding are those of the
    step from there to ``rod.x`` (the contact set lagged at ``previous_x``, as the solve lags it), against the
    primitives moving from ``previous_primitives`` (default: where they are now, ``rod.primitives``: a still scene;
    the rod does not keep its previous primitives, so a caller stepping moving links passes them) to
    ``rod.primitives``. With ``previous_x`` None the step is taken as none: no friction, no sliding (a rest
    state); with ``h`` None friction is reported but sliding speeds are 0.
    """
    x = rod.x
    n_v = len(x)
    kappa = np.zeros(n_v)
    kappa[1:-1] = vertex_curvatures(x)
    twists = _twists(rod)
    bend = vertex_bend(x, material_directors(rod, twists), kappa)
    twist = vertex_twist_rates(rod, twists[1])
    strain = vertex_strains(rod)
    normal, friction, slip = np.zeros(n_v), np.zeros(n_v), np.zeros(n_v)
    prims = rod.primitives
    if len(prims):
        before = prims if previous_primitives is None else previous_primitives
        x_prev = x if previous_x is None else np.ascontiguousarray(previous_x, dtype=float)
        c = rod.contact
        # only the pairs within the barrier's reach now or at the step's start carry force: the others are left out
        # before the per-pair work
        near = broad_phase(x, (rod.radius, prims.kind, prims.pos, prims.rot, prims.size, prims.mask), c.activation)[5]
        lagged = broad_phase(x_prev, (rod.radius, prims.kind, before.pos, before.rot, prims.size, prims.mask),
                             c.activation)[5]
        mask = near | lagged
        normal, friction, _, _ = contact_report(x, x_prev, rod.radius, prims.kind, prims.pos, prims.rot, prims.size,
                                                before.pos, before.rot, mask, c.activation, c.stiffness,
                                                c.friction, c.slip)
        if previous_x is not None and h is not None and h > 0 and math.isfinite(h):
            lag = friction_lag(x_prev, rod.radius, prims.kind, before.pos, before.rot, prims.size, prims.pos,
                               prims.rot, lagged, c.activation, c.stiffness)
            slip = vertex_slip(x, lag, h)
    return SegmentState(kappa, bend, twist, strain, normal, friction, slip)
