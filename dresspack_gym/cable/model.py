"""Builds a dresspack as MuJoCo 4 discrete elastic rods (raw 1D flexes) held by load-cell node bodies.

Mapping of the thesis Table 3.1 parameters (SPEC §2):
- bending EI and torsion GJ -> flex ``young = EI / I`` and ``shear = GJ / J`` with the circular section of
  the cable radius (I = pi r^4/4, J = pi r^4/2), exactly what MuJoCo's ``section="circle"`` uses;
- tension EA -> the flex edge equality is a soft constraint whose static compliance is set so that every
  edge carries tension = EA * strain, independent of the timestep (see :func:`edge_constraint`);
- mass -> consistent lumped masses rho*h per free vertex (rho*h/2 at a free end); vertices held by a node
  are massless points of the node body (the clamp carries that piece of cable).

Nodes. Every node is a small *node body* under its robot link (or the world), joined to it by a
kinematic 6-dof load cell (3 slides + a ball) whose joint values are written every step, so the node is
rigid and the generalised forces on the load-cell joints are exactly the force and torque the cable
exerts on the node (the connector load). A clamp holds two cable vertices on its node body: position,
tangent and material frame (twist) are held with no soft constraint, and the rod's reaction force and
torque land on the body. A ring holds one vertex (position only, the cable may swivel and twist).
The cable is split at interior clamps into separate rods, so each clamp holds the material frame on
both sides (MuJoCo clamps a rod's first and last edge only).

Rest shape. DER keeps any curvature present in ``qpos0`` as rest curvature, so in ``qpos0`` every vertex
of the cable lies on one straight line with the node bodies' frames all parallel (no rest bend, no rest
twist). The load-cell joint values then move each node body to its real place on the link. Each clamp's
roll about the cable is chosen so that the cable is installed untwisted at Home (the frame of the
previous clamp parallel-transported along the Home reference shape).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import ConfigError
from ..robots.model import ROBOT_ARMATURE, body_name, cable_affinity, cable_bits, mat_to_quat
from .config import CableNode, DresspackConfig
from .shape import node_vertices

CABLE_RGBA = (0.1, 0.1, 0.12, 1.0)
# Coulomb friction coefficient of the cable's jacket (the rod engine's on every contact of a station's cable)
CABLE_FRICTION = 0.5
# Constant impedance of the edge constraints: with solimp flat at d the static stiffness of an edge row
# is -solref[0] / ((1 - d) * invweight) (MuJoCo's soft-constraint regulariser R = (1 - d)/d * invweight);
# 0.5 keeps R comparable to the edge's own inverse mass, so the stretch mode is neither stiffer nor
# softer than its inertia can follow at the relaxation timesteps.
EDGE_IMPEDANCE = 0.5
# Contacts of the cable with obstacles and links: a fixed time constant (not tied to the timestep, so
# relaxation at larger steps sees the same contact), critically damped, MuJoCo's default impedance.
CONTACT_SOLREF = (0.02, 1.0)
# Node bodies are massless in effect: tiny mass and inertia so gravity on them is negligible.
NODE_MASS = 1e-6
NODE_INERTIA = 1e-12
# qpos / dof layout of one load cell: 3 slides then a ball joint (quaternion).
LOAD_CELL_NQ = 7
LOAD_CELL_NV = 6


@dataclass(frozen=True)
class NodeAttachment:
    """A compiled node: the cable vertices it holds and how its node body sits on its holder.

    ``load_qpos`` are the load-cell joint values that move the node body from its ``qpos0`` place on
    the straight rest line to the real node pose; ``slide_to_node`` rotates slide-joint force components
    into the node frame (x = cable direction for a clamp). ``held_mass`` [kg] and ``held_at`` (node
    frame) are the lumped masses of the held vertices: the node carries that piece of cable's weight.
    """

    node: CableNode
    vertices: tuple[int, ...]
    body: str
    load_qpos: tuple[float, ...]
    slide_to_node: tuple[tuple[float, float, float], ...]
    held_mass: tuple[float, ...] = ()
    held_at: tuple[tuple[float, float, float], ...] = ()

    @property
    def is_clamp(self) -> bool:
        return self.node.direction is not None


@dataclass(frozen=True)
class RodPiece:
    """One raw flex rod of a cable: global vertex indices in order and which are held by nodes."""

    flex: str
    vertices: tuple[int, ...]
    held: tuple[bool, ...]
    first_clamped: bool
    last_clamped: bool

    @property
    def n_edges(self) -> int:
        return len(self.vertices) - 1

    def twist_joint(self, edge: int) -> str | None:
        """Name of the twist hinge of local ``edge`` (None for a clamped end edge)."""
        if (edge == 0 and self.first_clamped) or (edge == self.n_edges - 1 and self.last_clamped):
            return None
        return f"{self.flex}_twist" if edge == self.n_edges - 1 else f"{self.flex}_twist_{edge}"


@dataclass(frozen=True)
class CableLayout:
    attachments: tuple[NodeAttachment, ...]
    pieces: tuple[RodPiece, ...]
    free_vertices: tuple[int, ...]  # global indices of the vertices that have their own (slider) body


def rod_pieces(robot: str, dresspack: DresspackConfig) -> list[RodPiece]:
    """Split the cable at its interior clamps into rods whose end edges the clamps hold."""
    n = dresspack.segments
    held = {v for node in dresspack.nodes for v in node_vertices(dresspack, node)}
    clamps = {dresspack.vertex_of(nd): nd for nd in dresspack.nodes if nd.direction is not None}
    cuts = [0] + [v for v, nd in clamps.items() if v > 0 and not dresspack.is_end_node(nd)]  # first vertex per piece
    pieces = []
    for p, start in enumerate(cuts):
        stop = cuts[p + 1] + 1 if p + 1 < len(cuts) else n  # a cut clamp's edge (v, v+1) ends this piece
        verts = tuple(range(start, stop + 1))
        first_clamped = start in clamps and not dresspack.is_end_node(clamps[start])
        last_clamped = p + 1 < len(cuts) or (stop in clamps and dresspack.is_end_node(clamps[stop]))
        flags = tuple(v in held for v in verts)
        if all(flags) or len(verts) < 4:
            raise ConfigError("dresspack.nodes", f"the cable between vertices {start} and {stop} has no free vertex "
                                                 f"at {n} segments; increase 'segments' or separate the nodes")
        name = f"{robot}/cable" if p == 0 else f"{robot}/cable_p{p}"
        pieces.append(RodPiece(name, verts, flags, first_clamped, last_clamped))
    return pieces


def _frame_with_x(x: np.ndarray, up_hint: np.ndarray) -> np.ndarray:
    """A rotation matrix whose first column is ``x`` and whose y axis is ``up_hint`` made orthogonal."""
    x = x / np.linalg.norm(x)
    y = up_hint - (up_hint @ x) * x
    if np.linalg.norm(y) < 1e-6:
        y = np.array([0.0, 0.0, 1.0]) - x[2] * x
        if np.linalg.norm(y) < 1e-6:
            y = np.array([0.0, 1.0, 0.0]) - x[1] * x
    y /= np.linalg.norm(y)
    return np.column_stack([x, y, np.cross(x, y)])


def _transport(vec: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Parallel transport of ``vec`` from unit tangent t0 to t1 (rotation about t0 x t1)."""
    axis = np.cross(t0, t1)
    s, c = np.linalg.norm(axis), float(t0 @ t1)
    if s < 1e-12:
        return vec
    k = axis / s
    return vec * c + np.cross(k, vec) * s + k * (k @ vec) * (1 - c)


