"""A station's obstacles and robot links as contact primitives for one cable, posed at the robots' joints."""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numba import njit

from ..robots.model import body_name
from ..stations.station import LINK_INDEX, Station
from .contact.motion import surface_displacements
from .contact.primitives import bounding_radii, point_distance
from .contact.segment import lower_bound, segment_gap
from .scene import BOX, CAPSULE, CYLINDER, PLANE, SPHERE, Primitives
from .station_cable import StationCable

# MuJoCo's geom types (as the ints the model stores) -> the contact kernels' kinds
KINDS = {int(mujoco.mjtGeom.mjGEOM_PLANE): PLANE, int(mujoco.mjtGeom.mjGEOM_SPHERE): SPHERE,
         int(mujoco.mjtGeom.mjGEOM_CAPSULE): CAPSULE, int(mujoco.mjtGeom.mjGEOM_BOX): BOX,
         int(mujoco.mjtGeom.mjGEOM_CYLINDER): CYLINDER}
# A moving primitive may close at most this fraction of its gap to the cable in one sub-step, so every sub-step's
# solve starts strictly outside it.
CLOSING_FRACTION = 0.5
# Gap [m] beyond which a moving primitive cannot limit a sub-step (nothing in a station moves this far in a sample).
FAR = 1.0


class StationScene:
    """The primitives one cable may touch: the station's obstacles and floor, the other robots' links, and its own
    robot's links when the dresspack collides with them (as in the MuJoCo model's contact bits); meshes are not
    primitives and are left out (``skipped`` names them)."""

    def __init__(self, station: Station, cable: StationCable):
        m = station.model
        self.station = station
        self.data = mujoco.MjData(m)
        self.data.qpos[:] = m.qpos0
        self.data.qpos[station.load_qpos] = station.load_values
        own = station.config.robots[cable.robot].dresspack.collide_with_robot
        geoms = list(station.obstacle_geoms)
        obstacles = {int(g) for g in station.obstacle_geoms}
        for j, r in enumerate(station.robots):
            if j != cable.robot or own:
                geoms += [g for g in r.geom_ids if m.geom_contype[g] != 0]
        self.skipped = [m.geom(int(g)).name for g in geoms if int(m.geom_type[g]) not in KINDS]
        self.geoms = np.array([g for g in geoms if int(m.geom_type[g]) in KINDS], dtype=int)
        self.kind = np.array([KINDS[int(m.geom_type[g])] for g in self.geoms], dtype=np.int64)
        # the obstacles (and floor) come first: what the clearance measure is taken to, as in the MuJoCo simulator
        self.n_obstacles = sum(int(g) in obstacles for g in self.geoms)
        self.obstacle_names = [m.geom(int(g)).name.removeprefix("obstacle/") for g in self.geoms[:self.n_obstacles]]
        self.size = m.geom_size[self.geoms].copy()
        self.bound = bounding_radii(self.kind, self.size)
        # the bodies that hold the cable's vertices and clamp frames (the world: -1), for its targets from the same
        # kinematics pass as the primitives
        link_body = {k: m.body(body_name(station.robots[cable.robot].name, link)).id for link, k in LINK_INDEX.items()}
        self.held_body = np.array([link_body.get(hp.link, -1) for hp in cable.held], dtype=int)
        self.held_local = np.array([hp.local for hp in cable.held], dtype=float).reshape(-1, 3)
        self.clamp_body = np.array([link_body.get(c.link, -1) for c in cable.clamps], dtype=int)
        self.clamp_local = np.array([c.local_director for c in cable.clamps], dtype=float).reshape(-1, 3)
        self.mask = pair_mask_of(cable, self.geoms, own_robot_links(station, cable.robot))

    def pose(self, q: np.ndarray) -> None:
        """MuJoCo's kinematics with the robots at ``q`` (n_robots, 6): the body and geom poses in ``data``."""
        self.data.qpos[self.station.robot_qpos] = q.ravel()
        mujoco.mj_kinematics(self.station.model, self.data)

    def at(self, q: np.ndarray) -> Primitives:
        """The primitives with the robots at ``q`` (n_robots, 6)."""
        self.pose(q)
        pos, rot = pose_primitives(self.data.geom_xpos, self.data.geom_xmat, self.geoms)
        return Primitives(self.kind, pos, rot, self.size, self.mask)

    def targets(self) -> tuple[np.ndarray, np.ndarray]:
        """The held vertices' world positions and the clamps' directors per span (n_spans, 2, 3) at the robots' pose
        of the last :meth:`at` (MuJoCo's kinematics: the same link frames the primitives were posed with)."""
        d = self.data
        return held_targets(d.xpos, d.xmat, self.held_body, self.held_local, self.clamp_body, self.clamp_local)

    def carried_start(self, x: np.ndarray, radius: float, now: Primitives, end: Primitives, reach: float
                      ) -> np.ndarray:
        """The cable ``x`` with the vertices a moving link may reach carried along with it (see carried_along)."""
        moved = surface_displacements(now.kind, now.size, now.pos, now.rot, end.pos, end.rot, self.bound)
        return carried_along(x, radius, now.kind, now.pos, now.rot, now.size, end.pos, end.rot, moved, reach)

    def advance_fraction(self, x: np.ndarray, radius: float, now: Primitives, end: Primitives) -> float:
        """The fraction (0, 1] of the way from ``now`` to ``end`` the primitives may move in one sub-step: no
        moving primitive closes more than CLOSING_FRACTION of its gap to the cable ``x``."""
        return closing_fraction(x, radius, now, end, self.bound)


