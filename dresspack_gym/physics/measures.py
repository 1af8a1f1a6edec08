"""Wear measures of a settled cable (thesis §4.3): curvature, tension, clearance, twist and node loads.

All functions read a compiled :class:`~dresspack_gym.stations.station.Station` and an ``MjData`` after
``mj_forward``/``mj_step`` (so ``xpos`` and constraint forces are current).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import SimulationError
from ..stations.station import CableIndex, Station, as_slice

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
    excursion_damage: float = 0.0  # fatigue damage of one excursion to this state, worst segment (fatigue.py)

    @staticmethod
    def worst(items: list["WearMeasures"]) -> "WearMeasures":
        """Station-level measures: the worst value of each measure over all cables."""
        if len(items) == 1:
            return items[0]
        kc = max(items, key=lambda m: m.max_curvature)
        kt = max(items, key=lambda m: m.max_tension)
        kd = min(items, key=lambda m: m.min_clearance)
        kr = max(items, key=lambda m: m.max_damage_rate)
        return WearMeasures(kc.max_curvature, kt.max_tension, kd.min_clearance,
                            max(m.max_twist_rate for m in items), kc.curvature_at, kt.tension_at, kd.clearance_at,
                            kd.nearest_obstacle, max(m.total_twist for m in items),
                            max(m.max_compression for m in items), max(m.max_node_force for m in items),
                            max(m.max_node_torque for m in items), kr.max_damage_rate, kr.damage_at,
                            max(m.excursion_damage for m in items))


def cable_points(data: mujoco.MjData, cable: CableIndex) -> np.ndarray:
    """World positions of the cable vertices, shape (n+1, 3) (free vertices and those nodes hold)."""
    return data.flexvert_xpos[cable.point_rows].copy()


# a x b = a[_NEXT] b[_PREV] - a[_PREV] b[_NEXT], component by component
_NEXT, _PREV = np.array([1, 2, 0]), np.array([2, 0, 1])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis of (..., 3) arrays: np.cross's arithmetic without its generic axis
    handling, which cost more than the math for the few vectors here (it was 6 % of a training step)."""
    return a.take(_NEXT, axis=-1) * b.take(_PREV, axis=-1) - a.take(_PREV, axis=-1) * b.take(_NEXT, axis=-1)


def _norms(v: np.ndarray) -> np.ndarray:
    """Euclidean norms over the last axis: np.linalg.norm's own arithmetic (so the same bits) without its dispatch."""
    return np.sqrt(np.add.reduce(v * v, axis=-1))


@dataclass(frozen=True)
class CableSample:
    """One cable's shape, edge forces and twists at one instant: what its wear measures and its segment states
    share, read once (:meth:`CableArrays.sample`)."""

    points: np.ndarray  # (n+1, 3) vertex positions
    edges: np.ndarray  # (n, 3) edge vectors
    lengths: np.ndarray  # (n,) edge lengths
    binormal: np.ndarray  # (n-1, 3) e0 x e1 at each interior vertex (the curvature binormal's direction)
    area: np.ndarray  # (n-1,) |e0 x e1|
    curvature: np.ndarray  # (n-1,) Menger curvature of each interior vertex (vertex_curvatures)
    tensions: np.ndarray  # (n,) axial edge forces, NaN for rigid edges (edge_tensions)
    stretch_forces: np.ndarray  # the stretchable edges' forces, rod after rod
    finite_forces: bool  # all of stretch_forces finite: NaN in ``tensions`` marks the rigid edges only
    theta: np.ndarray  # twist angle of every rod edge, rod after rod (0 for a clamped edge)
    twists: np.ndarray  # material twist of every rod's interior vertices, rod after rod (vertex_twists)
    twist_slices: tuple[slice, ...]  # each rod's part of ``twists``

    @property
    def rod_twists(self) -> list[np.ndarray]:
        return [self.twists[s] for s in self.twist_slices]


def _bends(points: np.ndarray) -> tuple[np.ndarray, ...]:
    """(edges, lengths, binormal, area, curvature) of a polyline (see :func:`vertex_curvatures`)."""
    edges = points[1:] - points[:-1]
    lengths = _norms(edges)
    binormal = cross(edges[:-1], edges[1:])
    area = _norms(binormal)
    denom = lengths[:-1] * lengths[1:] * _norms(edges[:-1] + edges[1:])
    return edges, lengths, binormal, area, 2.0 * area / np.maximum(denom, 1e-15)


