"""Builds a dresspack as a MuJoCo 4 discrete elastic rod (1D flexcomp) attached by its nodes.

Mapping of the thesis Table 3.1 parameters (SPEC §2):
- bending EI and torsion GJ -> flex ``young = EI / I`` and ``shear = GJ / J`` with the circular
  section of the cable radius (I = pi r^4/4, J = pi r^4/2), exactly what MuJoCo's ``section="circle"`` uses;
- tension EA -> the cable is inextensible to first order (EA = 1400 N against forces of tens of N gives
  strains of ~1 %), modelled by ``<edge equality="true"/>``; the edge constraint forces are the tensions;
- mass -> consistent lumped masses rho*h per vertex, rho*h/2 at both ends (flexcomp gives equal masses).

The rod is built straight (DER keeps any curvature present in qpos0 as rest curvature) and posed by
setting qpos to a smooth curve through its nodes. Nodes are site-to-site ``connect`` equalities: one
vertex for a ring (position only), two consecutive vertices for a clamp (position and tangent).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from .config import CableNode, DresspackConfig
from .errors import ConfigError
from .robot_model import OBSTACLE_BITS, ROBOT_BITS, body_name

CABLE_RGBA = (0.1, 0.1, 0.12, 1.0)
# Impedance of the cable's edge and node constraints. With MuJoCo's default (0.9, 0.95) a clamp holding
# 12 g vertices tilts by ~0.1 rad under a 2.5 N m moment; with these it holds to ~1e-4 rad (validated by
# the cantilever test in tests/test_physics_validation.py).
STIFF_SOLIMP = (0.9999, 0.99999, 0.001, 0.5, 2.0)


@dataclass(frozen=True)
class NodeAttachment:
    """A compiled node: the vertex indices it holds and the site names that hold them."""

    node: CableNode
    vertices: tuple[int, ...]
    robot_sites: tuple[str, ...]
    vertex_sites: tuple[str, ...]


def node_vertex(dresspack: DresspackConfig, node: CableNode) -> int:
    return int(round(node.arc_length / dresspack.segment_length))


def node_world_points(dresspack: DresspackConfig, node: CableNode, frame: np.ndarray) -> list[np.ndarray]:
    """World positions the node's vertices must take: the node point, then the clamp's second point."""
    h = dresspack.segment_length
    p = frame[:3, :3] @ np.asarray(node.pos) + frame[:3, 3]
    pts = [p]
    if node.direction is not None:
        d = frame[:3, :3] @ np.asarray(node.direction)
        pts.append(p + d * h if node.arc_length < dresspack.length - 1e-9 else p - d * h)
    return pts


def reference_shape(dresspack: DresspackConfig, frames: list[np.ndarray], gravity_dir=(0, 0, -1)) -> np.ndarray:
    """A smooth, sagging cable shape through all nodes (world frame), one point per vertex.

    ``frames[i]`` is the world pose (4x4) of the body holding node i. Each span between nodes is a
    cubic Hermite curve that leaves/enters along the clamp directions plus a parabolic sag along
    gravity, with the sag found by bisection so that the span has exactly its arc length.
    Raises ConfigError if the cable is shorter than the distance its nodes demand.
    """
    n = dresspack.segments
    h = dresspack.segment_length
    g = np.asarray(gravity_dir, dtype=float)
    pts = np.full((n + 1, 3), np.nan)
    anchors: list[tuple[int, np.ndarray, np.ndarray | None]] = []  # (vertex, point, tangent)
    for node, frame in zip(dresspack.nodes, frames):
        v = node_vertex(dresspack, node)
        world = node_world_points(dresspack, node, frame)
        pts[v] = world[0]
        if len(world) == 2:
            is_end = node.arc_length >= dresspack.length - 1e-9
            w = v - 1 if is_end else v + 1
            pts[w] = world[1]
            tangent = (world[0] - world[1]) / h if is_end else (world[1] - world[0]) / h
            if is_end:
                anchors.append((w, world[1], tangent))
                anchors.append((v, world[0], tangent))
            else:
                anchors.append((v, world[0], tangent))
                anchors.append((w, world[1], tangent))
        else:
            anchors.append((v, world[0], None))
    anchors.sort(key=lambda a: a[0])
    for (v0, p0, t0), (v1, p1, t1) in zip(anchors, anchors[1:]):
        if v1 - v0 <= 1:
            if np.linalg.norm(p1 - p0) > h * (v1 - v0) * 1.02 + 1e-9:
                _too_short(dresspack, p0, p1, (v1 - v0) * h)
            continue
        pts[v0:v1 + 1] = _span(p0, t0, p1, t1, (v1 - v0) * h, v1 - v0, g, dresspack)
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


def _too_short(dresspack, p0, p1, length):
    raise ConfigError("dresspack.length",
                      f"cable of {dresspack.length:.3f} m is too short: {np.linalg.norm(p1 - p0):.3f} m lie between "
                      f"its nodes where only {length:.3f} m of cable is available at the Home configuration")


def _span(p0, t0, p1, t1, length, segments, g, dresspack) -> np.ndarray:
    chord = np.linalg.norm(p1 - p0)
    if chord > length * 0.999:
        _too_short(dresspack, p0, p1, length)
    u = np.linspace(0.0, 1.0, 2001)[:, None]
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
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if arc(curve(k, mid)) < length else (lo, mid)
    dense = curve(k, 0.5 * (lo + hi))
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    targets = np.linspace(0.0, s[-1], segments + 1)
    return np.stack([np.interp(targets, s, dense[:, i]) for i in range(3)], axis=1)


def flexcomp_xml(dresspack: DresspackConfig, straight: np.ndarray, *, timestep: float,
                 bending_damping: float) -> str:
    """MJCF of the rod as a straight ``direct`` flexcomp (zero rest curvature)."""
    n = dresspack.segments
    elements = " ".join(f"{i} {i + 1}" for i in range(n))
    points = " ".join(f"{v:.9f}" for v in straight.ravel())
    affinity = OBSTACLE_BITS | (ROBOT_BITS if dresspack.collide_with_robot else 0)
    # Edge constraints as stiff as the step allows (time constant 2 steps, critically damped) with an
    # impedance near 1: light vertices make default-soft constraints stretch and give at clamps.
    solref = f"{2 * timestep:.6g} 1"
    solimp = " ".join(map(str, STIFF_SOLIMP))
    return f"""<mujoco>
  <worldbody>
    <flexcomp name="cable" type="direct" dim="1" point="{points}" element="{elements}"
              mass="{dresspack.linear_density * dresspack.length:.9g}" radius="{dresspack.radius:.9g}"
              rgba="{' '.join(map(str, CABLE_RGBA))}">
      <edge equality="true" solref="{solref}" solimp="{solimp}"/>
      <elasticity young="{dresspack.young_modulus:.9g}" shear="{dresspack.shear_modulus:.9g}"
                  damping="{bending_damping:.6g}" section="circle"/>
      <contact contype="0" conaffinity="{affinity}" condim="3" friction="0.5" selfcollide="none"
               solref="{solref}"/>
    </flexcomp>
  </worldbody>
