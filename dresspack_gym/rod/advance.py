"""One motion step of a station cable in one compiled call: targets and primitives read off the kinematics, the
carried start, its outside check, the lagged friction set and the Newton solve."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .contact.friction import MAX_RELAGS, friction_lag, friction_relag, friction_settled
from .contact.motion import surface_displacements
from .contact.primitives import bounding_radii
from .newton import BROAD_MARGIN, broad_phase, contact_energy, largest_move, newton_step
from .station_scene import carried_along, held_targets, pose_primitives


@njit(cache=True)
def following(x, v, h, held, held_pos):
    """The inertial prediction x + h v corrected by each held vertex's miss (its new place less its prediction),
    interpolated linearly along the cable between held vertices (``held`` ascending) and constant beyond the outer
    ones: the cable follows its holders into the solve's start."""
    out = x + h * v
    k = held.shape[0]
    if k == 0:
        return out
    miss = np.empty((k, 3))
    for j in range(k):
        for a in range(3):
            miss[j, a] = held_pos[j, a] - out[held[j], a]
    j = 0
    for i in range(x.shape[0]):
        while j < k - 1 and held[j + 1] <= i:
            j += 1
        if i <= held[0]:
            w, lo, hi = 0.0, 0, 0
        elif j == k - 1:
            w, lo, hi = 0.0, k - 1, k - 1
        else:
            w, lo, hi = (i - held[j]) / (held[j + 1] - held[j]), j, j + 1
        for a in range(3):
            out[i, a] += (1.0 - w) * miss[lo, a] + w * miss[hi, a]
    return out


@njit(cache=True)
def carried_step(x, v, ref, held, rest, voronoi, mass, ea, ei, gj, gravity, damping, span_edges, span_len,
                 force_scale, xpos, xmat, geom_xpos, geom_xmat, geoms, kind, size, mask, held_body, held_local,
                 clamp_body, clamp_local, prev_pos, prev_rot, lagged, r, dhat, kappa, mu, eps, reach, h, tolerance,
                 max_iterations, settled_step):
    """One implicit step of ``h`` s of a station cable whose robots' kinematics were just run (MuJoCo's body poses
    ``xpos``/``xmat`` and geom poses): the held vertices and clamp directors are read off the bodies, the primitives
    off the geoms, the solve starts from the holders' followed prediction with the vertices an approaching link
    meets carried along (see station_scene.carried_along) and lags its friction from ``x`` against the primitives'
    previous poses (``lagged``: there were any). ``ok`` is False (nothing solved) where that start is not outside
    every primitive: the caller sub-steps then. Returns (ok, x, ref, iterations, residual, converged, tau, static
    gradient, primitive pos, rot, held positions, span directors)."""
    pos, rot = pose_primitives(geom_xpos, geom_xmat, geoms)
    held_pos, dirs = held_targets(xpos, xmat, held_body, held_local, clamp_body, clamp_local)
    start = following(x, v, h, held, held_pos)
    bound = bounding_radii(kind, size)
    moved = surface_displacements(kind, size, prev_pos, prev_rot, pos, rot, bound)
    start = carried_along(start, r, kind, prev_pos, prev_rot, size, pos, rot, moved, reach)
    for j in range(held.shape[0]):
        start[held[j]] = held_pos[j]
    empty_i = np.zeros(0, np.int64)
    empty_1 = np.zeros(0)
    empty_3 = np.zeros((0, 3))
    bare = (r, kind, pos, rot, size, mask, dhat, kappa, empty_i, empty_1, empty_3, empty_1, empty_3, mu, eps, False)
    near_start = broad_phase(start, bare, BROAD_MARGIN)  # the solve's own first broad phase
    if math.isinf(contact_energy(start, near_start)):
        return (False, x, ref, 0, np.inf, False, np.zeros(span_edges.shape[0]), np.zeros_like(x), pos, rot,
                held_pos, dirs)
    if lagged:
        # the pairs within dhat of x at the previous poses lie within dhat + the largest move of a vertex and of a
        # primitive of the start's pairs (margin BROAD_MARGIN): those serve the lag unless the moves were larger
        shift = 0.0
        for i in range(x.shape[0]):
            shift = max(shift, math.sqrt((start[i, 0] - x[i, 0]) ** 2 + (start[i, 1] - x[i, 1]) ** 2
                                         + (start[i, 2] - x[i, 2]) ** 2))
        if dhat + shift + moved.max() < BROAD_MARGIN:
            near = near_start[5]
        else:
            near = broad_phase(x, (r, kind, prev_pos, prev_rot, size, mask), dhat)[5]
        lag = friction_lag(x, r, kind, prev_pos, prev_rot, size, pos, rot, near, dhat, kappa)
        contact = (r, kind, pos, rot, size, mask, dhat, kappa, lag[0], lag[1], lag[2], lag[3], lag[4], mu, eps, False)
    else:
        contact = bare
    x_new, ref_new, iterations, residual, converged, tau, static = newton_step(
        start, ref, x, v, held, held_pos, rest, voronoi, mass, ea, ei, gj, gravity, h, damping, span_edges, dirs,
        span_len, force_scale, tolerance, max_iterations, contact, settled_step, near_start[5])
    # friction lagged from the step's start falls short of mu N where a link presses harder within the step (or
    # where a contact begins in it): the set is lagged again at the solution and the step solved again from there,
    # until that changes no vertex's friction bound by the solve's tolerance or the solution moves less than a
    # settled step (Coulomb's law at the step's end)
    for _ in range(MAX_RELAGS):
        near_new = broad_phase(x_new, bare, BROAD_MARGIN)[5]  # the solve's first broad phase too
        lag = friction_relag(x, x_new, r, kind, prev_pos, prev_rot, size, pos, rot, near_new, dhat, kappa)
        if friction_settled(x.shape[0], contact[8], contact[9], contact[11], lag[0], lag[1], lag[3], mu, force_scale,
                            tolerance):
            break
        contact = (r, kind, pos, rot, size, mask, dhat, kappa, lag[0], lag[1], lag[2], lag[3], lag[4], mu, eps, False)
        x_again, ref_again, more, residual, converged, tau, static = newton_step(
            x_new, ref, x, v, held, held_pos, rest, voronoi, mass, ea, ei, gj, gravity, h, damping, span_edges, dirs,
            span_len, force_scale, tolerance, max_iterations, contact, settled_step, near_new)
        iterations += more
        moved_most = largest_move(x_again, x_new)
        x_new, ref_new = x_again, ref_again
        if moved_most <= max(settled_step, 1e-9):
            break
    return (True, x_new, ref_new, iterations, residual, converged, tau, static, pos, rot, held_pos, dirs)
