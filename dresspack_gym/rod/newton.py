"""One implicit step of a rod (or its static equilibrium) by projected Newton on the incremental potential.

The step minimises elastic + gravity energy + m/(2 h^2)|x - x0 - h v0|^2 (inertia) + c m/(2 h)|x - x0|^2 (drag):
implicit Euler's update as an energy, so every accepted iterate lowers it and the step cannot blow up. A static
solve drops both terms (h = inf). The Hessian is the exact one while it factors; where it is not positive definite
(a compressed edge, a sharp bend, a span twisted past buckling) the iteration uses its Gauss-Newton part, which is.
The reference frames are re-based on every iterate, so the gradient and Hessian of the twist are exact there.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .band import cholesky, pin, solve_low_rank
from .contact.barrier import barrier_accumulate, barrier_energy
from .contact.ccd import max_step
from .contact.friction import friction_accumulate, friction_energy
from .contact.primitives import bounding_radii
from .contact.segment import lower_bound
from .elastic import KD, elastic
from .frames import transport_frames, unit_tangents
from .recovery import penalty

# Armijo's sufficient-decrease fraction and the energy's round-off allowance relative to its size.
ARMIJO = 1e-4
ROUNDOFF = 1e-13
MAX_HALVINGS = 40
# The broad phase keeps the (edge, primitive) pairs within this many metres of each other at its last update; it is
# redone before any vertex could close that distance less the barrier's reach (so no pair that can touch is left out).
BROAD_MARGIN = 0.05
# Below this decrease (relative to the energy) Newton's step is taken without the energy test.
TRUST_MODEL = 1e-11


@njit(cache=True)
def _held_coords(held):
    out = np.empty(3 * held.shape[0], dtype=np.int64)
    for j in range(held.shape[0]):
        for a in range(3):
            out[3 * j + a] = 3 * held[j] + a
    return out


@njit(cache=True)
def total_energy(x, ref_base, t_base, x_hat, x0, rest, voronoi, mass, ea, ei, gj, gravity, inertia, drag,
                 span_edges, span_dirs, span_len, contact):
    """The incremental potential at ``x``, frames carried from the base iterate (line-search evaluations)."""
    t, lengths = unit_tangents(x)
    for e in range(lengths.shape[0]):
        if not lengths[e] > 0.0:
            return np.inf
    ref = transport_frames(ref_base, t_base, t)
    dummy_g = np.zeros((1, 3))
    dummy_b = np.zeros((1, 1))
    dummy_d = np.zeros((1, 1, 3))
    energy, _ = elastic(x, ref, t, lengths, rest, voronoi, ea, ei, gj, span_edges, span_dirs, span_len,
                        False, True, dummy_g, dummy_b, dummy_d)
    for v in range(x.shape[0]):
        for a in range(3):
            energy -= mass[v] * gravity[a] * x[v, a]
            energy += 0.5 * mass[v] * (inertia * (x[v, a] - x_hat[v, a]) ** 2 + drag * (x[v, a] - x0[v, a]) ** 2)
    return energy + contact_energy(x, contact)


@njit(cache=True)
def contact_energy(x, contact):
    """Barrier + lagged friction energy of ``contact`` (see :func:`newton_step`); inf on any penetration."""
    r, kind, pos, rot, size, mask, dhat, kappa, edge, t, normal, lam, anchor, mu, eps, recovering = contact
    if kind.shape[0] == 0:
        return 0.0
    if recovering:  # the recovery's penalty stands in for the barrier (see recovery.py)
        return penalty(x, r, kind, pos, rot, size, mask, dhat, kappa, False, x, x)
    return barrier_energy(x, r, kind, pos, rot, size, mask, dhat, kappa) + friction_energy(
        x, edge, t, normal, lam, anchor, mu, eps)


@njit(cache=True)
def assemble(x, ref, rest, voronoi, mass, ea, ei, gj, gravity, inertia, drag, x_hat, x0,
             span_edges, span_dirs, span_len, exact, contact):
    """Energy, gradient (n+1, 3), lower band Hessian, span twists and the twist rank-one vectors at ``x``."""
    n1 = x.shape[0]
    t, lengths = unit_tangents(x)
    grad = np.zeros((n1, 3))
    band = np.zeros((KD + 1, 3 * n1))
    dirs = np.zeros((span_edges.shape[0], n1, 3))
    energy, tau = elastic(x, ref, t, lengths, rest, voronoi, ea, ei, gj, span_edges, span_dirs, span_len,
                          True, exact, grad, band, dirs)
    for v in range(n1):
        diag = mass[v] * (inertia + drag)
        for a in range(3):
            energy -= mass[v] * gravity[a] * x[v, a]
            energy += 0.5 * mass[v] * (inertia * (x[v, a] - x_hat[v, a]) ** 2 + drag * (x[v, a] - x0[v, a]) ** 2)
            grad[v, a] += -mass[v] * gravity[a] + mass[v] * (inertia * (x[v, a] - x_hat[v, a])
                                                               + drag * (x[v, a] - x0[v, a]))
            band[0, 3 * v + a] += diag
    r, kind, pos, rot, size, mask, dhat, kappa, edge, tc, normal, lam, anchor, mu, eps, recovering = contact
    if kind.shape[0] > 0 and recovering:
        energy += penalty(x, r, kind, pos, rot, size, mask, dhat, kappa, True, grad, band)
    elif kind.shape[0] > 0:
        energy += barrier_accumulate(x, r, kind, pos, rot, size, mask, dhat, kappa, grad, band, True)
        energy += friction_accumulate(x, edge, tc, normal, lam, anchor, mu, eps, grad, band)
    return energy, grad, band, tau, dirs, t


# Edges per block of the broad phase's first pass: a block's bounding ball against each primitive's prunes most
# pairs of a long cable before any pair's own bound is taken.
BROAD_BLOCK = 8


@njit(cache=True)
def broad_phase(x, contact, margin):
    """``contact`` with its pair mask cut to the pairs whose gap may be below ``margin`` at ``x``: first blocks of
    BROAD_BLOCK edges against whole primitives by their bounding balls (a plane: by the block's lowest vertex),
    then each remaining pair by its gap's lower bound."""
    r, kind, pos, rot, size, mask = contact[0], contact[1], contact[2], contact[3], contact[4], contact[5]
    near = mask.copy()
    bound = bounding_radii(kind, size)
    n_e = x.shape[0] - 1
    for lo in range(0, n_e, BROAD_BLOCK):
        hi = min(lo + BROAD_BLOCK, n_e)  # edges lo .. hi - 1, vertices lo .. hi
        c0, c1, c2 = 0.5 * (x[lo, 0] + x[hi, 0]), 0.5 * (x[lo, 1] + x[hi, 1]), 0.5 * (x[lo, 2] + x[hi, 2])
        spread = 0.0
        for v in range(lo, hi + 1):
            spread = max(spread, math.sqrt((x[v, 0] - c0) ** 2 + (x[v, 1] - c1) ** 2 + (x[v, 2] - c2) ** 2))
        for j in range(kind.shape[0]):
            if kind[j] == 0:  # a plane: the block's lowest vertex above it (exact for every edge in the block)
                low = np.inf
                for v in range(lo, hi + 1):
                    low = min(low, (x[v, 0] - pos[j, 0]) * rot[j, 0, 2] + (x[v, 1] - pos[j, 1]) * rot[j, 1, 2]
                              + (x[v, 2] - pos[j, 2]) * rot[j, 2, 2])
                gap = low - r
            else:
                gap = math.sqrt((pos[j, 0] - c0) ** 2 + (pos[j, 1] - c1) ** 2 + (pos[j, 2] - c2) ** 2) - spread \
                    - bound[j] - r
            if gap >= margin:
                for i in range(lo, hi):
                    near[i, j] = False
                continue
            for i in range(lo, hi):
                if near[i, j] and lower_bound(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j],
                                              bound[j]) >= margin:
                    near[i, j] = False
    return (r, kind, pos, rot, size, near) + contact[6:]


