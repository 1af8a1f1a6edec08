"""Wear measures of a settled cable (thesis §4.3): curvature, tension, clearance, twist and node loads.

All functions read a compiled :class:`~dresspack_gym.stations.station.Station` and an ``MjData`` after
``mj_forward``/``mj_step`` (so ``xpos`` and constraint forces are current).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import SimulationError
from ..stations.station import CableIndex, Station

# Distances beyond this are not refined (the cost only cares about the clearance threshold c).
MAX_CLEARANCE = 10.0


@dataclass(frozen=True)
class WearMeasures:
    """The measures of one cable configuration; ``*_at`` are arc lengths [m] along the cable."""

    max_curvature: float  # kappa [1/m]
    max_tension: float  # F [N], largest pull in an edge or at a node
    min_clearance: float  # d [m], 0 in contact
    max_twist_rate: float  # [rad/m], largest material twist per unit length
    curvature_at: float = 0.0
    tension_at: float = 0.0
    clearance_at: float = 0.0
    nearest_obstacle: str = ""
    total_twist: float = 0.0  # [rad], largest |twist| accumulated between two clamps
    max_compression: float = 0.0  # [N], largest push in an edge (reported apart from the tension)
    max_node_force: float = 0.0  # [N], largest force a node (clamp/ring) carries
    max_node_torque: float = 0.0  # [N m], largest torque a clamp carries
    max_damage_rate: float = 0.0  # damage per second of the worst segment (damage.damage_rate; value terms)
    damage_at: float = 0.0

    @staticmethod
    def worst(items: list["WearMeasures"]) -> "WearMeasures":
        """Station-level measures: the worst value of each measure over all cables."""
        kc = max(items, key=lambda m: m.max_curvature)
        kt = max(items, key=lambda m: m.max_tension)
        kd = min(items, key=lambda m: m.min_clearance)
        kr = max(items, key=lambda m: m.max_damage_rate)
        return WearMeasures(kc.max_curvature, kt.max_tension, kd.min_clearance,
                            max(m.max_twist_rate for m in items), kc.curvature_at, kt.tension_at, kd.clearance_at,
                            kd.nearest_obstacle, max(m.total_twist for m in items),
                            max(m.max_compression for m in items), max(m.max_node_force for m in items),
                            max(m.max_node_torque for m in items), kr.max_damage_rate, kr.damage_at)


def cable_points(data: mujoco.MjData, cable: CableIndex) -> np.ndarray:
    """World positions of the cable vertices, shape (n+1, 3) (free vertices and those nodes hold)."""
    return data.flexvert_xpos[cable.point_rows].copy()


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis of (..., 3) arrays: np.cross's arithmetic without its generic axis
    handling, which cost more than the math for the few vectors here (it was 6 % of a training step)."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1], a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def vertex_curvatures(points: np.ndarray) -> np.ndarray:
    """Curvature at each interior vertex: the circle through the vertex and its neighbours.

    kappa = 2 |e0 x e1| / (|e0| |e1| |e0 + e1|) (Menger curvature) is exact for points on an arc.
    """
    e0 = points[1:-1] - points[:-2]
    e1 = points[2:] - points[1:-1]
    area = np.linalg.norm(cross(e0, e1), axis=1)
    denom = np.linalg.norm(e0, axis=1) * np.linalg.norm(e1, axis=1) * np.linalg.norm(e0 + e1, axis=1)
    return 2.0 * area / np.maximum(denom, 1e-15)


def edge_tensions(model: mujoco.MjModel, data: mujoco.MjData, cable: CableIndex) -> np.ndarray:
    """Axial force of each cable edge [N] (positive = pulled, negative = pushed), NaN for rigid clamp edges.

    The force of an edge's equality row: with the edge compliance of cable_model.edge_constraint it is
    EA * strain. A clamp's own edge lies on one rigid node body and carries no row.
    """
    out = np.full(cable.n_vertices - 1, np.nan)
    eq_rows = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    for p in cable.pieces:
        forces = -data.efc_force[eq_rows & (data.efc_id == p.edge_eq_id)]
        stretchable = np.where(~p.rigid_edge)[0]
        if len(forces) != len(stretchable):
            raise SimulationError(f"cable of robot {cable.robot!r}: {len(forces)} edge constraint rows for "
                                  f"{len(stretchable)} stretchable edges")
        out[np.asarray(p.piece.vertices[:-1])[stretchable]] = forces
    return out


def node_loads(model: mujoco.MjModel, data: mujoco.MjData, cable: CableIndex) -> tuple[np.ndarray, np.ndarray]:
    """(forces, torques), each (n_nodes, 3): what the cable exerts on each node, in the node's frame.

    Read from the node's kinematic load cell: the generalised forces on its three slides (along the
    node body's rest axes, rotated into the node frame) and its ball joint (torque in the node frame,
    about the node point). Elastic, damping and constraint (edge, contact) forces are included, plus the
    weight of the cable piece the node holds (its lumped vertex masses); the node body's own (negligible)
    gravity is not. For a clamp, x is the cable direction.
    """
    gen = data.qfrc_spring + data.qfrc_damper + data.qfrc_constraint
    gravity = np.asarray(model.opt.gravity, dtype=float)
    forces = np.zeros((len(cable.attachments), 3))
    torques = np.zeros((len(cable.attachments), 3))
    for k, att in enumerate(cable.attachments):
        f = gen[cable.load_dof[k]]
        rot = data.xmat[cable.node_bodies[k]].reshape(3, 3)
        g_local = rot.T @ gravity
        forces[k] = np.asarray(att.slide_to_node) @ f[:3] + sum(att.held_mass) * g_local
        torques[k] = f[3:] + sum(cross(np.asarray(r), m * g_local) for m, r in zip(att.held_mass, att.held_at))
    return forces, torques


def node_tensions(cable: CableIndex, points: np.ndarray, forces: np.ndarray, body_rot: list[np.ndarray]) -> np.ndarray:
    """Tension where the cable enters each node [N]: the node load's component pulling into the cable.

    For a cable hanging from a clamp at its top this is the cable's whole weight.
    """
    out = np.zeros(len(cable.attachments))
    n = len(points) - 1
    for k, att in enumerate(cable.attachments):
        f_world = body_rot[k] @ forces[k]
        outer = att.vertices[-1]  # a clamp's second (outer) vertex; a ring's only one
        sides = [s for s in (outer + 1, outer - 1) if 0 <= s <= n and s not in att.vertices]
        out[k] = max((float(f_world @ ((points[s] - points[outer]) / max(np.linalg.norm(points[s] - points[outer]),
                                                                        1e-12))) for s in sides), default=0.0)
    return out


def vertex_twists(model: mujoco.MjModel, data: mujoco.MjData, cable: CableIndex) -> list[np.ndarray]:
    """Material twist [rad] at each interior vertex of each rod: theta_e - theta_(e-1) + reference twist.

    theta_e is the angle of edge e's twist hinge (0 for an edge a clamp holds: its material frame is the
    node body's); the reference twist is the twist of the time-parallel reference frames that MuJoCo
    keeps in ``mjData.plastic`` after the 6 numbers per edge of the frames themselves (DER, Bergou et al.).
    """
    out = []
    for p in cable.pieces:
        ne = p.piece.n_edges
        theta = np.where(p.twist_qpos >= 0, data.qpos[np.maximum(p.twist_qpos, 0)], 0.0)
        ref = data.plastic[p.plastic_adr + 6 * ne:p.plastic_adr + 6 * ne + ne - 1]
        out.append(np.diff(theta) + ref)
    return out


def _edge_capsules(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each cable edge's midpoint and half length: its capsule's centre and half axis."""
    return 0.5 * (points[1:] + points[:-1]), 0.5 * np.linalg.norm(points[1:] - points[:-1], axis=1)


