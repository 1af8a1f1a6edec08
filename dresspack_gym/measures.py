"""Wear measures of a settled cable (thesis §4.3): curvature, tension, clearance, plus twist rate.

All functions read a compiled :class:`~dresspack_gym.station.Station` and an ``MjData`` after
``mj_forward``/``mj_step`` (so ``xpos`` and constraint forces are current).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import mujoco
import numpy as np

from .errors import SimulationError
from .station import CableIndex, Station

# Distances beyond this are not refined (the cost only cares about the clearance threshold c).
MAX_CLEARANCE = 10.0


@dataclass(frozen=True)
class WearMeasures:
    """The measures of one cable configuration; ``*_at`` are arc lengths [m] along the cable."""

    max_curvature: float  # kappa [1/m]
    max_tension: float  # F [N]
    min_clearance: float  # d [m], 0 in contact
    max_twist_rate: float  # [rad/m]
    curvature_at: float = 0.0
    tension_at: float = 0.0
    clearance_at: float = 0.0
    nearest_obstacle: str = ""

    def as_dict(self) -> dict:
        return asdict(self)

    @staticmethod
    def worst(items: list["WearMeasures"]) -> "WearMeasures":
        """Station-level measures: the worst value of each measure over all cables."""
        kc = max(items, key=lambda m: m.max_curvature)
        kt = max(items, key=lambda m: m.max_tension)
        kd = min(items, key=lambda m: m.min_clearance)
        kw = max(items, key=lambda m: m.max_twist_rate)
        return WearMeasures(kc.max_curvature, kt.max_tension, kd.min_clearance, kw.max_twist_rate,
                            kc.curvature_at, kt.tension_at, kd.clearance_at, kd.nearest_obstacle)


def cable_points(data: mujoco.MjData, cable: CableIndex) -> np.ndarray:
    """World positions of the cable vertices, shape (n+1, 3)."""
    return data.xpos[cable.vertex_bodies].copy()


def vertex_curvatures(points: np.ndarray) -> np.ndarray:
    """Curvature at each interior vertex: the circle through the vertex and its neighbours.

    kappa = 2 |e0 x e1| / (|e0| |e1| |e0 + e1|) (Menger curvature) is exact for points on an arc.
    """
    e0 = points[1:-1] - points[:-2]
    e1 = points[2:] - points[1:-1]
    cross = np.linalg.norm(np.cross(e0, e1), axis=1)
    denom = np.linalg.norm(e0, axis=1) * np.linalg.norm(e1, axis=1) * np.linalg.norm(e0 + e1, axis=1)
    return 2.0 * cross / np.maximum(denom, 1e-15)


def edge_tensions(model: mujoco.MjModel, data: mujoco.MjData, cable: CableIndex) -> np.ndarray:
    """Tension of each edge [N] from the flex edge-equality constraint forces (positive = pulled)."""
    rows = (data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY) & (data.efc_id == cable.edge_eq_id)
    return -data.efc_force[rows]


def node_tensions(model: mujoco.MjModel, data: mujoco.MjData, cable: CableIndex, points: np.ndarray) -> np.ndarray:
    """Tension where the cable enters each node [N]: the node's reaction force along the cable.

    The connect forces (``efc_force``, the force on the cable vertex) of all vertices a node holds add
    up to the force the node applies to the cable; its component pulling the cable towards the node is
    the continuum tension at the attachment (for a hanging cable: its whole weight, rho g L).
    """
    out = np.zeros(len(cable.attachments))
    eq_rows = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    n = len(points) - 1
    for k, (att, eq_ids) in enumerate(zip(cable.attachments, cable.node_eq_ids)):
        force = np.zeros(3)
        for eq in eq_ids:
            force += data.efc_force[eq_rows & (data.efc_id == eq)]
        v = att.vertices[0]
        # Unit vector from the cable into the node: against the arc-length direction at a start
        # node, along it at an end node; interior nodes pull both ways, use the larger side.
        if v == 0:
            toward = [points[0] - points[1]]
        elif v == n:
            toward = [points[n] - points[n - 1]]
        else:
            toward = [points[v] - points[v + 1], points[v] - points[v - 1]]
        out[k] = max(float(force @ (t / max(np.linalg.norm(t), 1e-12))) for t in toward)
    return out


def twist_rates(model: mujoco.MjModel, data: mujoco.MjData, cable: CableIndex) -> np.ndarray:
    """Material twist per unit length at each interior vertex [rad/m]: (theta_e - theta_{e-1}) / h.

    theta_e is the DER material angle of edge e relative to its time-parallel-transported reference
    frame (the ``<flex>_twist*`` hinge joints; 0 for a clamped edge). The extra numbers MuJoCo keeps
    after the frames in ``mjData.plastic`` carry no torque (checked: bent, writhed cables with free
    ends show zero twist torque), so they are not part of the material twist.
    """
    theta = np.where(cable.twist_qpos >= 0, data.qpos[np.maximum(cable.twist_qpos, 0)], 0.0)
    return np.abs(np.diff(theta)) / cable.segment_length


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
        self.names = [m.geom(g).name.removeprefix("obstacle/") for g in self.obstacles]
        self._fromto = np.zeros(6)
        self._quat = np.zeros(4)
        self._rot = np.zeros(9)

    def min_distance(self, data: mujoco.MjData, cable: CableIndex, points: np.ndarray) -> tuple[float, int, str]:
        """(distance, edge index, obstacle name) of the nearest obstacle; (MAX_CLEARANCE, -1, '') if none."""
        if len(self.obstacles) == 0:
            return MAX_CLEARANCE, -1, ""
        m = self.station.model
        mids = 0.5 * (points[1:] + points[:-1])
        half = 0.5 * np.linalg.norm(points[1:] - points[:-1], axis=1)
        centers = data.geom_xpos[self.obstacles]
        lb = np.linalg.norm(mids[:, None, :] - centers[None, :, :], axis=2)
        lb = lb - half[:, None] - self.rbound[None, :] - cable.radius
        lb[:, self.is_plane] = -np.inf  # planes are unbounded: always check them exactly
        plane_cols = np.where(self.is_plane)[0]
        if len(plane_cols):  # a plane's exact distance is cheap; compute it in numpy
            normals = data.geom_xmat[self.obstacles[plane_cols]].reshape(-1, 3, 3)[:, :, 2]
            offs = np.einsum("pk,pk->p", normals, centers[plane_cols])
            vd = points @ normals.T - offs[None, :] - cable.radius  # (n+1, planes)
            lb[:, plane_cols] = np.minimum(vd[1:], vd[:-1])
            exact_plane = True
        else:
            exact_plane = False
        order = np.argsort(lb, axis=None)
        best, best_edge, best_obs = MAX_CLEARANCE, -1, -1
        size = m.geom_size[self.probe]
        for flat in order:
            e, o = divmod(int(flat), len(self.obstacles))
            if lb[e, o] >= best:
                break
            if exact_plane and self.is_plane[o]:
                dist = lb[e, o]
            else:
                data.geom_xpos[self.probe] = mids[e]
                mujoco.mju_quatZ2Vec(self._quat, points[e + 1] - points[e])
                mujoco.mju_quat2Mat(self._rot, self._quat)
                data.geom_xmat[self.probe] = self._rot
                size[0], size[1] = cable.radius, max(half[e], 1e-6)
                dist = mujoco.mj_geomDistance(m, data, self.probe, int(self.obstacles[o]), best, self._fromto)
            if dist < best:
                best, best_edge, best_obs = dist, e, o
        return max(best, 0.0), best_edge, (self.names[best_obs] if best_obs >= 0 else "")


def measure_cable(station: Station, data: mujoco.MjData, cable: CableIndex, probe: ClearanceProbe) -> WearMeasures:
    points = cable_points(data, cable)
    if not np.isfinite(points).all():
        raise SimulationError(f"cable of robot {cable.robot!r} has non-finite vertex positions")
    h = cable.segment_length
    kappa = vertex_curvatures(points)
    tension = np.concatenate([edge_tensions(station.model, data, cable),
                              node_tensions(station.model, data, cable, points)])
    twist = twist_rates(station.model, data, cable)
    dist, edge, obstacle = probe.min_distance(data, cable, points)
    ik, it = int(np.argmax(kappa)), int(np.argmax(tension))
    n_edges = len(points) - 1
    tension_at = (it + 0.5) * h if it < n_edges else cable.attachments[it - n_edges].node.arc_length
    values = (float(kappa[ik]), float(max(tension.max(), 0.0)), float(dist),
              float(twist.max()) if len(twist) else 0.0)
    if not all(np.isfinite(values)):
        raise SimulationError(f"wear measures of robot {cable.robot!r} are not finite: {values}")
    return WearMeasures(*values, curvature_at=(ik + 1) * h, tension_at=tension_at,
                        clearance_at=(edge + 0.5) * h if edge >= 0 else 0.0, nearest_obstacle=obstacle)