</mujoco>"""


def add_cable(spec: mujoco.MjSpec, robot: str, dresspack: DresspackConfig, start_frame: np.ndarray, *,
              timestep: float, cable_damping: float, bending_damping: float) -> list[NodeAttachment]:
    """Attach the dresspack of ``robot`` to ``spec``; returns its node attachments.

    The straight qpos0 rod starts at the first node and runs along its direction (any straight
    placement works: only straightness matters for the rest shape).
    """
    n = dresspack.segments
    h = dresspack.segment_length
    first = dresspack.nodes[0]
    origin = start_frame[:3, :3] @ np.asarray(first.pos) + start_frame[:3, 3]
    direction = (start_frame[:3, :3] @ np.asarray(first.direction)) if first.direction else np.array([1.0, 0, 0])
    straight = origin[None, :] + np.arange(n + 1)[:, None] * h * direction[None, :]
    child = mujoco.MjSpec.from_string(flexcomp_xml(dresspack, straight, timestep=timestep,
                                                   bending_damping=bending_damping))
    # Consistent lumped masses: rho*h per vertex, half at the two ends. Cable damping (air and
    # contact losses) comes from MuJoCo's inertia-box fluid model with viscosity 1 (set by the
    # station): f = -6 pi r v, so an inertia box of half-size r = c m / (6 pi) damps at rate c [1/s].
    rho_h = dresspack.linear_density * h
    for i in range(n + 1):
        b = child.body(f"cable_{i}")
        mass = rho_h * (0.5 if i in (0, n) else 1.0)
        r_box = cable_damping * mass / (6.0 * np.pi)
        b.mass = mass
        b.inertia = [2.0 / 3.0 * mass * r_box ** 2] * 3
        b.explicitinertial = True
    attachments = []
    for k, node in enumerate(dresspack.nodes):
        v = node_vertex(dresspack, node)
        is_end = node.arc_length >= dresspack.length - 1e-9
        verts = [v] if node.direction is None else ([v, v - 1] if is_end else [v, v + 1])
        vsites, rsites = [], []
        for j, vert in enumerate(verts):
            vs = f"node{k}_v{j}"
            child.body(f"cable_{vert}").add_site(name=vs, pos=[0, 0, 0], size=[0.01, 0, 0])
            vsites.append(f"{robot}/{vs}")
            rsites.append(f"{robot}/cable_node{k}_{j}")
        attachments.append(NodeAttachment(node, tuple(verts), tuple(rsites), tuple(vsites)))
    frame = spec.worldbody.add_frame()
    spec.attach(child, frame=frame, prefix=f"{robot}/")
    for att in attachments:
        node = att.node
        holder = spec.worldbody if node.body == "world" else spec.body(body_name(robot, node.body))
        points = [np.asarray(node.pos, dtype=float)]
        if node.direction is not None:
            is_end = node.arc_length >= dresspack.length - 1e-9
            points.append(points[0] + (-1 if is_end else 1) * h * np.asarray(node.direction))
        for site, p in zip(att.robot_sites, points):
            holder.add_site(name=site, pos=list(p), size=[0.012, 0, 0], rgba=[0.1, 0.6, 1.0, 1.0])
        for rs, vs in zip(att.robot_sites, att.vertex_sites):
            # One-step time constant (the station disables MuJoCo's 2-step "refsafe" floor): the clamp
            # moment arm is a single short edge, so any softness shows up as a tilted clamp.
            spec.add_equality(name=f"{vs}_connect", type=mujoco.mjtEq.mjEQ_CONNECT, objtype=mujoco.mjtObj.mjOBJ_SITE,
                              name1=vs, name2=rs, solref=[timestep, 1.0], solimp=list(STIFF_SOLIMP))
    return attachments
