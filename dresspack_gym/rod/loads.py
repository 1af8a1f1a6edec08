"""What the cable exerts on each of its holders: the force and the torque about the node point."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .rod import Rod


def holder_loads(rod: Rod, members: np.ndarray, anchors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(forces, torques), each (holders, 3) in the world frame: the static force on the vertices each holder holds
    (their weight included), its moment about the holder's node point ``anchors`` (a vertex index each), and for a
    clamp the twist's torque GJ tau / L about its edge (the near clamp of a span is turned along +tau, the far one
    against it). ``members``: (holders, vertices) 0/1, the vertices each holder holds."""
    spans = rod.model.span_edges
    moments = (rod.model.torsional_stiffness * rod.twists() / rod.model.span_lengths) if len(spans) else np.zeros(0)
    return holder_loads_kernel(rod.x, rod.static_forces(), members, np.asarray(anchors, dtype=np.int64), spans, moments)


@njit(cache=True)
def holder_loads_kernel(x, forces_v, members, anchors, spans, moments):
    """:func:`holder_loads` on plain arrays (the compiled measure pass calls it directly): ``forces_v`` the static
    force on every vertex, ``moments`` each span's twist torque GJ tau / L."""
    k, n1 = members.shape
    forces = np.zeros((k, 3))
    torques = np.zeros((k, 3))
    for h in range(k):
        a = anchors[h]
        for v in range(n1):
            if members[h, v] == 0.0:
                continue
            f = forces_v[v]
            r0, r1, r2 = x[v, 0] - x[a, 0], x[v, 1] - x[a, 1], x[v, 2] - x[a, 2]
            forces[h, 0] += f[0]
            forces[h, 1] += f[1]
            forces[h, 2] += f[2]
            torques[h, 0] += r1 * f[2] - r2 * f[1]
            torques[h, 1] += r2 * f[0] - r0 * f[2]
            torques[h, 2] += r0 * f[1] - r1 * f[0]
    for s in range(spans.shape[0]):
        for end in range(2):
            e = spans[s, end]
            sign = 1.0 if end == 0 else -1.0
            t0, t1, t2 = x[e + 1, 0] - x[e, 0], x[e + 1, 1] - x[e, 1], x[e + 1, 2] - x[e, 2]
            ln = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            for h in range(k):
                if members[h, e] != 0.0 and members[h, e + 1] != 0.0:
                    torques[h, 0] += sign * moments[s] * t0 / ln
                    torques[h, 1] += sign * moments[s] * t1 / ln
                    torques[h, 2] += sign * moments[s] * t2 / ln
    return forces, torques