def vertex_curvatures(points: np.ndarray) -> np.ndarray:
    """Curvature at each interior vertex: the circle through the vertex and its neighbours.

    kappa = 2 |e0 x e1| / (|e0| |e1| |e0 + e1|) (Menger curvature) is exact for points on an arc.
    """
    return _bends(np.asarray(points))[4]


class CableArrays:
    """One cable's addresses and constants for reading its measures, gathered into index arrays once: with ~25
    vertices the cost of a measure is numpy's per-call overhead, so every rod, node and edge is read in one
    vectorised call instead of a Python loop."""

    def __init__(self, cable: CableIndex):
        self.cable = cable
        pieces = cable.pieces
        self.n_edges = cable.n_vertices - 1
        # each rod's stretchable edges, in the order of its equality constraint rows
        self.rod_edges = [(p.edge_eq_id, np.asarray(p.piece.vertices[:-1], dtype=int)[~p.rigid_edge])
                          for p in pieces]
        self.rigid = np.ones(self.n_edges, dtype=bool)
        for _, edges in self.rod_edges:
            self.rigid[edges] = False
        # the rods' edges (twist hinges and DER frames), rod after rod. Consecutive rods share the edge of the clamp
        # between them: the material frame of a cable edge is that of its last rod (a slice when that is every edge
        # in order, as for a cable of one rod).
        rod_edge = np.concatenate([np.asarray(p.piece.vertices[:-1], dtype=int) for p in pieces])
        edge_row = np.full(self.n_edges, -1)
        for row, e in enumerate(rod_edge):
            edge_row[e] = row
        if (edge_row < 0).any():
            raise SimulationError(f"cable of robot {cable.robot!r}: edges {np.flatnonzero(edge_row < 0)} lie in no rod")
        self.edge_row = as_slice(edge_row)
        twist_qpos = np.concatenate([p.twist_qpos for p in pieces])
        self.hinged, self.twist_qpos = twist_qpos >= 0, np.maximum(twist_qpos, 0)
        self.frame_rows = np.concatenate([p.plastic_adr + np.arange(6 * p.piece.n_edges) for p in pieces])
        # interior vertices: the rod edges before and after each, its reference twist (after the rod's frames in
        # mjData.plastic) and its global index
        first = np.cumsum([0] + [p.piece.n_edges for p in pieces])
        self.after = np.concatenate([np.arange(a + 1, b) for a, b in zip(first[:-1], first[1:])])
        self.before = self.after - 1
        self.ref_twist_rows = np.concatenate([p.plastic_adr + 6 * p.piece.n_edges + np.arange(p.piece.n_edges - 1)
                                              for p in pieces])
        self.twist_vertices = np.concatenate([np.asarray(p.piece.vertices[1:-1], dtype=int) for p in pieces])
        self.twist_slices = tuple(slice(a - i, b - i - 1) for i, (a, b) in enumerate(zip(first[:-1], first[1:])))
        # nodes: load-cell dofs, slide axes, held masses (zero-padded to the most any node holds)
        atts = cable.attachments
        k, held = len(atts), max((len(a.held_mass) for a in atts), default=0)
        self.load_dof = np.asarray(cable.load_dof, dtype=int).reshape(k, 6)
        self.node_bodies = np.asarray(cable.node_bodies, dtype=int)
        self.slide_to_node = np.array([a.slide_to_node for a in atts], dtype=float).reshape(k, 3, 3)
        self.held_total = np.array([sum(a.held_mass) for a in atts], dtype=float)
        self.held_mass = np.zeros((k, held))
        self.held_at = np.zeros((k, held, 3))
        for i, a in enumerate(atts):
            if a.held_mass:
                self.held_mass[i, :len(a.held_mass)] = a.held_mass
                self.held_at[i, :len(a.held_at)] = a.held_at
        # node tensions: the cable vertices beside each node's outer vertex (at most two; a clamp at a cable end
        # has one); ``side_table`` lists each node's, padded with an entry past the last
        n = cable.n_vertices - 1
        sides = [[s for s in (a.vertices[-1] + 1, a.vertices[-1] - 1) if 0 <= s <= n and s not in a.vertices]
                 for a in atts]
        self.side_vertex = np.array([s for ss in sides for s in ss], dtype=int)
        self.side_outer = np.array([a.vertices[-1] for a, ss in zip(atts, sides) for _ in ss], dtype=int)
        self.side_node = np.array([i for i, ss in enumerate(sides) for _ in ss], dtype=int)
        self.one_side = all(len(ss) == 1 for ss in sides)
        self.side_table = np.full((k, 2), len(self.side_vertex), dtype=int)
        for i in range(k):
            rows = np.flatnonzero(self.side_node == i)
            self.side_table[i, :len(rows)] = rows
        self.has_side = np.array([bool(ss) for ss in sides], dtype=bool)

    def sample(self, data: mujoco.MjData) -> CableSample:
        """The cable's shape, edge forces and twists in ``data``."""
        points = cable_points(data, self.cable)
        edges, lengths, binormal, area, curvature = _bends(points)
        tensions, forces = self._edge_forces(data)
        theta, twists = self.twists(data)
        return CableSample(points, edges, lengths, binormal, area, curvature, tensions, forces,
                           bool(np.isfinite(forces).all()), theta, twists, self.twist_slices)

    def twists(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """(theta, twists): every rod edge's twist angle and every rod's interior material twists, rod after rod."""
        theta = np.where(self.hinged, data.qpos[self.twist_qpos], 0.0)
        return theta, (theta[self.after] - theta[self.before]) + data.plastic[self.ref_twist_rows]

    def _edge_forces(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """(edge_tensions, the stretchable edges' forces rod after rod)."""
        out = np.full(self.n_edges, np.nan)
        # MuJoCo orders the constraint rows by type, equality rows first (data.ne of them)
        eq_id, eq_force = data.efc_id[:data.ne], data.efc_force[:data.ne]
        rods = []
        for rod_eq, edges in self.rod_edges:
            forces = -eq_force[eq_id == rod_eq]
            if len(forces) != len(edges):
                raise SimulationError(f"cable of robot {self.cable.robot!r}: {len(forces)} edge constraint rows for "
                                      f"{len(edges)} stretchable edges")
            out[edges] = forces
            rods.append(forces)
        return out, (rods[0] if len(rods) == 1 else np.concatenate(rods))

    def filled_tensions(self, sample: CableSample, nan: float) -> np.ndarray:
        """``np.nan_to_num(sample.tensions, nan=nan)`` (at a tenth of its cost while the forces are finite)."""
        if sample.finite_forces:
            return np.where(self.rigid, nan, sample.tensions)
        return np.nan_to_num(sample.tensions, nan=nan)

    def node_rotations(self, data: mujoco.MjData) -> np.ndarray:
        """(n_nodes, 3, 3) world rotation of each node body."""
        return data.xmat[self.node_bodies].reshape(-1, 3, 3)

    def node_loads(self, model: mujoco.MjModel, data: mujoco.MjData,
                   rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`node_loads` with the node bodies' rotations ``rot``."""
        dof = self.load_dof
        f = data.qfrc_spring[dof] + data.qfrc_damper[dof] + data.qfrc_constraint[dof]
        g_local = np.matmul(rot.transpose(0, 2, 1), model.opt.gravity)
        forces = np.matmul(self.slide_to_node, f[:, :3, None])[:, :, 0] + self.held_total[:, None] * g_local
        torques = f[:, 3:]
        if self.held_mass.shape[1]:  # the held vertices' weights about the node point, summed vertex by vertex
            held = cross(self.held_at, self.held_mass[:, :, None] * g_local[:, None, :])
            moment = held[:, 0]
            for j in range(1, held.shape[1]):
                moment = moment + held[:, j]
            torques = torques + moment
        return forces, torques

    def node_tensions(self, points: np.ndarray, forces: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """:func:`node_tensions` with the node bodies' rotations ``rot``."""
        f_world = np.matmul(rot, forces[:, :, None])[:, :, 0]
        v = points[self.side_vertex] - points[self.side_outer]
        unit = v / np.maximum(_norms(v), 1e-12)[:, None]
        pull = np.add.reduce(f_world[self.side_node] * unit, axis=-1)
        if self.one_side:
            return pull
        return np.where(self.has_side, np.append(pull, -np.inf)[self.side_table].max(axis=1), 0.0)

    def measure(self, station: Station, data: mujoco.MjData, probe: "ClearanceProbe", sample: CableSample, *,
                max_damage_rate: float = 0.0, damage_at: float = 0.0, excursion_damage: float = 0.0) -> WearMeasures:
        """The cable's :class:`WearMeasures` (see :func:`measure_cable`) from its ``sample`` of ``data``."""
        cable, points = self.cable, sample.points
        if not np.isfinite(points).all():
            raise SimulationError(f"cable of robot {cable.robot!r} has non-finite vertex positions")
        h = cable.segment_length
        kappa, edges = sample.curvature, sample.tensions
        rot = self.node_rotations(data)
        forces, torques = self.node_loads(station.model, data, rot)
        tension = np.concatenate([self.filled_tensions(sample, -np.inf), self.node_tensions(points, forces, rot)])
        twist = np.abs(sample.twists) / h
        dist, edge, obstacle = probe._min_distance(data, cable, points, 0.5 * (points[1:] + points[:-1]),
                                                   0.5 * sample.lengths)
        ik, it = int(np.argmax(kappa)), int(np.argmax(tension))
        n_edges = len(points) - 1
        tension_at = (it + 0.5) * h if it < n_edges else cable.attachments[it - n_edges].node.arc_length
        if sample.finite_forces:
            push = sample.stretch_forces
            compression = float(max(0.0, -push.min())) if len(push) else 0.0
        else:
            compression = float(max(0.0, -np.nanmin(edges))) if np.isfinite(edges).any() else 0.0
        values = (float(kappa[ik]), float(max(tension.max(), 0.0)), float(dist),
                  float(twist.max()) if len(twist) else 0.0)
        extra = (max((abs(float(t.sum())) for t in sample.rod_twists), default=0.0), compression,
                 float(_norms(forces).max()), float(_norms(torques).max()))
        if not all(map(math.isfinite, values + extra)):
            raise SimulationError(f"wear measures of robot {cable.robot!r} are not finite: {values + extra}")
        return WearMeasures(*values, curvature_at=(ik + 1) * h, tension_at=tension_at,
                            clearance_at=(edge + 0.5) * h if edge >= 0 else 0.0, nearest_obstacle=obstacle,
                            total_twist=extra[0], max_compression=extra[1], max_node_force=extra[2],
                            max_node_torque=extra[3], max_damage_rate=max_damage_rate, damage_at=damage_at,
                            excursion_damage=excursion_damage)


def edge_tensions(model: mujoco.MjModel, data: mujoco.MjData, cable: CableIndex) -> np.ndarray:
    """Axial force of each cable edge [N] (positive = pulled, negative = pushed), NaN for rigid clamp edges.

    The force of an edge's equality row: with the edge compliance of cable_model.edge_constraint it is
    EA * strain. A clamp's own edge lies on one rigid node body and carries no row.
    """
    return CableArrays(cable)._edge_forces(data)[0]


def node_loads(model: mujoco.MjModel, data: mujoco.MjData, cable: CableIndex) -> tuple[np.ndarray, np.ndarray]:
    """(forces, torques), each (n_nodes, 3): what the cable exerts on each node, in the node's frame.

    Read from the node's kinematic load cell: the generalised forces on its three slides (along the
    node body's rest axes, rotated into the node frame) and its ball joint (torque in the node frame,
    about the node point). Elastic, damping and constraint (edge, contact) forces are included, plus the
    weight of the cable piece the node holds (its lumped vertex masses); the node body's own (negligible)
    gravity is not. For a clamp, x is the cable direction.
    """
    arrays = CableArrays(cable)
    return arrays.node_loads(model, data, arrays.node_rotations(data))


def node_tensions(cable: CableIndex, points: np.ndarray, forces: np.ndarray, body_rot: list[np.ndarray]) -> np.ndarray:
    """Tension where the cable enters each node [N]: the node load's component pulling into the cable.

    For a cable hanging from a clamp at its top this is the cable's whole weight.
    """
    rot = np.asarray(body_rot, dtype=float).reshape(-1, 3, 3)
    return CableArrays(cable).node_tensions(np.asarray(points), np.asarray(forces, dtype=float), rot)


def vertex_twists(model: mujoco.MjModel, data: mujoco.MjData, cable: CableIndex) -> list[np.ndarray]:
    """Material twist [rad] at each interior vertex of each rod: theta_e - theta_(e-1) + reference twist.

    theta_e is the angle of edge e's twist hinge (0 for an edge a clamp holds: its material frame is the
    node body's); the reference twist is the twist of the time-parallel reference frames that MuJoCo
    keeps in ``mjData.plastic`` after the 6 numbers per edge of the frames themselves (DER, Bergou et al.).
    """
    arrays = CableArrays(cable)
    twists = arrays.twists(data)[1]
    return [twists[s] for s in arrays.twist_slices]


def _edge_capsules(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each cable edge's midpoint and half length: its capsule's centre and half axis."""
    return 0.5 * (points[1:] + points[:-1]), 0.5 * _norms(points[1:] - points[:-1])


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
        self.box_geoms = self.obstacles[self.box_cols]
        self.n_boxes, self.box_index = len(self.box_cols), as_slice(self.box_cols)  # a slice selects as a view
        self.n_planes, self.plane_index = int(self.is_plane.sum()), as_slice(np.flatnonzero(self.is_plane))
        self.plane_geoms = self.obstacles[self.plane_index]
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
        gap = mids[:, None, :] - centers[None, :, :]
        lb = _norms(gap) - half[:, None] - self.rbound[None, :] - cable.radius
        if self.n_boxes:
            # an edge's bounding sphere (centre mid, radius half + r) outside a box: the gap from its centre to
            # the box less that radius bounds the capsule's distance; a positive one only (a sphere reaching into
            # the box bounds no penetration depth), else the sphere-sphere bound stays
            box = self.box_index
            frames = data.geom_xmat[self.box_geoms].reshape(-1, 3, 3)
            d = gap[:, box]
            # the gap in the box frame: d_k frame_kj summed over k in order, as np.einsum does, at half its cost
            local = d[..., 0, None] * frames[:, 0] + d[..., 1, None] * frames[:, 1] + d[..., 2, None] * frames[:, 2]
            outside = np.maximum(np.abs(local) - self.box_half[None], 0.0)
            box_lb = np.sqrt(np.einsum("ebk,ebk->eb", outside, outside)) - half[:, None] - cable.radius
            lb[:, box] = np.maximum(lb[:, box], np.where(box_lb > 0.0, box_lb, -np.inf))
        if self.n_planes:  # a plane's exact distance is cheap: the nearer end's height less the radius
            normals = data.geom_xmat[self.plane_geoms].reshape(-1, 3, 3)[:, :, 2]
            offs = np.einsum("pk,pk->p", normals, centers[self.plane_index])
            vd = points @ normals.T - offs[None, :] - cable.radius  # (n+1, planes)
            lb[:, self.plane_index] = np.minimum(vd[1:], vd[:-1])
        return lb

    def min_distance(self, data: mujoco.MjData, cable: CableIndex, points: np.ndarray, *,
                     signed: bool = False, planes: bool = True) -> tuple[float, int, str]:
        """(distance, edge index, obstacle name) of the nearest obstacle; (MAX_CLEARANCE, -1, '') if none.
        The distance is 0 in contact, or with ``signed`` negative by the depth of the deepest penetration (a
        predicted shape may pass through an obstacle; a simulated one only touches it). ``planes=False`` leaves
        the planes (the floor) out."""
        return self._min_distance(data, cable, points, *_edge_capsules(points), signed=signed, planes=planes)

    def _min_distance(self, data: mujoco.MjData, cable: CableIndex, points: np.ndarray, mids: np.ndarray,
                      half: np.ndarray, *, signed: bool = False, planes: bool = True) -> tuple[float, int, str]:
        if len(self.obstacles) == 0 or (not planes and self.is_plane.all()):
            return MAX_CLEARANCE, -1, ""
        m = self.station.model
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
    """The wear measures of ``cable`` in ``data`` (damage fields left 0: they need its segment state)."""
    arrays = CableArrays(cable)
    return arrays.measure(station, data, probe, arrays.sample(data))