@njit(cache=True)
def inside(x, contact) -> bool:
    """Whether ``x`` lies inside some primitive of ``contact`` (its barrier is infinite there)."""
    if contact[1].shape[0] == 0:
        return False
    return math.isinf(contact_energy(x, broad_phase(x, contact, contact[6])))


@njit(cache=True)
def largest_move(a, b) -> float:
    """The largest distance between a vertex of ``a`` and the same vertex of ``b`` [m]."""
    out = 0.0
    for v in range(a.shape[0]):
        out = max(out, math.sqrt((a[v, 0] - b[v, 0]) ** 2 + (a[v, 1] - b[v, 1]) ** 2 + (a[v, 2] - b[v, 2]) ** 2))
    return out


@njit(cache=True)
def static_gradient(x, ref, rest, voronoi, mass, ea, ei, gj, gravity, span_edges, span_dirs, span_len, contact):
    """Gradient of elastic + gravity + contact energy: minus the net static force on every vertex."""
    zero = np.zeros_like(x)
    _, grad, _, _, _, _ = assemble(x, ref, rest, voronoi, mass, ea, ei, gj, gravity, 0.0, 0.0, zero, zero,
                                   span_edges, span_dirs, span_len, False, contact)
    return grad


@njit(cache=True)
def newton_step(x_start, ref_start, x0, v0, held, held_pos, rest, voronoi, mass, ea, ei, gj, gravity, h, damping,
                span_edges, span_dirs, span_len, force_scale, tolerance, max_iterations, contact, settled_step=0.0,
                start_near=None):
    """Minimise the incremental potential from ``x_start`` (frames ``ref_start`` on the tangents of ``x0``, the last
    state).

    ``held`` vertex indices sit at ``held_pos``; ``h`` the step [s] (inf: static equilibrium), ``damping`` the drag
    rate [1/s]. Converged when every free vertex's net force (including inertia and drag) is below
    ``tolerance`` times ``force_scale[v]`` (its weight). ``contact``: (radius, kind, pos, rot, size, mask, dhat,
    kappa, the lagged friction set (edge, t, normal, lam, anchor), mu, eps, recovering) as :mod:`.contact` takes them
    (``recovering``: the penalty of :mod:`.recovery`, dhat its margin and kappa its stiffness, instead of the
    barrier), the primitives static during the solve; every step is cut by continuous collision detection, so an
    iterate never passes through a primitive. With ``settled_step`` > 0 a full Newton step that moves no vertex that
    far [m] also ends the solve as converged (for motion steps). ``start_near``: the caller's broad phase at the
    start (the pair mask of :func:`broad_phase` at ``x_start``, held vertices placed, margin BROAD_MARGIN), having
    found the start outside every primitive. Returns (x, ref, iterations, residual, converged,
    tau, the static gradient at x).
    """
    n1 = x_start.shape[0]
    inertia = 0.0 if math.isinf(h) else 1.0 / (h * h)
    drag = 0.0 if math.isinf(h) else damping / h
    x_hat = x0.copy() if math.isinf(h) else x0 + h * v0
    # the start: ``x_start`` (the inertial prediction) unless it lies inside a primitive, then the last state; the
    # frames arrive on x0's tangents and are carried to the start's
    full_contact = contact
    margin = BROAD_MARGIN
    dhat = contact[6]
    x = x_start.copy()
    for j in range(held.shape[0]):
        x[held[j]] = held_pos[j]
    # the broad phase's pairs hold every pair the start could be inside (the others are a margin clear of it)
    if start_near is not None:
        contact = full_contact[:5] + (start_near,) + full_contact[6:]
    else:
        contact = broad_phase(x, full_contact, margin)
    if start_near is None and math.isinf(contact_energy(x, contact)):
        x = x0.copy()
        for j in range(held.shape[0]):
            x[held[j]] = held_pos[j]
        contact = broad_phase(x, full_contact, margin)
    broad_at = x.copy()
    t_now, _ = unit_tangents(x)
    t_base, _ = unit_tangents(x0)
    ref = transport_frames(ref_start, t_base, t_now)
    coords = _held_coords(held)
    free = np.ones(n1, dtype=np.bool_)
    for j in range(held.shape[0]):
        free[held[j]] = False
    residual = np.inf
    iterations = 0
    converged = False
    energy, grad, band, tau, dirs, t_now = assemble(x, ref, rest, voronoi, mass, ea, ei, gj, gravity, inertia, drag,
                                                    x_hat, x0, span_edges, span_dirs, span_len, True, contact)
    for it in range(max_iterations + 1):
        if not math.isfinite(energy):  # even the last state is inside a primitive that moved: nothing to descend
            residual = np.inf
            break
        residual = 0.0
        for v in range(n1):
            if free[v]:
                f = math.sqrt(grad[v, 0] ** 2 + grad[v, 1] ** 2 + grad[v, 2] ** 2) / force_scale[v]
                residual = max(residual, f)
        if residual < tolerance:
            converged = True
            break
        if it == max_iterations:
            break
        iterations += 1
        g = grad.ravel().copy()
        g[coords] = 0.0
        weights = gj / span_len
        vectors = dirs.reshape(span_edges.shape[0], 3 * n1).copy()
        for s in range(span_edges.shape[0]):
            vectors[s, coords] = 0.0
        pin(band, coords)
        ok, factor = cholesky(band)
        if not ok:
            _, _, band, _, _, _ = assemble(x, ref, rest, voronoi, mass, ea, ei, gj, gravity, inertia, drag,
                                           x_hat, x0, span_edges, span_dirs, span_len, False, contact)
            pin(band, coords)
            shift = 0.0
            ok, factor = cholesky(band)
            while not ok:  # Gauss-Newton is PSD; a zero-gravity static rod may still be singular
                shift = 1e-9 if shift == 0.0 else shift * 10.0
                _, _, band, _, _, _ = assemble(x, ref, rest, voronoi, mass, ea, ei, gj, gravity, inertia, drag,
                                               x_hat, x0, span_edges, span_dirs, span_len, False, contact)
                for c in range(3 * n1):
                    band[0, c] += shift * max(1.0, abs(band[0, c]))
                pin(band, coords)
                ok, factor = cholesky(band)
        step = -solve_low_rank(factor, weights, vectors, g)
        dx = step.reshape(n1, 3)
        reach = 0.0
        for v in range(n1):
            reach = max(reach, math.sqrt(dx[v, 0] ** 2 + dx[v, 1] ** 2 + dx[v, 2] ** 2))
        if largest_move(x, broad_at) + reach > margin - dhat:  # this step could reach a pair left out: redo
            margin = max(BROAD_MARGIN, 2.0 * reach + dhat)
            broad_at = x.copy()
            contact = broad_phase(x, full_contact, margin)
        slope = g @ step
        alpha = 1.0
        r, kind, pos, rot, size, mask = contact[0], contact[1], contact[2], contact[3], contact[4], contact[5]
        if kind.shape[0] > 0 and not contact[15]:  # the recovery's penalty may pass through: no CCD there
            alpha = max_step(x, dx, r, kind, pos, rot, size, mask, 0.1, 64)
        # a decrease the energy's round-off cannot resolve: the quadratic model is exact enough there, take the step
        trusted = alpha == 1.0 and -slope <= TRUST_MODEL * abs(energy)
        settled = settled_step > 0.0 and alpha == 1.0 and reach < settled_step
        trial = x + alpha * dx
        t_trial, _ = unit_tangents(trial)
        ref_trial = transport_frames(ref, t_now, t_trial)
        if trusted and settled:
            # a full Newton step this short: the next would move no vertex a measurable distance (motion steps
            # only; an equilibrium is proven by its force residual). The gradient kept is the last iterate's, a step
            # behind: no assembly at the final x.
            x, ref = trial, ref_trial
            converged = True
            break
        # the first trial's energy from its assembly, which the next iteration needs anyway where it is accepted
        e_new, g_new, b_new, tau_new, d_new, t_new = assemble(trial, ref_trial, rest, voronoi, mass, ea, ei, gj,
                                                              gravity, inertia, drag, x_hat, x0, span_edges,
                                                              span_dirs, span_len, True, contact)
        accepted = trusted or e_new <= energy + ARMIJO * alpha * slope + ROUNDOFF * abs(energy)
        for _ in range(0 if accepted else MAX_HALVINGS):
            alpha *= 0.5
            trial = x + alpha * dx
            e_trial = total_energy(trial, ref, t_now, x_hat, x0, rest, voronoi, mass, ea, ei, gj, gravity, inertia,
                                   drag, span_edges, span_dirs, span_len, contact)
            if e_trial <= energy + ARMIJO * alpha * slope + ROUNDOFF * abs(energy):
                accepted = True
                t_trial, _ = unit_tangents(trial)
                ref_trial = transport_frames(ref, t_now, t_trial)
                e_new, g_new, b_new, tau_new, d_new, t_new = assemble(
                    trial, ref_trial, rest, voronoi, mass, ea, ei, gj, gravity, inertia, drag, x_hat, x0, span_edges,
                    span_dirs, span_len, True, contact)
                break
        if not accepted:
            break
        x, ref = trial, ref_trial
        energy, grad, band, tau, dirs, t_now = e_new, g_new, b_new, tau_new, d_new, t_new
        if settled:
            converged = True  # as above, with the gradient at the final x
            break
    # the last gradient was taken at the final x: less inertia and drag it is minus the net static force
    static = grad.copy()
    for v in range(n1):
        for a in range(3):
            static[v, a] -= mass[v] * (inertia * (x[v, a] - x_hat[v, a]) + drag * (x[v, a] - x0[v, a]))
    return x, ref, iterations, residual, converged, tau, static
