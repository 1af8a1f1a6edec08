"""The rod engine as a cosseratbench solver (entry point ``dresspack_rod``): a benchmark extra, imported by nothing."""

from __future__ import annotations

import math
from importlib.metadata import PackageNotFoundError, version

import numpy as np
from cosseratbench.scenario import Cylinder, End, EndCondition, Scenario
from cosseratbench.scenario import Rod as RodSpec
from cosseratbench.solver import Capability, Diverged
from cosseratbench.trajectory import Trajectory

from .contact.barrier import barrier_d1
from .contact.segment import segment_gap
from .frames import reference_twists, signed_angle, unit_tangents
from .model import RodModel
from .rod import Rod
from .scene import CYLINDER, PLANE, ContactSettings, Primitives

# The implicit step resolves the slowest mode: h * slowest_frequency <= RESOLVE (times time_step_scale). The answer
# of a quasi-static scenario is the equilibrium, which implicit Euler reaches at any step; this keeps the path to it
# (what the settling residual and the capstan's slide read) a damped motion rather than a jump.
RESOLVE = 0.2
# Newton's tolerance: the largest net force on a free vertex, over its weight (at 1 m/s^2 when weightless).
TOLERANCE = 1e-6
# Contact: the barrier acts within ACTIVATION rod radii of gap (so the gap it leaves shifts the shape by less than
# that), and is as stiff as puts the characteristic force per element at a gap of a tenth of the activation.
ACTIVATION = 0.1
# Friction is smoothed below a slip speed of SLIP_SPEED rod lengths per second, the built-in adapters' tolerance.
SLIP_SPEED = 1e-4
# With obstacles, the first step is taken as steps growing from 2^-ONSET of it. The engine lags friction's normal
# forces from the start of each step, and at the start contact has not yet come to its force (the barrier's gap is
# the start's):
# in one full step a rope on a cylinder slid 2 mm before friction caught it, and off at 95% of the holding load.
ONSET = 10


def _backend_version() -> str | None:
    try:
        return version("dresspack-gym")
    except PackageNotFoundError:
        return None


def _clamp_vertices(spec: RodSpec, n: int) -> dict[End, tuple[int, ...]]:
    """The vertices each end holds: a pinned end its end vertex, a clamped end its whole end edge (the engine holds
    a clamp's frame by holding its edge and, between two clamps, the edges' material directors)."""
    held = {}
    for end, (tip, inner) in ((End.START, (0, 1)), (End.END, (n, n - 1))):
        condition = spec.condition(end)
        if condition is EndCondition.PINNED:
            held[end] = (tip,)
        elif condition is EndCondition.CLAMPED:
            held[end] = (tip, inner)
    return held


def _primitives(scenario: Scenario, n: int) -> Primitives:
    kinds, pos, rot, size = [], [], [], []
    for obstacle in scenario.obstacles:
        if isinstance(obstacle, Cylinder):
            axis = obstacle.unit_axis
            center, half = np.asarray(obstacle.center, float), obstacle.length / 2.0
            kinds.append(CYLINDER)
            size.append([obstacle.radius, half, 0.0])
        else:
            axis = obstacle.unit_normal  # a plane's solid lies below its local z
            center = np.asarray(obstacle.point, float)
            kinds.append(PLANE)
            size.append([0.0, 0.0, 0.0])
        x = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
        x /= np.linalg.norm(x)
        rot.append(np.stack([x, np.cross(axis, x), axis], axis=1))  # columns: local axes, z along the axis/normal
        pos.append(center)
    k = len(kinds)
    return Primitives(np.array(kinds, dtype=np.int64), np.array(pos, float).reshape(k, 3),
                      np.array(rot, float).reshape(k, 3, 3), np.array(size, float).reshape(k, 3),
                      np.ones((n, k), dtype=np.bool_))