def clamp_rotations(dresspack: DresspackConfig, home_frames: list[np.ndarray], home_shape: np.ndarray,
                    ) -> list[np.ndarray | None]:
    """Node rotations relative to their holders that make the cable untwisted at Home.

    The first clamp's material frame is its direction with y as close to the holder's z axis as
    possible; every later clamp takes the frame transported twist-free along the Home reference shape.
    Rings return None (they hold no frame).
    """
    tangents = np.diff(home_shape, axis=0)
    tangents /= np.maximum(np.linalg.norm(tangents, axis=1, keepdims=True), 1e-12)
    out: list[np.ndarray | None] = []
    carried: tuple[int, np.ndarray] | None = None  # (edge, world material y axis on that edge)
    for node, frame in zip(dresspack.nodes, home_frames):
        if node.direction is None:
            out.append(None)
            continue
        rot = frame[:3, :3]
        x_world = rot @ np.asarray(node.direction)
        verts = node_vertices(dresspack, node)
        edge = min(verts)
        if carried is None:
            local = _frame_with_x(np.asarray(node.direction, dtype=float), np.array([0.0, 0.0, 1.0]))
            y_world = rot @ local[:, 1]
        else:
            e0, y_world = carried
            for e in range(e0, edge):
                y_world = _transport(y_world, tangents[e], tangents[e + 1])
            local = _frame_with_x(np.asarray(node.direction, dtype=float), rot.T @ y_world)
            y_world = rot @ local[:, 1]
        carried = (edge, y_world - (y_world @ x_world) * x_world)
        out.append(local)
    return out