def own_robot_links(station: Station, robot: int) -> dict[int, int]:
    """Geom id -> link number (0 = base .. 6) of every collision geom of robot ``robot``."""
    r = station.robots[robot]
    return {int(g): int(k) for g, k in zip(r.geom_ids, r.geom_links)}


def pair_mask_of(cable: StationCable, geoms: np.ndarray, own_links: dict[int, int]) -> np.ndarray:
    """Which (edge, primitive) pairs may touch (n_edges, k): all but

    * a clamp's own edge (both ends held), which is part of its node;
    * an edge leaving a node (one end held) against the links of the cable's own robot other than the node's link.
      The held end is the node's hardware, rigid on its link: where another link of the same robot comes at it
      (the tool support against the forearm at a folded wrist), the robot meets its own dresspack's support, a
      contact between two driven bodies that no motion of the cable resolves (its barrier would be infinite with
      nothing free to move). The edge's free end stays guarded by its other edge.

    ``own_links``: geom id -> link number of the cable's own robot's geoms (see :func:`own_robot_links`).
    """
    held = {hp.vertex: hp.link for hp in cable.held}
    mask = np.ones((cable.model.segments, len(geoms)), dtype=np.bool_)
    for e in range(cable.model.segments):
        if e in held and e + 1 in held:
            mask[e] = False
        elif (e in held) != (e + 1 in held):
            link = held[e] if e in held else held[e + 1]
            for j, g in enumerate(geoms):
                if int(g) in own_links and own_links[int(g)] != link:
                    mask[e, j] = False
    return mask


@njit(cache=True)
def pose_primitives(geom_xpos, geom_xmat, geoms):
    """The primitives' world positions (k, 3) and rotations (k, 3, 3) from MuJoCo's geom poses (xmat rows of 9)."""
    k = geoms.shape[0]
    pos = np.empty((k, 3))
    rot = np.empty((k, 3, 3))
    for j in range(k):
        g = geoms[j]
        for a in range(3):
            pos[j, a] = geom_xpos[g, a]
            for b in range(3):
                rot[j, a, b] = geom_xmat[g, 3 * a + b]
    return pos, rot


@njit(cache=True)
def held_targets(xpos, xmat, held_body, held_local, clamp_body, clamp_local):
    """The held vertices' world positions (h, 3) and the clamps' directors per span (c - 1, 2, 3) from MuJoCo's body
    poses; a body index below 0 is the world (the local values are world values)."""
    pos = np.empty((held_body.shape[0], 3))
    for j in range(held_body.shape[0]):
        b = held_body[j]
        for a in range(3):
            if b < 0:
                pos[j, a] = held_local[j, a]
            else:
                pos[j, a] = xpos[b, a] + xmat[b, 3 * a] * held_local[j, 0] + xmat[b, 3 * a + 1] * held_local[j, 1] \
                    + xmat[b, 3 * a + 2] * held_local[j, 2]
    c = clamp_body.shape[0]
    dirs = np.empty((c, 3))
    for j in range(c):
        b = clamp_body[j]
        for a in range(3):
            if b < 0:
                dirs[j, a] = clamp_local[j, a]
            else:
                dirs[j, a] = xmat[b, 3 * a] * clamp_local[j, 0] + xmat[b, 3 * a + 1] * clamp_local[j, 1] \
                    + xmat[b, 3 * a + 2] * clamp_local[j, 2]
    spans = np.empty((max(c - 1, 0), 2, 3))
    for s in range(c - 1):
        spans[s, 0] = dirs[s]
        spans[s, 1] = dirs[s + 1]
    return pos, spans


