"""How far any point of a primitive moves between two poses: the bound by which moving links are sub-stepped."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def rotation_angle(rot_prev, rot):
    """Angle [rad] of the relative rotation rot_prev^T rot (atan2 form: accurate near 0 and pi)."""
    rel = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            rel[a, b] = rot_prev[0, a] * rot[0, b] + rot_prev[1, a] * rot[1, b] + rot_prev[2, a] * rot[2, b]
    sx = rel[2, 1] - rel[1, 2]
    sy = rel[0, 2] - rel[2, 0]
    sz = rel[1, 0] - rel[0, 1]
    sin2 = math.sqrt(sx * sx + sy * sy + sz * sz)  # 2 sin(angle)
    cos2 = rel[0, 0] + rel[1, 1] + rel[2, 2] - 1.0  # 2 cos(angle)
    return math.atan2(sin2, cos2)


@njit(cache=True)
def pose_displacement(pos_prev, rot_prev, pos, rot, radius):
    """Upper bound [m] on the displacement of any point within radius of the origin: |dpos| + radius * angle."""
    d0, d1, d2 = pos[0] - pos_prev[0], pos[1] - pos_prev[1], pos[2] - pos_prev[2]
    angle = rotation_angle(rot_prev, rot)
    # a still primitive of unbounded extent (a plane: radius inf) does not move: inf * 0 must not make a NaN
    return math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) + (radius * angle if angle > 0.0 else 0.0)


@njit(cache=True)
def pose_displacements(pos_prev, rot_prev, pos, rot, radius):
    """:func:`pose_displacement` of each primitive: pos (k, 3), rot (k, 3, 3), radius (k,) -> (k,)."""
    out = np.empty(pos.shape[0])
    for j in range(pos.shape[0]):
        out[j] = pose_displacement(pos_prev[j], rot_prev[j], pos[j], rot[j], radius[j])
    return out


@njit(cache=True)
def surface_displacements(kind, size, pos_prev, rot_prev, pos, rot, radius):
    """Upper bound [m] per primitive on how far its surface moved: a gap to it shrinks by at most this much.

    A sphere's surface moves with its centre and a capsule's with its axis segment (a rigid motion moves the segment's
    points by interpolating its ends' displacements), so a spin about its own axis moves neither; other kinds take
    :func:`pose_displacement` with ``radius`` (their bounding radius).
    """
    out = np.empty(kind.shape[0])
    for j in range(kind.shape[0]):
        if kind[j] == 1:  # sphere
            d0, d1, d2 = pos[j, 0] - pos_prev[j, 0], pos[j, 1] - pos_prev[j, 1], pos[j, 2] - pos_prev[j, 2]
            out[j] = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        elif kind[j] == 2:  # capsule: the larger of its axis ends' displacements
            worst = 0.0
            for sign in (-1.0, 1.0):
                acc = 0.0
                for a in range(3):
                    d = (pos[j, a] + sign * size[j, 1] * rot[j, a, 2]) - (pos_prev[j, a] + sign * size[j, 1]
                                                                          * rot_prev[j, a, 2])
                    acc += d * d
                worst = max(worst, math.sqrt(acc))
            out[j] = worst
        else:
            out[j] = pose_displacement(pos_prev[j], rot_prev[j], pos[j], rot[j], radius[j])
    return out
