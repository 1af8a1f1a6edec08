"""Where a dresspack's vertices start: the vertices each node holds and a smooth, sagging curve through them.

A settle starts from this reference shape (the equilibrium is found by the physics); the shape at Home also
fixes each clamp's roll (the cable is installed untwisted at Home, see cable_model).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .config import CableNode, DresspackConfig

# A span whose chord is within this fraction of its cable length is laid straight (taut) at build time.
TAUT_SLACK = 1e-6


def node_vertices(dresspack: DresspackConfig, node: CableNode) -> tuple[int, ...]:
    """Cable vertices a node holds: its own, plus the next one (previous one at the end) for a clamp."""
    v = dresspack.vertex_of(node)
    if node.direction is None:
        return (v,)
    return (v, v - 1) if dresspack.is_end_node(node) else (v, v + 1)


def node_world_points(dresspack: DresspackConfig, node: CableNode, frame: np.ndarray) -> list[np.ndarray]:
    """World positions the node's vertices must take: the node point, then the clamp's second point."""
    h = dresspack.segment_length
    p = frame[:3, :3] @ np.asarray(node.pos) + frame[:3, 3]
    pts = [p]
    if node.direction is not None:
        d = frame[:3, :3] @ np.asarray(node.direction)
        pts.append(p - d * h if dresspack.is_end_node(node) else p + d * h)
    return pts


def reference_shape(dresspack: DresspackConfig, frames: list[np.ndarray], gravity_dir=(0, 0, -1), *,
                    resolution: int = 2001) -> np.ndarray:
    """A smooth, sagging cable shape through all nodes (world frame), one point per vertex.

    ``frames[i]`` is the world pose (4x4) of the body holding node i. Each span between nodes is a
    cubic Hermite curve that leaves/enters along the clamp directions plus a parabolic sag along
    gravity, with the sag found by bisection so that the span has exactly its arc length.
    Raises ConfigError if the cable is shorter than the distance its nodes demand. ``resolution``: points of
    each span's curve whose length is matched (coarser is faster and a little less exact in length).
    """
    n = dresspack.segments
    h = dresspack.segment_length
    g = np.asarray(gravity_dir, dtype=float)
    pts = np.full((n + 1, 3), np.nan)
    anchors = _anchors(dresspack, frames, pts)
    for (v0, p0, t0), (v1, p1, t1) in zip(anchors, anchors[1:]):
        if v1 - v0 <= 1:
            if np.linalg.norm(p1 - p0) > h * (v1 - v0) * 1.02 + 1e-9:
                _too_short(dresspack, p0, p1, (v1 - v0) * h)
            continue
        pts[v0:v1 + 1] = _span(p0, t0, p1, t1, (v1 - v0) * h, v1 - v0, g, dresspack, resolution)
    last_v, last_p, last_t = anchors[-1]
    if last_v < n:  # free hanging end: along the last tangent for one segment, then down
        direction = last_t if last_t is not None else g
        tail = [last_p]
        for i in range(n - last_v):
            step = direction if i == 0 else g
            tail.append(tail[-1] + step * h)
        pts[last_v:] = np.array(tail)
    if np.isnan(pts).any():
        raise ConfigError("dresspack.nodes", "internal error: some cable vertices were not placed")
    return pts


def _anchors(dresspack: DresspackConfig, frames: list[np.ndarray],
             pts: np.ndarray | None = None) -> list[tuple[int, np.ndarray, np.ndarray | None]]:
    """(vertex, world point, clamp tangent or None) of every vertex a node holds, in cable order; the node
    points are also written into ``pts`` if given."""
    anchors = []
    for node, frame in zip(dresspack.nodes, frames):
        verts = node_vertices(dresspack, node)
        world = node_world_points(dresspack, node, frame)
        if pts is not None:
            for v, p in zip(verts, world):
                pts[v] = p
        if len(world) == 2:
            tangent = frame[:3, :3] @ np.asarray(node.direction)
            for v, p in sorted(zip(verts, world), key=lambda a: a[0]):
                anchors.append((v, p, tangent))
        else:
            anchors.append((verts[0], world[0], None))
    anchors.sort(key=lambda a: a[0])
    return anchors


def span_slack(dresspack: DresspackConfig, frames: list[np.ndarray]) -> float:
    """The smallest slack [m] over the cable's spans between nodes: arc length available minus the straight
    distance the nodes demand. Negative: the cable cannot reach (the robot would tear it)."""
    h = dresspack.segment_length
    anchors = _anchors(dresspack, frames)
    slack = np.inf
    for (v0, p0, _), (v1, p1, _) in zip(anchors, anchors[1:]):
        if v1 - v0 > 1:  # a clamp's own rigid edge is held by one body
            slack = min(slack, (v1 - v0) * h - float(np.linalg.norm(p1 - p0)))
    return float(slack)


def _too_short(dresspack, p0, p1, length):
    raise ConfigError("dresspack.length",
                      f"cable of {dresspack.length:.3f} m is too short: {np.linalg.norm(p1 - p0):.3f} m lie between "
                      f"its nodes where only {length:.3f} m of cable is available at the Home configuration")


def _span(p0, t0, p1, t1, length, segments, g, dresspack, resolution: int = 2001) -> np.ndarray:
    chord = np.linalg.norm(p1 - p0)
    if chord > length * (1.0 + TAUT_SLACK):
        _too_short(dresspack, p0, p1, length)
    if chord > length * (1.0 - TAUT_SLACK):  # an exactly taut span: the straight line between its ends
        return p0 + np.linspace(0.0, 1.0, segments + 1)[:, None] * (p1 - p0)
    u = np.linspace(0.0, 1.0, resolution)[:, None]
    h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
    c = (p1 - p0) / max(chord, 1e-12)
    t0 = c if t0 is None else t0
    t1 = c if t1 is None else t1

    def curve(k, sag):
        return h00 * p0 + h10 * (k * t0) + h01 * p1 + h11 * (k * t1) + sag * 4 * u * (1 - u) * g

    def arc(curve_pts):
        return np.linalg.norm(np.diff(curve_pts, axis=0), axis=1).sum()

    for k in (0.5 * chord, 0.25 * chord, 0.1 * chord, 0.0):
        if arc(curve(k, 0.0)) <= length:
            break
    lo, hi = 0.0, max(length, 1e-3)
    while arc(curve(k, hi)) < length:
        hi *= 2.0
    for _ in range(60 if resolution >= 2001 else 32):  # 32 halvings of [0, >= length] leave < 1 nm
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if arc(curve(k, mid)) < length else (lo, mid)
    dense = curve(k, 0.5 * (lo + hi))
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    targets = np.linspace(0.0, s[-1], segments + 1)
    return np.stack([np.interp(targets, s, dense[:, i]) for i in range(3)], axis=1)
