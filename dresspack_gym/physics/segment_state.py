"""The state of every cable segment at one instant: bending (signed, in the material frame), twist, strain and
contact (normal force, friction force, sliding speed) -- the inputs of per-segment damage and fatigue life.

A segment is the piece of cable around one vertex (vertex i covers arc lengths (i - 1/2) h .. (i + 1/2) h). Bending
and twist live at vertices (discrete elastic rods), strain on edges (averaged onto the two vertices of each edge),
and MuJoCo reports cable contacts per vertex.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..stations.station import CableIndex
from .measures import CableArrays, CableSample, cross

SLIP_SPEED = 1e-3  # [m/s] below this a contact sticks (relaxation creep, not sliding)


@dataclass(frozen=True)
class SegmentState:
    """Per vertex (n + 1 values each) at one instant."""

    curvature: np.ndarray  # [1/m], Menger curvature (0 at the ends), as measures.vertex_curvatures
    bend: np.ndarray  # (n + 1, 2) curvature vector in the material frame (d1, d2) [1/m]; |bend| = curvature
    twist_rate: np.ndarray  # material twist per length [rad/m], signed
    strain: np.ndarray  # axial strain (tension / EA; negative = compressed)
    normal_force: np.ndarray  # contact normal force on the segment [N]
    friction_force: np.ndarray  # contact friction force on the segment [N]
    slip_speed: np.ndarray  # tangential speed of the segment relative to what it touches [m/s]

    @property
    def friction_power(self) -> np.ndarray:
        """Friction force x sliding speed [W]: the rate of sliding wear (zero while sticking or free)."""
        return self.friction_force * self.slip_speed


class SegmentStateReader:
    """Reads :class:`SegmentState` of one cable from a simulator's MjData (private scratch, no side effects)."""

    def __init__(self, model: mujoco.MjModel, cable: CableIndex, tensile_stiffness: float):
        self.model = model
        self.cable = cable
        self.arrays = CableArrays(cable)
        self.ea = float(tensile_stiffness)
        n = cable.n_vertices
        self.flex_vertex = {}  # flex id -> global vertex index of each of its local vertices
        for p in cable.pieces:
            self.flex_vertex[p.flex_id] = np.asarray(p.piece.vertices, dtype=int)
        # by flex id (+1 row for -1, a contact's side without a flex): whether it is one of this cable's rods
        self.own_flex = np.zeros(model.nflex + 1, dtype=bool)
        self.own_flex[list(self.flex_vertex)] = True
        self.vertex_body = np.full(n, -1, dtype=int)
        for p in cable.pieces:
            adr = int(model.flex_vertadr[p.flex_id])
            for j, v in enumerate(p.piece.vertices):
                self.vertex_body[v] = int(model.flex_vertbodyid[adr + j])
        self._force = np.zeros(6)
        self._vel = np.zeros(6)

    def read(self, data: mujoco.MjData, live: mujoco.MjData | None = None) -> SegmentState:
        """The state of ``data`` (the simulator's static-force pass: shape, tensions, contact forces at rest)
        with sliding speeds from ``live`` (the running simulation's velocities; none: no sliding)."""
        return self.state(data, live, self.arrays.sample(data))

    def state(self, data: mujoco.MjData, live: mujoco.MjData | None, sample: CableSample) -> SegmentState:
        """:meth:`read` from the cable's ``sample`` of ``data`` (shared with its wear measures)."""
        n = self.cable.n_vertices
        kappa = np.zeros(n)
        kappa[1:-1] = sample.curvature
        bend = np.zeros((n, 2))
        twist = np.zeros(n)
        d1 = self._material_d1(data, sample.theta)
        kb, norm = sample.binormal, sample.area  # the curvature binormal's direction
        axis = np.divide(kb, norm[:, None], out=np.zeros_like(kb), where=norm[:, None] > 1e-15)
        t = sample.edges[:-1] / sample.lengths[:-1, None]
        d1v = d1[:-1]  # the material frame of the edge entering each interior vertex
        d2v = cross(t, d1v)
        bend[1:-1, 0] = kappa[1:-1] * np.einsum("ij,ij->i", axis, d1v)
        bend[1:-1, 1] = kappa[1:-1] * np.einsum("ij,ij->i", axis, d2v)
        twist[self.arrays.twist_vertices] = sample.twists / self.cable.segment_length
        edge_strain = self.arrays.filled_tensions(sample, 0.0) / self.ea
        strain = np.zeros(n)
        strain[:-1] += 0.5 * edge_strain
        strain[1:] += 0.5 * edge_strain
        strain[0] *= 2.0  # the end vertices have one edge
        strain[-1] *= 2.0
        normal, friction, slip = self._contacts(data, live, n)
        return SegmentState(kappa, bend, twist, strain, normal, friction, slip)

    def _material_d1(self, data: mujoco.MjData, theta: np.ndarray | None = None) -> np.ndarray:
        """(n, 3) material director d1 of every edge: MuJoCo's time-parallel reference frame (tangent, d1_ref per
        edge in mjData.plastic) turned by the edge's twist angle ``theta`` (CableArrays.twists; read from ``data``
        if not given); a clamped edge's frame is its node's."""
        arrays = self.arrays
        theta = arrays.twists(data)[0] if theta is None else theta
        frames = data.plastic[arrays.frame_rows].reshape(-1, 6)
        tan, ref = frames[:, :3], frames[:, 3:]
        # d1 = cos(theta) d1_ref + sin(theta) (t x d1_ref): checked against the clamps of a twisted rod, whose
        # material frame turns continuously from one clamp's frame to the other's.
        d1 = np.cos(theta)[:, None] * ref + np.sin(theta)[:, None] * cross(tan, ref)
        return d1[arrays.edge_row]

    def _contacts(self, data: mujoco.MjData, live: mujoco.MjData | None, n: int):
        """Per vertex: normal force, friction force and sliding speed of its contacts. A sliding contact carries
        Coulomb friction mu * N (the static pass only knows the friction that would hold it at rest)."""
        m = self.model
        normal, friction, slip = np.zeros(n), np.zeros(n), np.zeros(n)
        if data.ncon == 0:
            return normal, friction, slip
        ours = self.own_flex[data.contact.flex]  # (ncon, 2): which sides of which contacts are this cable's
        for i in np.flatnonzero(ours[:, 0] | ours[:, 1]).tolist():
            c = data.contact[i]
            for side in (0, 1):
                touched = self._touched(data, c, side) if ours[i, side] else []
                if not touched:
                    continue
                mujoco.mj_contactForce(m, data, i, self._force)
                frame = c.frame.reshape(3, 3)  # rows: normal, two tangents
                speed = 0.0
                if live is not None:
                    mine = sum(w * self._velocity_at(live, self.vertex_body[v], c.pos) for v, w in touched)
                    rel = mine - self._other_velocity(live, c, side)
                    speed = float(np.linalg.norm(rel - np.dot(rel, frame[0]) * frame[0]))
                fn = abs(float(self._force[0]))
                ft = c.friction[0] * fn if speed > SLIP_SPEED else float(np.linalg.norm(self._force[1:3]))
                for v, w in touched:  # an edge contact is shared by its two vertices by where it lies
                    normal[v] += w * fn
                    friction[v] += w * ft
                    slip[v] = max(slip[v], speed)
        return normal, friction, slip

    def _touched(self, data: mujoco.MjData, c, side: int) -> list[tuple[int, float]]:
        """(vertex, share) of this cable that contact ``c`` touches on ``side``: a vertex (contacts with geoms)
        or an edge (flex-flex contacts), split between its two vertices by the contact point's position."""
        verts = self.flex_vertex.get(int(c.flex[side]))
        if verts is None:
            return []
        if c.vert[side] >= 0:
            return [(int(verts[c.vert[side]]), 1.0)]
        e = int(c.elem[side])
        if e < 0 or e + 1 >= len(verts):
            return []
        a, b = int(verts[e]), int(verts[e + 1])
        pa, pb = data.flexvert_xpos[self.cable.point_rows[a]], data.flexvert_xpos[self.cable.point_rows[b]]
        axis = pb - pa
        s = float(np.clip(np.dot(c.pos - pa, axis) / max(float(axis @ axis), 1e-15), 0.0, 1.0))
        return [(a, 1.0 - s), (b, s)]

    def _velocity_at(self, data: mujoco.MjData, body: int, point: np.ndarray) -> np.ndarray:
        """Linear velocity of ``body``'s material point at ``point`` (world frame)."""
        mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_BODY, int(body), self._vel, 0)
        return self._vel[3:] + cross(self._vel[:3], point - data.xipos[body])

    def _other_velocity(self, data: mujoco.MjData, c, side: int) -> np.ndarray:
        """Velocity of what the cable touches at the contact: a geom's body, or a flex vertex / edge (another
        robot's cable; the body ids of its vertices are the model's, so any flex works)."""
        other = 1 - side
        if c.geom[other] >= 0:
            return self._velocity_at(data, int(self.model.geom_bodyid[c.geom[other]]), c.pos)
        flex = int(c.flex[other])
        if flex < 0:
            return np.zeros(3)
        adr = int(self.model.flex_vertadr[flex])
        if c.vert[other] >= 0:
            return self._velocity_at(data, int(self.model.flex_vertbodyid[adr + c.vert[other]]), c.pos)
        e = int(c.elem[other])  # a 1D flex's element e joins its local vertices e and e + 1
        bodies = self.model.flex_vertbodyid[adr + e:adr + e + 2]
        return 0.5 * sum(self._velocity_at(data, int(b), c.pos) for b in bodies)