def edge_constraint(dresspack: DresspackConfig) -> tuple[tuple[float, float], tuple[float, ...], float]:
    """(solref, solimp, invweight) of the edge equality giving tension = EA * strain at rest.

    Static stiffness of a soft equality row = -solref[0] / ((1 - d) * invweight) (checked in
    tests/physics/test_physics_validation.py at several timesteps and segment counts). Every stretchable edge
    gets the same invweight (set on the compiled model by :func:`apply_edge_invweight`), so every edge
    has k = EA / h exactly; solref[1] damps the two-vertex stretch mode critically.
    """
    h = dresspack.segment_length
    m = dresspack.linear_density * h
    invweight = 2.0 / m
    k_edge = dresspack.tensile_stiffness / h
    b_edge = 2.0 * np.sqrt(k_edge * m / 2.0)
    scale = (1.0 - EDGE_IMPEDANCE) * invweight
    d = EDGE_IMPEDANCE
    return (-k_edge * scale, -b_edge * scale), (d, d, 0.001, 0.5, 2.0), invweight


def apply_edge_invweight(model: mujoco.MjModel, flex_ids, invweight: float) -> None:
    """Give every stretchable edge of the flexes the same constraint invweight (see edge_constraint)."""
    for f in flex_ids:
        adr, num = model.flex_edgeadr[f], model.flex_edgenum[f]
        w = model.flexedge_invweight0[adr:adr + num]
        w[w > 0] = invweight  # rigid edges (both vertices on one node body) have no constraint row