def _clear(points: np.ndarray, radius: float, prims: Primitives, gap: float, fixed: tuple[int, ...]) -> np.ndarray:
    """``points`` with every edge at least ``gap`` outside every primitive. The barrier needs a start outside
    everything, and a scenario's start at this resolution may not be: a polyline wrapped on a cylinder cuts into it
    between its vertices. Vertices move out along the contact normal, each by the most any of its edges lacks."""
    x = points.copy()
    p, nrm, hess = np.empty(3), np.empty(3), np.empty((3, 3))
    for _ in range(100):
        push = np.zeros_like(x)
        for i in range(len(x) - 1):
            for j in range(len(prims)):
                d, _ = segment_gap(x[i], x[i + 1], radius, prims.kind[j], prims.pos[j], prims.rot[j], prims.size[j],
                                   p, nrm, hess)
                if d < gap:
                    for v in (i, i + 1):
                        move = (gap - d) * 1.01 * nrm
                        if move @ move > push[v] @ push[v]:
                            push[v] = move
        if not push.any():
            return x
        if push[list(fixed)].any():
            raise NotImplementedError("a held rod vertex inside an obstacle")
        x += push
    raise NotImplementedError("a start the adapter could not move outside the obstacles")


class _Runner:
    """One scenario rod on the engine: its model, state, clamps and loads."""

    def __init__(self, spec: RodSpec, scenario: Scenario, n: int, damping: float, h: float, contact_force: float):
        self.spec, self.n = spec, n
        self.ends = _clamp_vertices(spec, n)
        held = tuple(sorted(v for vs in self.ends.values() for v in vs))
        m = spec.material
        inertia = spec.second_moment_of_area
        clamped = [end for end in End if spec.condition(end) is EndCondition.CLAMPED]
        # Twist lives between two clamps (uniform there, the engine's quasi-static twist); a rod with one clamp or none
        # carries no twist, as an isotropic rod with a free end cannot hold a torque.
        spans = ((0, n - 1),) if len(clamped) == 2 else ()
        self.model = RodModel(spec.length, n, m.density * spec.area, m.youngs_modulus * spec.area,
                              m.youngs_modulus * inertia, m.shear_modulus * 2.0 * inertia, held=held, spans=spans,
                              damping=damping, gravity=tuple(map(float, scenario.gravity)))
        nodes = spec.nodes(n)
        self.directors0 = spec.directors(n)
        self.nodes0 = nodes
        self.clamped = clamped
        self.time = 0.0
        self.prims = _primitives(scenario, n)
        activation = ACTIVATION * spec.radius
        if len(self.prims):
            friction = {max(o.friction, spec.friction) for o in scenario.obstacles}
            if len(friction) > 1:
                raise NotImplementedError("obstacles of different friction (the engine has one coefficient per rod)")
            stiffness = contact_force / -barrier_d1(activation / 10.0, activation)
            contact = ContactSettings(activation=activation, stiffness=stiffness, friction=friction.pop(),
                                      slip=SLIP_SPEED * spec.length * h)
            nodes = _clear(nodes, spec.radius, self.prims, activation / 2.0, held)
        else:
            contact = None
        self.contact = contact
        self.rod = Rod(self.model, nodes, frames=self.directors0, clamp_directors=self.clamp_directors(0.0),
                       radius=spec.radius, contact=contact)
        # a benchmark's solves end on the force residual alone (TOLERANCE), not on the station's 0.1 mm settled step,
        # which is coarse against a benchmark's millimetre rods
        self.rod.settled_step = 0.0
        if len(self.prims):
            # The obstacles stand still from the start: the first step lags its friction from the start too (with
            # no primitives before, the engine would take that step frictionless).
            self.rod.primitives = self.prims
        # Loads on free vertices (a held vertex's load goes into its holder).
        self.loads = [(0 if load.at is End.START else n, np.asarray(load.force, float)) for load in spec.loads]
        self.loads = [(v, f) for v, f in self.loads if v not in held]

    def _pose(self, end: End, time: float) -> tuple[np.ndarray, np.ndarray]:
        motion = self.spec.motion(end)
        if motion is None:
            return np.zeros(3), np.eye(3)
        return motion.pose(time)

    def held_positions(self, time: float) -> np.ndarray:
        """The held vertices at ``time``: an end's edge moved and turned rigidly about its end point."""
        where = {}
        for end, vertices in self.ends.items():
            tip = self.nodes0[vertices[0]]
            displacement, rotation = self._pose(end, time)
            for v in vertices:
                where[v] = tip + displacement + rotation @ (self.nodes0[v] - tip)
        return np.array([where[v] for v in self.model.held]).reshape(-1, 3)

    def clamp_directors(self, time: float) -> np.ndarray | None:
        if len(self.clamped) != 2:
            return None
        edges = {End.START: 0, End.END: self.n - 1}
        return np.array([[self._pose(end, time)[1] @ self.directors0[edges[end]] for end in (End.START, End.END)]])

    def step(self, time: float, h: float):
        self.time = time
        # The engine's only external force is gravity. Implicit Euler with a constant force F is the step from the
        # momentum m v + h F, so a point load enters as that impulse on its vertex (v is recomputed by the step).
        for v, force in self.loads:
            self.rod.v[v] += h * force / self.model.masses[v]
        return self.rod.step(self.held_positions(time), h, clamp_directors=self.clamp_directors(time),
                             tolerance=TOLERANCE, primitives=self.prims if len(self.prims) else None)

    def directors(self) -> np.ndarray:
        """Material d1 per edge: the reference frames turned by the material angle, which (twist being uniform
        between two clamps, and zero without two) follows from the clamps' directors and the reference twists."""
        rod, n = self.rod, self.n
        x = np.ascontiguousarray(rod.x)
        t, _ = unit_tangents(x)
        ref = rod.ref
        m = reference_twists(ref, t)  # m[i]: reference twist at vertex i
        theta = np.zeros(n)
        if len(self.clamped) == 2:
            tau = rod.twists()[0]
            theta[0] = signed_angle(ref[0], rod.clamp_directors[0, 0], t[0])
            for i in range(1, n):
                theta[i] = theta[i - 1] + tau / (n - 1) - m[i]
        elif self.clamped == [End.END]:  # from the clamp's director, untwisted
            rotation = self._pose(End.END, self.time)[1]
            theta[n - 1] = signed_angle(ref[n - 1], rotation @ self.directors0[n - 1], t[n - 1])
            for i in range(n - 1, 0, -1):
                theta[i - 1] = theta[i] + m[i]
        else:  # from a clamped start's director, or with no clamp edge 0's reference carried in time; untwisted
            if self.clamped == [End.START]:
                rotation = self._pose(End.START, self.time)[1]
                theta[0] = signed_angle(ref[0], rotation @ self.directors0[0], t[0])
            for i in range(1, n):
                theta[i] = theta[i - 1] - m[i]
        c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
        return c * ref + s * np.cross(t, ref)