def closing_fraction(x: np.ndarray, radius: float, now: Primitives, end: Primitives, bound: np.ndarray) -> float:
    """See :meth:`StationScene.advance_fraction` (``bound``: the primitives' bounding radii)."""
    moved = surface_displacements(now.kind, now.size, now.pos, now.rot, end.pos, end.rot, bound)
    if not (moved > 1e-12).any():
        return 1.0
    gaps = primitive_gaps(x, radius, now.kind, now.pos, now.rot, now.size, now.mask, moved, FAR)
    return float(min(1.0, (CLOSING_FRACTION * np.maximum(gaps, 0.0) / np.maximum(moved, 1e-300)).min()))


@njit(cache=True)
def carried_along(x, r, kind, pos, rot, size, pos_end, rot_end, moved, reach):
    """``x`` with every vertex that a moving primitive comes at this step (it would end within ``reach`` of the
    vertex left where it is) moved rigidly with the nearest such primitive: a pushed cable's start that the link has
    not entered, so that one solve replaces the sub-steps a link pushing the cable would otherwise need."""
    out = x.copy()
    n = np.empty(3)
    h = np.empty((3, 3))
    local = np.empty(3)
    bound = bounding_radii(kind, size)
    for v in range(x.shape[0]):
        best, best_j = np.inf, -1
        for j in range(kind.shape[0]):
            if moved[j] <= 1e-12 or kind[j] == 0:  # still, or a plane (the floor never moves)
                continue
            ball = math.sqrt((x[v, 0] - pos[j, 0]) ** 2 + (x[v, 1] - pos[j, 1]) ** 2 + (x[v, 2] - pos[j, 2]) ** 2)
            if ball - bound[j] - r >= moved[j] + reach:  # beyond its bounding ball's reach: cannot be met
                continue
            # nor beyond the cheap bound of its own shape (a box's or capsule's distance, with no Hessian)
            if lower_bound(x[v], x[v], r, kind[j], pos[j], rot[j], size[j], bound[j]) >= moved[j] + reach:
                continue
            d = point_distance(kind[j], pos[j], rot[j], size[j], x[v], n, h) - r
            if d >= moved[j] + reach or d >= best:
                continue
            # only a link that comes at the vertex carries it: one moving away or past leaves it to the solve
            if point_distance(kind[j], pos_end[j], rot_end[j], size[j], x[v], n, h) - r >= reach:
                continue
            best, best_j = d, j
        if best_j < 0:
            continue
        j = best_j
        for a in range(3):
            local[a] = 0.0
            for b in range(3):
                local[a] += rot[j, b, a] * (x[v, b] - pos[j, b])
        for a in range(3):
            out[v, a] = pos_end[j, a] + rot_end[j, a, 0] * local[0] + rot_end[j, a, 1] * local[1] \
                + rot_end[j, a, 2] * local[2]
    # a vertex carried by one link may now lie in another that moved (the wrist's links meet): set it on that one's
    # surface, ``reach`` out (twice: two links may take turns)
    for _ in range(2):
        for v in range(x.shape[0]):
            for j in range(kind.shape[0]):
                if moved[j] <= 1e-12 or kind[j] == 0:
                    continue
                ball = math.sqrt((out[v, 0] - pos_end[j, 0]) ** 2 + (out[v, 1] - pos_end[j, 1]) ** 2
                                 + (out[v, 2] - pos_end[j, 2]) ** 2)
                if ball - bound[j] - r >= reach or lower_bound(out[v], out[v], r, kind[j], pos_end[j], rot_end[j],
                                                               size[j], bound[j]) >= reach:
                    continue  # not within reach of it
                d = point_distance(kind[j], pos_end[j], rot_end[j], size[j], out[v], n, h) - r
                if d < reach:
                    for a in range(3):
                        out[v, a] += (reach - d) * n[a]
    return out


@njit(cache=True)
def primitive_gaps(x, r, kind, pos, rot, size, mask, moved, far):
    """The smallest gap of the cable to each primitive that moved (``far`` for those beyond it or still)."""
    k = kind.shape[0]
    bound = bounding_radii(kind, size)
    out = np.full(k, far)
    p = np.empty(3)
    n = np.empty(3)
    h = np.empty((3, 3))
    for j in range(k):
        if moved[j] <= 1e-12:
            continue
        for i in range(x.shape[0] - 1):
            if not mask[i, j] or lower_bound(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], bound[j]) >= out[j]:
                continue
            d, _ = segment_gap(x[i], x[i + 1], r, kind[j], pos[j], rot[j], size[j], p, n, h)
            out[j] = min(out[j], d)
    return out