class ClearanceProbe:
    """Exact capsule-to-geometry distances with MuJoCo's own narrow phase (``mj_geomDistance``).

    Each cable edge is a capsule of the cable radius. A lower bound from bounding spheres orders
    the (edge, obstacle) pairs so that only the few pairs that can be nearest are computed exactly.
    """

    def __init__(self, station: Station):
        self.station = station
        m = station.model
        self.probe = m.geom("clearance_probe").id
        self.obstacles = station.obstacle_geoms
        self.rbound = m.geom_rbound[self.obstacles].copy()
        self.is_plane = m.geom_type[self.obstacles] == mujoco.mjtGeom.mjGEOM_PLANE
        # Boxes (the station's panels, fixtures and floor plates, some 4 m long): their bounding spheres bound
        # nothing near them, so an edge's distance to the box itself bounds them (most exact queries were boxes')
        self.box_cols = np.flatnonzero(m.geom_type[self.obstacles] == mujoco.mjtGeom.mjGEOM_BOX)
        self.box_half = m.geom_size[self.obstacles[self.box_cols]].copy()
        self.names = [m.geom(g).name.removeprefix("obstacle/") for g in self.obstacles]
        self.plane_names = frozenset(n for n, p in zip(self.names, self.is_plane) if p)
        self._fromto = np.zeros(6)
        self._quat = np.zeros(4)
        self._rot = np.zeros(9)

    def lower_bounds(self, data: mujoco.MjData, cable: CableIndex, points: np.ndarray) -> np.ndarray:
        """(edges, obstacles): a lower bound on each edge capsule's signed distance to each obstacle (a plane's
        is exact), what orders and prunes :meth:`min_distance`'s exact queries."""
        return self._lower_bounds(data, cable, points, *_edge_capsules(points))

    def _lower_bounds(self, data: mujoco.MjData, cable: CableIndex, points: np.ndarray, mids: np.ndarray,
                      half: np.ndarray) -> np.ndarray:
        centers = data.geom_xpos[self.obstacles]
        lb = np.linalg.norm(mids[:, None, :] - centers[None, :, :], axis=2)
        lb = lb - half[:, None] - self.rbound[None, :] - cable.radius
        if len(self.box_cols):
            # an edge's bounding sphere (centre mid, radius half + r) outside a box: the gap from its centre to
            # the box less that radius bounds the capsule's distance; a positive one only (a sphere reaching into
            # the box bounds no penetration depth), else the sphere-sphere bound stays
            frames = data.geom_xmat[self.obstacles[self.box_cols]].reshape(-1, 3, 3)
            local = np.einsum("ebk,bkj->ebj", mids[:, None, :] - centers[None, self.box_cols], frames)
            outside = np.maximum(np.abs(local) - self.box_half[None], 0.0)
            box_lb = np.sqrt(np.einsum("ebk,ebk->eb", outside, outside)) - half[:, None] - cable.radius
            lb[:, self.box_cols] = np.maximum(lb[:, self.box_cols], np.where(box_lb > 0.0, box_lb, -np.inf))
        plane_cols = np.flatnonzero(self.is_plane)
        if len(plane_cols):  # a plane's exact distance is cheap: the nearer end's height less the radius
            normals = data.geom_xmat[self.obstacles[plane_cols]].reshape(-1, 3, 3)[:, :, 2]
            offs = np.einsum("pk,pk->p", normals, centers[plane_cols])
            vd = points @ normals.T - offs[None, :] - cable.radius  # (n+1, planes)
            lb[:, plane_cols] = np.minimum(vd[1:], vd[:-1])
        return lb

    def min_distance(self, data: mujoco.MjData, cable: CableIndex, points: np.ndarray, *,
                     signed: bool = False, planes: bool = True) -> tuple[float, int, str]:
        """(distance, edge index, obstacle name) of the nearest obstacle; (MAX_CLEARANCE, -1, '') if none.
        The distance is 0 in contact, or with ``signed`` negative by the depth of the deepest penetration (a
        predicted shape may pass through an obstacle; a simulated one only touches it). ``planes=False`` leaves
        the planes (the floor) out."""
        if len(self.obstacles) == 0 or (not planes and self.is_plane.all()):
            return MAX_CLEARANCE, -1, ""
        m = self.station.model
        mids, half = _edge_capsules(points)
        lb = self._lower_bounds(data, cable, points, mids, half)
        if not planes:
            lb[:, self.is_plane] = np.inf
        order = np.argsort(lb, axis=None)
        best, best_edge, best_obs = MAX_CLEARANCE, -1, -1
        size = m.geom_size[self.probe]
        for flat in order:
            e, o = divmod(int(flat), len(self.obstacles))
            if lb[e, o] >= best:
                break
            if self.is_plane[o]:  # its bound is its exact distance
                dist = lb[e, o]
            else:
                data.geom_xpos[self.probe] = mids[e]
                mujoco.mju_quatZ2Vec(self._quat, points[e + 1] - points[e])
                mujoco.mju_quat2Mat(self._rot, self._quat)
                data.geom_xmat[self.probe] = self._rot
                size[0], size[1] = cable.radius, max(half[e], 1e-6)
                limit = max(best, 0.0) if signed else best  # a negative limit would cut a penetration short
                dist = mujoco.mj_geomDistance(m, data, self.probe, int(self.obstacles[o]), limit, self._fromto)
            if dist < best:
                best, best_edge, best_obs = dist, e, o
        return (best if signed else max(best, 0.0)), best_edge, (self.names[best_obs] if best_obs >= 0 else "")