class DresspackRodSolver:
    """dresspack_gym's rod engine: discrete elastic rods (stretch, bend, twist uniform between clamps) stepped by
    implicit Euler, every step a Newton solve; barrier contact with smoothed, lagged Coulomb friction against
    planes and cylinders. No shear, no contact between rods or of a rod with itself."""

    name = "dresspack_rod"
    backend_version = _backend_version()
    capabilities = frozenset({Capability.STRETCH, Capability.CYLINDER_CONTACT, Capability.PLANE_CONTACT})

    def __init__(self, time_step_scale: float = 1.0) -> None:
        self.time_step_scale = time_step_scale
        self.last_run: dict = {}  # Newton's record of the last run: steps, unconverged steps, iterations, residual

    def _steps(self, scenario: Scenario, n_frames: int) -> tuple[float, int]:
        frame_interval = scenario.duration / (n_frames - 1)
        limit = self.time_step_scale * RESOLVE / scenario.slowest_frequency()
        per_frame = math.ceil(frame_interval / limit - 1e-9)
        return frame_interval / per_frame, per_frame

    @staticmethod
    def _damping(scenario: Scenario) -> float:
        # Mass-proportional drag, critical for the slowest mode, as the built-in adapters damp quasi-static scenarios.
        return 2.0 * scenario.slowest_frequency()

    @staticmethod
    def _contact_force(scenario: Scenario, spec: RodSpec, n: int) -> float:
        # The characteristic force (dismech's adapter's: weight, loads or EI/L^2, whichever is largest) per element.
        weight = spec.material.density * spec.area * spec.length * float(np.linalg.norm(scenario.gravity))
        loads = sum(float(np.linalg.norm(load.force)) for load in spec.loads)
        bending = spec.material.youngs_modulus * spec.second_moment_of_area / spec.length ** 2
        return max(weight, loads, bending) / n

    def settings(self, scenario: Scenario, *, n_elements: int, n_frames: int) -> dict:
        h, _ = self._steps(scenario, n_frames)
        out = {"integrator": "implicit Euler (Newton)", "time_step": h, "damping_rate": self._damping(scenario),
               "newton_tolerance": f"{TOLERANCE:g} of a vertex's weight"}
        if scenario.obstacles:
            out["contact_activation"] = [ACTIVATION * r.radius for r in scenario.rods]
            out["contact_stiffness"] = [self._contact_force(scenario, r, n_elements)
                                        / -barrier_d1(ACTIVATION * r.radius / 10.0, ACTIVATION * r.radius)
                                        for r in scenario.rods]
            out["friction_slip_speed"] = [SLIP_SPEED * r.length for r in scenario.rods]
        return out

    def run(self, scenario: Scenario, *, n_elements: int, n_frames: int) -> Trajectory:
        if not scenario.quasi_static:
            raise NotImplementedError("dynamics (a scenario that is not quasi-static): implicit Euler damps them")
        for spec in scenario.rods:
            for end in End:
                motion = spec.motion(end)
                if motion is not None and motion.slides_along is not None:
                    raise NotImplementedError("an end that slides along its clamp (held vertices are held in all "
                                              "three coordinates)")
        h, per_frame = self._steps(scenario, n_frames)
        damping = self._damping(scenario)
        runners = [_Runner(spec, scenario, n_elements, damping, h, self._contact_force(scenario, spec, n_elements))
                   for spec in scenario.rods]
        positions = [[r.rod.x.copy()] for r in runners]
        directors = [[r.directors()] for r in runners]
        record = {"steps": 0, "unconverged": 0, "iterations": 0, "max_residual": 0.0}
        onset = [2.0 ** -ONSET] + [2.0 ** -j for j in range(ONSET, 0, -1)]  # sums to 1
        for frame in range(n_frames - 1):
            for k in range(per_frame):
                start = (frame * per_frame + k) * h
                pieces = onset if frame == k == 0 and scenario.obstacles else [1.0]
                done = 0.0
                for piece in pieces:
                    done += piece
                    time = start + min(done, 1.0) * h
                    for r in runners:
                        result = r.step(time, piece * h)
                        if not math.isfinite(result.residual) or not np.isfinite(r.rod.x).all():
                            raise Diverged("a Newton solve left no finite state", time=time)
                        record["steps"] += 1
                        record["iterations"] += result.iterations
                        record["unconverged"] += not result.converged
                        record["max_residual"] = max(record["max_residual"], result.residual)
            for r, p, d in zip(runners, positions, directors):
                p.append(r.rod.x.copy())
                d.append(r.directors())
        self.last_run = record
        times = np.linspace(0.0, scenario.duration, n_frames)
        return Trajectory(times, tuple(np.stack(p) for p in positions), tuple(np.stack(d) for d in directors))
