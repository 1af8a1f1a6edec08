"""Compiles a :class:`StationConfig` into one MuJoCo model and records where everything lives in it."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..cable.model import (
    LOAD_CELL_NQ,
    LOAD_CELL_NV,
    CableLayout,
    NodeAttachment,
    RodPiece,
    add_cable,
    apply_edge_invweight,
    edge_constraint,
)
from ..cable.shape import reference_shape
from ..errors import ConfigError, KinematicsError
from ..robots.kinematics import RobotKinematics, rpy_matrix, weld_configurations
from ..robots.model import OBSTACLE_BITS, _set_primitive, add_robot, body_name, joint_name, mat_to_quat
from .checks import check_station
from .config import StationConfig
from .rendering import OFFSCREEN_HEIGHT, OFFSCREEN_WIDTH

DOWN = np.array([0.0, 0.0, -1.0])  # gravity's direction (simulation.gravity is its magnitude along -z)
LINK_INDEX = {"base": 0, "link1": 1, "link2": 2, "link3": 3, "link4": 4, "link5": 5, "link6": 6}
# The Newton solver's tolerance, for motions and settles alike. MuJoCo's tolerance is relative to the model's mean
# inertia, which the robots' links make about a million times a cable vertex's mass: at MuJoCo's default (1e-8) the
# warm-started solve stops with no iteration on a third or more of the steps, those steps reuse the previous
# acceleration (the rod's forces a step late) and an undamped cable gains energy (tests/physics/test_energy.py).
# 1e-10 solves every step (one or two iterations) and lets settles reach the equilibrium residual, for ~8 % more
# time on a replay.
SOLVER_TOLERANCE = 1e-10


@dataclass
class PieceIndex:
    """Addresses of one rod (raw flex) of a cable."""

    piece: RodPiece
    flex_id: int
    edge_eq_id: int  # equality id of its edge constraint
    twist_qpos: np.ndarray  # qpos address per edge twist hinge (-1 for a clamped edge)
    twist_dof: np.ndarray  # dof address per edge twist hinge (-1 for a clamped edge)
    rigid_edge: np.ndarray  # True where both vertices sit on one node body (no stretch, no tension row)
    plastic_adr: int  # start of the rod's DER state in mjData.plastic (frames, then reference twist)
    vert_adr: int  # first row of the rod's vertices in mjData.flexvert_xpos


@dataclass
class CableIndex:
    """Addresses of one dresspack inside the compiled model."""

    robot: str
    layout: CableLayout
    pieces: list[PieceIndex]
    point_rows: np.ndarray  # (n+1,) row of each cable vertex in mjData.flexvert_xpos
    free_vertices: np.ndarray  # global indices of vertices with their own slider body
    free_bodies: np.ndarray  # their body ids
    free_qpos: np.ndarray  # (n_free, 3) qpos addresses of their slide joints
    free_dof: np.ndarray  # (n_free, 3) dof addresses
    free_mass: np.ndarray  # (n_free,) kg
    load_qpos: np.ndarray  # (n_nodes, 7) qpos addresses of each node's load cell
    load_dof: np.ndarray  # (n_nodes, 6) dof addresses of each node's load cell
    node_bodies: np.ndarray  # (n_nodes,) body id of each node body
    segment_length: float
    radius: float

    @property
    def attachments(self) -> tuple[NodeAttachment, ...]:
        return self.layout.attachments

    @property
    def n_vertices(self) -> int:
        return len(self.point_rows)


@dataclass
class RobotIndex:
    name: str
    qpos: np.ndarray  # (6,) qpos addresses of j1..j6
    dof: np.ndarray  # (6,) dof addresses
    kinematics: RobotKinematics
    geom_ids: np.ndarray  # collision geoms of the robot (its links, and the dresspack nodes it carries)
    tcp_site: int
    geom_links: np.ndarray = None  # link number (0 = base .. 6) carrying each geom of geom_ids


class Station:
    """A compiled station: ``model``, plus robot, cable and obstacle indices and the source config."""

    def __init__(self, config: StationConfig):
        self.config = config
        spec = self._build_spec(config)
        try:
            self.model = spec.compile()
        except ValueError as exc:  # MuJoCo's compile errors are ValueErrors with the XML context
            raise ConfigError("station", f"MuJoCo could not compile the station {config.name!r}: {exc}") from None
        m = self.model
        m.opt.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE
        m.opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
        for r, layout in zip(config.robots, self._attachments):
            flexes = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, p.flex) for p in layout.pieces]
            apply_edge_invweight(m, flexes, edge_constraint(r.dresspack)[2])
        self.robots = []
        layout_of = {r.name: layout for r, layout in zip(config.robots, self._attachments)}
        for r in config.robots:
            qpos = np.array([m.jnt_qposadr[m.joint(joint_name(r.name, j)).id] for j in range(6)])
            dof = np.array([m.jnt_dofadr[m.joint(joint_name(r.name, j)).id] for j in range(6)])
            link_of = {m.body(body_name(r.name, link)).id: k for link, k in LINK_INDEX.items()}
            for att in layout_of[r.name].attachments:  # node bodies ride on their link
                if att.node.body != "world":
                    link_of[m.body(att.body).id] = LINK_INDEX[att.node.body]
            geoms = np.array([g for g in range(m.ngeom) if m.geom_bodyid[g] in link_of], dtype=int)
            links = np.array([link_of[m.geom_bodyid[g]] for g in geoms], dtype=int)
            self.robots.append(RobotIndex(r.name, qpos, dof, RobotKinematics(r.robot, r.base_pos, r.base_yaw),
                                          geoms, m.site(f"{r.name}/tcp").id, links))
        self.cables = [self._cable_index(r, att) for r, att in zip(config.robots, self._attachments)]
        self.obstacle_geoms = np.array([m.geom(f"obstacle/{o.name}").id for o in config.obstacles]
                                       + ([m.geom("floor").id] if config.floor else []), dtype=int)
        self.robot_qpos = np.concatenate([r.qpos for r in self.robots])
        self.robot_dof = np.concatenate([r.dof for r in self.robots])
        # Load cells are kinematic like the robot joints: written every step with these constant values.
        self.load_qpos = np.concatenate([c.load_qpos.ravel() for c in self.cables])
        self.load_dof = np.concatenate([c.load_dof.ravel() for c in self.cables])
        self.load_values = np.concatenate([np.asarray(a.load_qpos, dtype=float) for c in self.cables
                                           for a in c.attachments])
        self.home = np.stack([r.home for r in config.robots])
        self.home_cable_shapes = self._home_shapes  # reference shapes at Home, made while building the model
        check_station(self)
        self.weld_configurations, self.unreachable_welds = self._solve_welds(config)

    def _solve_welds(self, config: StationConfig) -> tuple[dict[str, np.ndarray], dict[str, str]]:
        """All IK solutions (within joint limits) of every weld point, and why each unreachable one is: a station
        with an unreachable weld still loads; a task that uses it fails naming it (tasks.select_weld_goals)."""
        out, unreachable = {}, {}
        for i, w in enumerate(config.weld_points):
            kin = self.robots[config.robot_index(w.robot)].kinematics
            try:
                out[w.name] = weld_configurations(kin, w)
            except KinematicsError as exc:
                out[w.name] = np.zeros((0, 6))
                unreachable[w.name] = f"weld_points[{i}].pos: {exc}"
        return out, unreachable

    @property
    def n_robots(self) -> int:
        return len(self.robots)

    def check_robot(self, index, field: str = "robot") -> int:
        """``index`` if it names one of the station's robots, else a ConfigError listing them."""
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < self.n_robots:
            names = [r.name for r in self.robots]
            raise ConfigError(field, f"robot index {index!r} does not exist: this station's robots are "
                                     f"{dict(enumerate(names))}")
        return int(index)

    # ------------------------------------------------------------------------------------ build
    def _build_spec(self, config: StationConfig) -> mujoco.MjSpec:
        sim = config.simulation
        spec = mujoco.MjSpec()
        spec.modelname = config.name
        spec.option.timestep = sim.timestep
        spec.option.gravity = [0, 0, -sim.gravity]
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE
        spec.option.cone = (mujoco.mjtCone.mjCONE_ELLIPTIC if sim.friction_cone == "elliptic"
                            else mujoco.mjtCone.mjCONE_PYRAMIDAL)
        spec.option.impratio = sim.impratio
        spec.option.tolerance = SOLVER_TOLERANCE
        # No model-wide fluid: cable damping is explicit viscous drag on the free vertices (physics/simulation.py),
        # so no option acts on the rod's twist bodies or the node bodies.
        spec.option.viscosity = 0.0
        if len(config.robots) == 1:
            # One robot, its nodes and its cable (tied by the edge equalities) are always a single constraint island,
            # so MuJoCo's per-step island bookkeeping only costs: off, the same Newton solve runs ~5 % cheaper (equal
            # up to rounding). Several robots keep islands: solved apart they are cheaper, and one joint solve would
            # couple their line searches.
            spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
        spec.visual.global_.offwidth, spec.visual.global_.offheight = OFFSCREEN_WIDTH, OFFSCREEN_HEIGHT
        spec.worldbody.add_light(pos=[0, 0, 6], dir=[0, 0, -1], diffuse=[0.8, 0.8, 0.8])
        spec.worldbody.add_light(pos=[4, -4, 5], dir=[-1, 1, -1], diffuse=[0.4, 0.4, 0.4])
        if config.floor:
            floor = spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1],
                                            rgba=[0.82, 0.82, 0.8, 1])
            floor.contype, floor.conaffinity = OBSTACLE_BITS, 0
        for o in config.obstacles:
            self._add_obstacle(spec, o)
        # An invisible, non-colliding capsule that ClearanceProbe poses on each cable edge.
        probe_body = spec.worldbody.add_body(name="clearance_probe", mocap=True)
        probe = probe_body.add_geom(name="clearance_probe", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                                    size=[0.01, 0.01, 0], rgba=[0, 0, 0, 0], group=5)
        probe.contype, probe.conaffinity = 0, 0
        self._attachments = []
        for i, r in enumerate(config.robots):
            add_robot(spec, r.name, r.robot, r.base_pos, r.base_yaw, i)
        self._home_shapes = []
        for i, r in enumerate(config.robots):
            kin = RobotKinematics(r.robot, r.base_pos, r.base_yaw)
            zero_frames = node_frames(r, kin.link_frames(np.zeros(6)))
            home_frames = node_frames(r, kin.link_frames(r.home))
            try:  # the Home reference shape fixes the clamps' roll (installed untwisted at Home)
                home_shape = reference_shape(r.dresspack, home_frames, DOWN)
            except ConfigError as exc:
                raise ConfigError(f"robots[{i}].{exc.field}", str(exc).split(": ", 1)[1]) from None
            self._home_shapes.append(home_shape)
            self._attachments.append(add_cable(spec, r.name, r.dresspack, zero_frames=zero_frames,
                                               home_frames=home_frames, home_shape=home_shape,
                                               bending_damping=sim.bending_damping, index=i,
                                               n_robots=len(config.robots)))
        return spec

    def _add_obstacle(self, spec: mujoco.MjSpec, o) -> None:
        if o.type == "mesh":
            spec.add_mesh(name=f"mesh/{o.name}", file=o.mesh_file, scale=list(o.mesh_scale))
            g = spec.worldbody.add_geom(name=f"obstacle/{o.name}", type=mujoco.mjtGeom.mjGEOM_MESH,
                                        meshname=f"mesh/{o.name}", pos=list(o.pos),
                                        quat=list(mat_to_quat(rpy_matrix(o.rpy))))
        else:
            g = spec.worldbody.add_geom(name=f"obstacle/{o.name}")
            _set_primitive(g, o.type, o.size, o.pos, o.rpy, o.fromto)
        g.rgba = list(o.rgba)
        g.contype, g.conaffinity = OBSTACLE_BITS, 0

    def _cable_index(self, placement, layout: CableLayout) -> CableIndex:
        m = self.model
        name = placement.name
        dp = placement.dresspack
        pieces, point_rows = [], np.full(dp.segments + 1, -1, dtype=int)
        for piece in layout.pieces:
            fid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, piece.flex)
            twist_q = np.full(piece.n_edges, -1, dtype=int)
            twist_v = np.full(piece.n_edges, -1, dtype=int)
            for e in range(piece.n_edges):
                jn = piece.twist_joint(e)
                if jn is not None:
                    twist_q[e] = m.jnt_qposadr[m.joint(jn).id]
                    twist_v[e] = m.jnt_dofadr[m.joint(jn).id]
            vadr = int(m.flex_vertadr[fid])
            for j, v in enumerate(piece.vertices):
                if point_rows[v] < 0:
                    point_rows[v] = vadr + j
            pieces.append(PieceIndex(piece, fid, m.equality(f"{piece.flex}_edges").id, twist_q, twist_v,
                                     _same_node(layout, piece), int(m.flex_plasticadr[fid]), vadr))
        free = np.array(layout.free_vertices, dtype=int)
        bodies = np.array([m.body(f"{name}/cable_{v}").id for v in free], dtype=int)
        fq = np.array([m.jnt_qposadr[m.body_jntadr[b]:m.body_jntadr[b] + 3] for b in bodies], dtype=int)
        fv = np.array([m.jnt_dofadr[m.body_jntadr[b]:m.body_jntadr[b] + 3] for b in bodies], dtype=int)
        lq, lv = [], []
        for att in layout.attachments:
            j0 = m.body_jntadr[m.body(att.body).id]
            lq.append(np.concatenate([np.arange(m.jnt_qposadr[j0], m.jnt_qposadr[j0] + 3),
                                      np.arange(m.jnt_qposadr[j0 + 3], m.jnt_qposadr[j0 + 3] + 4)]))
            lv.append(np.arange(m.jnt_dofadr[j0], m.jnt_dofadr[j0] + LOAD_CELL_NV))
        return CableIndex(name, layout, pieces, point_rows, free, bodies, fq, fv, m.body_mass[bodies].copy(),
                          np.array(lq, dtype=int).reshape(-1, LOAD_CELL_NQ),
                          np.array(lv, dtype=int).reshape(-1, LOAD_CELL_NV),
                          np.array([m.body(a.body).id for a in layout.attachments], dtype=int),
                          dp.segment_length, dp.radius)

    # ------------------------------------------------------------------------------ helpers
    def data_at_home(self) -> mujoco.MjData:
        """A private MjData with every robot at Home and each dresspack node at its place on its link, kinematics
        computed: geometric queries posed on it never disturb a running simulation."""
        data = mujoco.MjData(self.model)
        data.qpos[:] = self.model.qpos0
        data.qpos[self.robot_qpos] = self.home.ravel()
        data.qpos[self.load_qpos] = self.load_values
        mujoco.mj_kinematics(self.model, data)
        return data

    def initial_cable_shapes(self, q_robots: np.ndarray) -> list[np.ndarray]:
        """Reference shapes (world vertex positions) of every cable with the robots at ``q_robots``."""
        return [self.initial_cable_shapes_for(i, q) for i, q in enumerate(q_robots)]

    def initial_cable_shapes_for(self, i: int, q: np.ndarray) -> np.ndarray:
        r = self.config.robots[i]
        return reference_shape(r.dresspack, node_frames(r, self.robots[i].kinematics.link_frames(q)), DOWN)


def node_frames(placement, link_frames: list[np.ndarray]) -> list[np.ndarray]:
    """World pose of the body holding each node of the robot's dresspack."""
    return [np.eye(4) if nd.body == "world" else link_frames[LINK_INDEX[nd.body]] for nd in placement.dresspack.nodes]


def _same_node(layout: CableLayout, piece: RodPiece) -> np.ndarray:
    """Per edge of ``piece``: both vertices held by the same node (a clamp's rigid edge)."""
    owner = {v: k for k, att in enumerate(layout.attachments) for v in att.vertices}
    o = [owner.get(v, -1 - i) for i, v in enumerate(piece.vertices)]
    return np.array([a == b for a, b in zip(o[:-1], o[1:])])


def as_slice(index) -> slice | np.ndarray:
    """``index`` as a slice when it counts up by one (numpy reads and writes a slice as a view, without gathering:
    the simulator's and the collision checker's per-step writes), else unchanged."""
    index = np.asarray(index)
    if len(index) and np.array_equal(index, np.arange(index[0], index[0] + len(index))):
        return slice(int(index[0]), int(index[0]) + len(index))
    return index
