"""The wear measures of a rod engine cable in one compiled pass: curvature, tensions, node loads and clearance."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .clearance import nearest_gap
from .loads import holder_loads_kernel


@njit(cache=True)
def menger_curvature(x, i):
    """Menger curvature 2 |e x f| / (|e| |f| |e + f|) at interior vertex ``i`` of ``x``: exact on an arc."""
    e0, e1, e2 = x[i, 0] - x[i - 1, 0], x[i, 1] - x[i - 1, 1], x[i, 2] - x[i - 1, 2]
    f0, f1, f2 = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
    c0, c1, c2 = e1 * f2 - e2 * f1, e2 * f0 - e0 * f2, e0 * f1 - e1 * f0
    s0, s1, s2 = e0 + f0, e1 + f1, e2 + f2
    denom = math.sqrt((e0 * e0 + e1 * e1 + e2 * e2) * (f0 * f0 + f1 * f1 + f2 * f2) * (s0 * s0 + s1 * s1 + s2 * s2))
    return 2.0 * math.sqrt(c0 * c0 + c1 * c1 + c2 * c2) / max(denom, 1e-15)


@njit(cache=True)
def measure(x, rest, ea, radius, forces_v, members, anchors, spans, moments, tap_vertex, tap_neighbour, tap_node,
            kind, pos, rot, size, cap):
    """(curvature, its vertex, tension, its edge or -(tap + 1) for a node's, compression, clearance, its edge, its
    primitive, node force, node torque) of the cable ``x`` (see RodSimulator._measure for what each is)."""
    n = x.shape[0] - 1
    best_k, at_k = 0.0, 0
    for i in range(1, n):
        k = menger_curvature(x, i)
        if k > best_k:
            best_k, at_k = k, i
    tension, at_t, compression = -np.inf, 0, 0.0
    for e in range(n):
        d0, d1, d2 = x[e + 1, 0] - x[e, 0], x[e + 1, 1] - x[e, 1], x[e + 1, 2] - x[e, 2]
        t = ea * (math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) / rest[e] - 1.0)
        if t > tension:
            tension, at_t = t, e
        compression = max(compression, -t)
    forces, torques = holder_loads_kernel(x, forces_v, members, anchors, spans, moments)
    for tap in range(tap_vertex.shape[0]):  # where the cable enters a node: the node's load along the cable
        v, w, h = tap_vertex[tap], tap_neighbour[tap], tap_node[tap]
        u0, u1, u2 = x[w, 0] - x[v, 0], x[w, 1] - x[v, 1], x[w, 2] - x[v, 2]
        t = (forces[h, 0] * u0 + forces[h, 1] * u1 + forces[h, 2] * u2) / math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        if t > tension:
            tension, at_t = t, -(tap + 1)
    node_force, node_torque = 0.0, 0.0
    for h in range(forces.shape[0]):
        node_force = max(node_force, math.sqrt(forces[h, 0] ** 2 + forces[h, 1] ** 2 + forces[h, 2] ** 2))
        node_torque = max(node_torque, math.sqrt(torques[h, 0] ** 2 + torques[h, 1] ** 2 + torques[h, 2] ** 2))
    gap, edge, prim = nearest_gap(x, radius, kind, pos, rot, size, cap) if kind.shape[0] else (cap, -1, -1)
    return best_k, at_k, tension, at_t, compression, gap, edge, prim, node_force, node_torque
