"""Compiles a :class:`StationConfig` into one MuJoCo model and records where everything lives in it."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from .cable_model import NodeAttachment, add_cable, reference_shape
from .config import StationConfig
from .errors import ConfigError, KinematicsError
from .kinematics import RobotKinematics, rpy_matrix, weld_configurations
from .robot_model import OBSTACLE_BITS, _set_primitive, add_robot, body_name, joint_name, mat_to_quat

LINK_INDEX = {"base": 0, "link1": 1, "link2": 2, "link3": 3, "link4": 4, "link5": 5, "link6": 6}


@dataclass
class CableIndex:
    """Addresses of one dresspack inside the compiled model."""

    robot: str
    flex_id: int
    vertex_bodies: np.ndarray  # body id per vertex
    vertex_qpos: np.ndarray  # (n+1, 3) qpos addresses of the vertex slide joints
    vertex_dof: np.ndarray  # (n+1, 3) dof addresses
    twist_qpos: np.ndarray  # qpos address per edge twist joint (-1 where the edge has none)
    edge_eq_id: int  # equality id of the flex edge constraint
    attachments: tuple[NodeAttachment, ...]
    node_eq_ids: tuple[tuple[int, ...], ...]  # connect equality ids holding each node's vertices
    segment_length: float
    radius: float


@dataclass
class RobotIndex:
    name: str
    qpos: np.ndarray  # (6,) qpos addresses of j1..j6
    dof: np.ndarray  # (6,) dof addresses
    kinematics: RobotKinematics
    geom_ids: np.ndarray  # collision geoms of the robot
    tcp_site: int


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
        self.robots = []
        for r in config.robots:
            qpos = np.array([m.jnt_qposadr[m.joint(joint_name(r.name, j)).id] for j in range(6)])
            dof = np.array([m.jnt_dofadr[m.joint(joint_name(r.name, j)).id] for j in range(6)])
            body_ids = {m.body(body_name(r.name, link)).id for link in LINK_INDEX}
            geoms = np.array([g for g in range(m.ngeom) if m.geom_bodyid[g] in body_ids], dtype=int)
            self.robots.append(RobotIndex(r.name, qpos, dof, RobotKinematics(r.robot, r.base_pos, r.base_yaw),
                                          geoms, m.site(f"{r.name}/tcp").id))
        self.cables = [self._cable_index(r, att) for r, att in zip(config.robots, self._attachments)]
        self.obstacle_geoms = np.array([m.geom(f"obstacle/{o.name}").id for o in config.obstacles]
                                       + ([m.geom("floor").id] if config.floor else []), dtype=int)
        self.robot_qpos = np.concatenate([r.qpos for r in self.robots])
        self.robot_dof = np.concatenate([r.dof for r in self.robots])
        self.home = np.stack([r.home for r in config.robots])
        self.weld_configurations = self._solve_welds(config)
        self.restrictions = [r.restrictions for r in config.robots]
        self.allowed_weld_configurations = {
            w.name: self._allowed(config.robots[config.robot_index(w.robot)], self.weld_configurations[w.name])
            for w in config.weld_points}
        self.home_cable_shapes = self._home_shapes()

    @staticmethod
    def _allowed(placement, q: np.ndarray) -> np.ndarray:
        """The configurations that pass the joint restrictions and, if the robot has a map, are robust."""
        if len(q) == 0:
            return q
        ok = placement.restrictions.allowed(q)
        if placement.robustness_map is not None:
            ok &= placement.robustness_map.robust_joints(q)
        return q[ok]

    def _home_shapes(self) -> list[np.ndarray]:
        """Cable shapes at Home; fails early (naming the robot) if a cable cannot span its nodes."""
        try:
            return self.initial_cable_shapes(self.home)
        except ConfigError as exc:
            for i in range(self.n_robots):  # find the robot whose cable failed
                try:
                    self.initial_cable_shapes_for(i, self.home[i])
                except ConfigError:
                    break
            raise ConfigError(f"robots[{i}].{exc.field}", str(exc).split(": ", 1)[1]) from None

    def _solve_welds(self, config: StationConfig) -> dict[str, np.ndarray]:
        """All IK solutions (within joint limits) of every weld point; unreachable ones are config errors."""
        out = {}
        for i, w in enumerate(config.weld_points):
            kin = self.robots[config.robot_index(w.robot)].kinematics
            try:
                out[w.name] = weld_configurations(kin, w)
            except KinematicsError as exc:
                raise ConfigError(f"weld_points[{i}].pos", str(exc)) from None
        return out

    @property
    def n_robots(self) -> int:
        return len(self.robots)

    # ------------------------------------------------------------------------------------ build
    def _build_spec(self, config: StationConfig) -> mujoco.MjSpec:
        sim = config.simulation
        spec = mujoco.MjSpec()
        spec.modelname = config.name
        spec.option.timestep = sim.timestep
        spec.option.gravity = [0, 0, -sim.gravity]
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE
        spec.option.viscosity = 1.0  # cable damping via the inertia-box fluid model (see cable_model)
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_REFSAFE  # allow 1-step clamp constraints
        spec.visual.global_.offwidth = 1280
        spec.visual.global_.offheight = 960
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
        for r in config.robots:
            add_robot(spec, r)
        for r in config.robots:
            kin = RobotKinematics(r.robot, r.base_pos, r.base_yaw)
            frames = kin.link_frames(r.home)
            first = r.dresspack.nodes[0]
            start_frame = np.eye(4) if first.body == "world" else frames[LINK_INDEX[first.body]]
            self._attachments.append(add_cable(spec, r.name, r.dresspack, start_frame, timestep=sim.timestep,
                                               cable_damping=sim.cable_damping,
                                               bending_damping=sim.bending_damping))
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

    def _cable_index(self, placement, attachments) -> CableIndex:
        m = self.model
        name = placement.name
        dp = placement.dresspack
        n = dp.segments
        flex_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, f"{name}/cable")
        bodies = np.array([m.body(f"{name}/cable_{i}").id for i in range(n + 1)])
        qpos = np.zeros((n + 1, 3), dtype=int)
        dof = np.zeros((n + 1, 3), dtype=int)
        for i, b in enumerate(bodies):
            j0 = m.body_jntadr[b]
            if m.body_jntnum[b] != 3:
                raise ConfigError("dresspack", f"cable vertex {i} has {m.body_jntnum[b]} joints, expected 3")
            qpos[i] = m.jnt_qposadr[j0:j0 + 3]
            dof[i] = m.jnt_dofadr[j0:j0 + 3]
        twist = np.full(n, -1, dtype=int)
        for e in range(n):
            jname = f"{name}/cable_twist" if e == n - 1 else f"{name}/cable_twist_{e}"
            try:
                twist[e] = m.jnt_qposadr[m.joint(jname).id]
            except KeyError:
                pass
        eq = [i for i in range(m.neq) if m.eq_type[i] == mujoco.mjtEq.mjEQ_FLEX and m.eq_obj1id[i] == flex_id]
        node_eqs = tuple(tuple(m.equality(f"{vs}_connect").id for vs in att.vertex_sites) for att in attachments)
        return CableIndex(name, flex_id, bodies, qpos, dof, twist, eq[0], tuple(attachments), node_eqs,
                          dp.segment_length, dp.radius)

    # ------------------------------------------------------------------------------ helpers
    def initial_cable_shapes(self, q_robots: np.ndarray) -> list[np.ndarray]:
        """Reference shapes (world vertex positions) of every cable with the robots at ``q_robots``."""
        return [self.initial_cable_shapes_for(i, q) for i, q in enumerate(q_robots)]

    def initial_cable_shapes_for(self, i: int, q: np.ndarray) -> np.ndarray:
        r, rob = self.config.robots[i], self.robots[i]
        g = np.asarray(self.model.opt.gravity, dtype=float)
        gdir = g / np.linalg.norm(g) if np.linalg.norm(g) > 0 else np.array([0, 0, -1.0])
        frames = rob.kinematics.link_frames(q)
        node_frames = [np.eye(4) if nd.body == "world" else frames[LINK_INDEX[nd.body]] for nd in r.dresspack.nodes]
        return reference_shape(r.dresspack, node_frames, gdir)