def add_cable(spec: mujoco.MjSpec, robot: str, dresspack: DresspackConfig, *, zero_frames: list[np.ndarray],
              home_frames: list[np.ndarray], home_shape: np.ndarray,
              bending_damping: float, index: int = 0, n_robots: int = 1) -> CableLayout:
    """Add the dresspack of ``robot`` to ``spec``.

    ``zero_frames`` / ``home_frames``: world pose of each node's holder with the robot at qpos0 (all
    joints zero) and at Home; ``home_shape``: the Home reference shape (for the untwisted install).
    """
    n = dresspack.segments
    h = dresspack.segment_length
    rho_h = dresspack.linear_density * h
    # The straight rest line: it starts where the first node's body sits at qpos0, along its direction.
    first = dresspack.nodes[0]
    f0 = zero_frames[0]
    origin = f0[:3, :3] @ np.asarray(first.pos) + f0[:3, 3]
    line_dir = f0[:3, :3] @ np.asarray(first.direction) if first.direction is not None else np.array([1.0, 0, 0])
    line_rot = _frame_with_x(line_dir, np.array([0.0, 0.0, 1.0]))

    def on_line(v: int) -> np.ndarray:
        return origin + v * h * line_dir

    rotations = clamp_rotations(dresspack, home_frames, home_shape)
    attachments = []
    vertex_holder: dict[int, tuple[str, np.ndarray]] = {}  # vertex -> (body, coordinates in that body)
    for k, (node, zf, rot_node) in enumerate(zip(dresspack.nodes, zero_frames, rotations)):
        holder = spec.worldbody if node.body == "world" else spec.body(body_name(robot, node.body))
        verts = node_vertices(dresspack, node)
        bname = f"{robot}/node_{node.name}"
        # qpos0 pose of the node body, relative to its holder: on the rest line, frames parallel.
        rest_rot = zf[:3, :3].T @ line_rot
        rest_pos = zf[:3, :3].T @ (on_line(verts[0]) - zf[:3, 3])
        body = holder.add_body(name=bname, pos=list(rest_pos), quat=list(mat_to_quat(rest_rot)))
        body.mass, body.inertia, body.explicitinertial = NODE_MASS, [NODE_INERTIA] * 3, True
        for axis, jn in zip(np.eye(3), "xyz"):
            body.add_joint(name=f"{bname}_load_{jn}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=list(axis),
                           armature=ROBOT_ARMATURE)
        body.add_joint(name=f"{bname}_load_r", type=mujoco.mjtJoint.mjJNT_BALL, armature=ROBOT_ARMATURE)
        node_rot = rest_rot if rot_node is None else rot_node  # rings keep their rest orientation
        slide = rest_rot.T @ (np.asarray(node.pos) - rest_pos)
        ball = mat_to_quat(rest_rot.T @ node_rot)
        body.add_site(name=f"{bname}_site", size=[0.012, 0, 0], rgba=[0.1, 0.6, 1.0, 1.0])
        if node.body != "world":
            # The clamp (or ring) and the cable it holds are robot hardware: a collision primitive of the
            # robot for the planners' and masks' robot-obstacle checks. No MuJoCo contacts (contype and
            # conaffinity 0): the cable's own held piece must not collide with it, and a kinematic body pushed
            # into an obstacle would only report crushing forces.
            g = body.add_geom(name=f"{bname}_geom", rgba=[0.1, 0.6, 1.0, 0.6], group=3)
            g.contype, g.conaffinity = 0, 0
            if len(verts) == 2:
                sign = -1.0 if verts[1] < verts[0] else 1.0
                g.type = mujoco.mjtGeom.mjGEOM_CAPSULE
                g.fromto = [0.0, 0.0, 0.0, sign * h, 0.0, 0.0]
                g.size = [dresspack.radius, 0.0, 0.0]
            else:
                g.type = mujoco.mjtGeom.mjGEOM_SPHERE
                g.size = [dresspack.radius, 0.0, 0.0]
        for j, v in enumerate(verts):
            sign = -1.0 if (j == 1 and v < verts[0]) else 1.0
            vertex_holder[v] = (bname, np.array([sign * h * j, 0.0, 0.0]))
        held_mass = tuple(rho_h * (0.5 if v in (0, n) else 1.0) for v in verts)
        held_at = tuple(tuple(map(float, vertex_holder[v][1])) for v in verts)
        attachments.append(NodeAttachment(node, verts, bname, tuple(slide) + tuple(ball),
                                          tuple(map(tuple, node_rot.T @ rest_rot)), held_mass, held_at))
    free = []
    for v in range(n + 1):
        if v in vertex_holder:
            continue
        mass = rho_h * (0.5 if v == n else 1.0)
        b = spec.worldbody.add_body(name=f"{robot}/cable_{v}", pos=list(on_line(v)))
        # Slide joints only, undamped: flex vertices cannot carry joint damping, so the simulator applies the
        # cable's viscous drag itself (simulation.cable_damping).
        b.mass, b.inertia, b.explicitinertial = mass, [mass * 1e-4] * 3, True
        for axis in np.eye(3):
            b.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=list(axis))
        vertex_holder[v] = (f"{robot}/cable_{v}", np.zeros(3))
        free.append(v)
    pieces = rod_pieces(robot, dresspack)
    solref, solimp, _ = edge_constraint(dresspack)
    affinity = cable_affinity(index, n_robots, dresspack.collide_with_robot)
    polar = 0.5 * rho_h * dresspack.radius ** 2  # per-edge polar moment of inertia (solid circle)
    for piece in pieces:
        for e in range(piece.n_edges):  # twist hinges in edge order (MuJoCo binds them by name)
            jname = piece.twist_joint(e)
            if jname is None:
                continue
            # Mass rho*h with the polar inertia on all axes keeps the body physically sized (no model-wide
            # force may treat it as a huge box); it sits on the world origin and never translates.
            tb = spec.worldbody.add_body(name=jname)
            tb.mass, tb.inertia, tb.explicitinertial = rho_h, [polar] * 3, True
            tb.add_joint(name=jname, type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 0])
        f = spec.add_flex()
        f.name, f.dim, f.radius = piece.flex, 1, dresspack.radius
        f.vertbody = [vertex_holder[v][0] for v in piece.vertices]
        f.vert = list(np.concatenate([vertex_holder[v][1] for v in piece.vertices]))
        f.elem = [i for e in range(piece.n_edges) for i in (e, e + 1)]
        f.young, f.shear, f.damping = dresspack.young_modulus, dresspack.shear_modulus, bending_damping
        f.rgba = list(CABLE_RGBA)
        f.contype, f.conaffinity, f.condim = cable_bits(index), affinity, 3
        # MuJoCo combines two coefficients by the larger: against the links', the obstacles' and the floor's 1 the
        # cable slides at 1, on another cable at this
        f.friction = [CABLE_FRICTION, 0.005, 0.0001]
        f.selfcollide = mujoco.mjtFlexSelf.mjFLEXSELF_NONE
        f.solref = list(CONTACT_SOLREF)
        spec.add_equality(name=f"{piece.flex}_edges", type=mujoco.mjtEq.mjEQ_FLEX, name1=piece.flex,
                          solref=list(solref), solimp=list(solimp))
    return CableLayout(tuple(attachments), tuple(pieces), tuple(free))
