"""A station's dresspack as the rod engine holds it: the rod model, and where its nodes put the held vertices."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..cable.config import DresspackConfig
from ..cable.model import clamp_rotations
from ..cable.shape import node_vertices
from ..stations.config import SimulationConfig
from ..stations.station import LINK_INDEX, Station, node_frames
from .model import RodModel


@dataclass(frozen=True)
class HeldPoint:
    """One vertex a node holds: its index, the node (its index in the dresspack's nodes), the node's holder link
    (-1 the world) and its place in that frame."""

    vertex: int
    node: int
    link: int
    local: tuple[float, float, float]


@dataclass(frozen=True)
class ClampFrame:
    """A clamp's material director (its frame's y axis) in its holder's frame, and the edge it holds."""

    edge: int
    link: int
    local_director: tuple[float, float, float]


@dataclass(frozen=True)
class StationCable:
    """One robot's dresspack for the rod engine: ``model`` plus the held points and clamp frames by link."""

    robot: int
    model: RodModel
    held: tuple[HeldPoint, ...]
    clamps: tuple[ClampFrame, ...]  # in cable order; consecutive clamps bound a twist span
    radius: float
    anchors: tuple[int, ...] = ()  # per node, in the dresspack's order: the vertex at its point (node.pos)

    def targets(self, link_frames: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """World positions of the held vertices and the clamps' directors per span, (n_spans, 2, 3), for the
        robot's ``link_frames`` (base .. link6, as ``RobotKinematics.link_frames``)."""
        pos = np.empty((len(self.held), 3))
        for j, hp in enumerate(self.held):
            frame = np.eye(4) if hp.link < 0 else link_frames[hp.link]
            pos[j] = frame[:3, :3] @ np.asarray(hp.local) + frame[:3, 3]
        directors = []
        for c in self.clamps:
            frame = np.eye(4) if c.link < 0 else link_frames[c.link]
            directors.append(frame[:3, :3] @ np.asarray(c.local_director))
        spans = np.array([[directors[k], directors[k + 1]] for k in range(len(directors) - 1)]).reshape(-1, 2, 3)
        return pos, spans


def rod_model(dresspack: DresspackConfig, simulation: SimulationConfig, held: tuple[int, ...],
              spans: tuple[tuple[int, int], ...]) -> RodModel:
    """The dresspack's material and layout as a :class:`RodModel` (the same EA, EI, GJ, rho and drag as MuJoCo's)."""
    return RodModel(dresspack.length, dresspack.segments, dresspack.linear_density, dresspack.tensile_stiffness,
                    dresspack.bending_stiffness, dresspack.torsional_stiffness, held=held, spans=spans,
                    damping=simulation.cable_damping, gravity=(0.0, 0.0, -simulation.gravity))


def station_cable(station: Station, robot: int) -> StationCable:
    """Robot ``robot``'s dresspack, with the clamps' rolls that install it untwisted at Home (as in MuJoCo)."""
    placement = station.config.robots[robot]
    dp = placement.dresspack
    kin = station.robots[robot].kinematics
    home_frames = node_frames(placement, kin.link_frames(placement.home))
    rotations = clamp_rotations(dp, home_frames, station.home_cable_shapes[robot])
    h = dp.segment_length
    held, clamps, anchors = [], [], []
    for k, (node, rot) in enumerate(zip(dp.nodes, rotations)):
        link = -1 if node.body == "world" else LINK_INDEX[node.body]
        verts = node_vertices(dp, node)
        anchors.append(verts[0])
        p = np.asarray(node.pos, dtype=float)
        for j, v in enumerate(verts):
            local = p if j == 0 else p + (-1.0 if dp.is_end_node(node) else 1.0) * h * np.asarray(node.direction)
            held.append(HeldPoint(v, k, link, tuple(map(float, local))))
        if rot is not None:
            clamps.append(ClampFrame(min(verts), link, tuple(map(float, rot[:, 1]))))
    held.sort(key=lambda hp: hp.vertex)
    spans = tuple((clamps[k].edge, clamps[k + 1].edge) for k in range(len(clamps) - 1))
    model = rod_model(dp, station.config.simulation, tuple(hp.vertex for hp in held), spans)
    return StationCable(robot, model, tuple(held), tuple(clamps), dp.radius, tuple(anchors))