def measure_cable(station: Station, data: mujoco.MjData, cable: CableIndex, probe: ClearanceProbe) -> WearMeasures:
    points = cable_points(data, cable)
    if not np.isfinite(points).all():
        raise SimulationError(f"cable of robot {cable.robot!r} has non-finite vertex positions")
    m = station.model
    h = cable.segment_length
    kappa = vertex_curvatures(points)
    edges = edge_tensions(m, data, cable)
    forces, torques = node_loads(m, data, cable)
    rot = [data.xmat[b].reshape(3, 3) for b in cable.node_bodies]
    tension = np.concatenate([np.nan_to_num(edges, nan=-np.inf), node_tensions(cable, points, forces, rot)])
    twists = vertex_twists(m, data, cable)
    twist = np.abs(np.concatenate(twists)) / h if twists else np.zeros(0)
    dist, edge, obstacle = probe.min_distance(data, cable, points)
    ik, it = int(np.argmax(kappa)), int(np.argmax(tension))
    n_edges = len(points) - 1
    tension_at = (it + 0.5) * h if it < n_edges else cable.attachments[it - n_edges].node.arc_length
    values = (float(kappa[ik]), float(max(tension.max(), 0.0)), float(dist),
              float(twist.max()) if len(twist) else 0.0)
    extra = (max((abs(float(t.sum())) for t in twists), default=0.0),
             float(max(0.0, -np.nanmin(edges))) if np.isfinite(edges).any() else 0.0,
             float(np.linalg.norm(forces, axis=1).max()), float(np.linalg.norm(torques, axis=1).max()))
    if not all(np.isfinite(values + extra)):
        raise SimulationError(f"wear measures of robot {cable.robot!r} are not finite: {values + extra}")
    return WearMeasures(*values, curvature_at=(ik + 1) * h, tension_at=tension_at,
                        clearance_at=(edge + 0.5) * h if edge >= 0 else 0.0, nearest_obstacle=obstacle,
                        total_twist=extra[0], max_compression=extra[1], max_node_force=extra[2],
                        max_node_torque=extra[3])
