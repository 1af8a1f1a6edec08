"""The station's cables on the rod engine: robots moved by the time law, implicit rod steps sample by sample."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..cable.model import CABLE_FRICTION
from ..errors import ConfigError
from ..physics.damage import worst_rates
from ..physics.measures import MAX_CLEARANCE, WearMeasures
from ..physics.simulation import Equilibrium, MotionTrace, SettleResult, station_joints, station_motion_limits
from ..robots.time_law import JointLimits, SegmentMotion
from ..stations.station import Station
from .advance import carried_step, following
from .measuring import measure
from .rod import MAX_ITERATIONS, Rod, initial_frames
from .scene import ContactSettings, Primitives
from .segments import segment_state
from .station_cable import StationCable, station_cable
from .station_scene import StationScene

# A motion's sample [s] when it records none (the measures' sampling).
DEFAULT_SAMPLE = 0.05
# Implicit steps per sample (a sample's robot motion split evenly between them): with one, peak tensions in motion ran
# 9 % above MuJoCo's (median over the default station's fixed weld cycles), with two 3 %, for an eighth more time.
STEPS_PER_SAMPLE = 2
# A motion step is solved to this fraction of a vertex's weight (inertia and drag included in the balance). On the
# default station's fixed weld cycles (bench's five), 1e-1 with a 0.1 mm settled step (rod.SETTLED_STEP) moves
# integral C dt by at most 0.05 % and the peak tension and curvature by under 0.1 % against 1e-3 with a micrometre,
# for a quarter fewer Newton iterations.
STEP_TOLERANCE = 1e-1
# A vertex within this many barrier activations of where an approaching link will be is carried along with it, and
# one that ends nearer to another link is set this far out (an edge between two such vertices cuts a link's curved
# surface by its sagitta: about a millimetre on the forearm)
CARRY_REACH = 4.0
# At most this many sub-steps per sample when a link closes in on a cable (each an implicit step of its share).
MAX_SUBSTEPS = 256


class RodSimulator:
    """The fast engine's counterpart of :class:`~dresspack_gym.physics.simulation.CableSimulator`: the same
    station, Home, time law and measures, each cable a :class:`Rod` stepped once per sample."""

    engine = "fast"  # its name among physics.profiles.ENGINES

    def __init__(self, station: Station):
        self.station = station
        self.config = station.config.simulation
        self.cables: list[StationCable] = [station_cable(station, i) for i in range(station.n_robots)]
        self.scenes = [StationScene(station, c) for c in self.cables]
        self.unconverged_steps = 0  # motion steps whose Newton solve missed its tolerance (flagged, never dropped)
        self.jammed_samples = 0  # samples whose links needed more than MAX_SUBSTEPS sub-steps (flagged)
        self._tension_taps = [_tension_taps(c) for c in self.cables]
        self._anchors = [np.array(c.anchors, dtype=int) for c in self.cables]  # each node's point
        self.q = station.home.copy()
        self.motion_time = 0.0
        self.last_settle: SettleResult | None = None
        self.rods: list[Rod] = []
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self, q=None, *, settle: bool = True) -> None:
        q = self._as_q(self.station.home if q is None else q, "q")
        self.q = q.copy()
        at_home = np.array_equal(q, self.station.home)
        shapes = self.station.home_cable_shapes if at_home else self.station.initial_cable_shapes(q)
        self.rods = []
        for cable, scene, shape in zip(self.cables, self.scenes, shapes):
            primitives = scene.at(q)
            _, dirs = scene.targets()
            rod = Rod(cable.model, shape, clamp_directors=dirs, radius=cable.radius,
                      contact=ContactSettings(friction=CABLE_FRICTION))  # the jacket's, as in MuJoCo
            rod.ref[:] = initial_frames(shape, dirs[0, 0] if len(dirs) else None)
            rod.primitives = primitives
            self.rods.append(rod)
        self.motion_time = 0.0
        self.last_settle = None
        if settle:
            self.settle()

    def get_state(self) -> np.ndarray:
        """Every cable's positions, velocities and reference frames, the robots' joints and the motion time."""
        parts = [np.concatenate([r.x.ravel(), r.v.ravel(), r.ref.ravel()]) for r in self.rods]
        return np.concatenate(parts + [self.q.ravel(), [self.motion_time]])

    def set_state(self, state: np.ndarray) -> None:
        sizes = [r.x.size * 2 + r.ref.size for r in self.rods]
        expected = sum(sizes) + self.q.size + 1
        state = np.asarray(state, dtype=float)
        if state.shape != (expected,):
            raise ConfigError("state", f"expected a state vector of length {expected} from get_state(), "
                                       f"got shape {state.shape}")
        at = 0
        q = state[sum(sizes):sum(sizes) + self.q.size].reshape(self.q.shape)
        for rod, scene, size in zip(self.rods, self.scenes, sizes):
            chunk = state[at:at + size]
            n = rod.x.size
            rod.x = chunk[:n].reshape(rod.x.shape).copy()
            rod.v = chunk[n:2 * n].reshape(rod.v.shape).copy()
            rod.ref = chunk[2 * n:].reshape(rod.ref.shape).copy()
            rod.primitives = scene.at(q)
            rod.clamp_directors = scene.targets()[1]
            rod.forget_forces()
            at += size
        self.q = q.copy()
        self.motion_time = float(state[-1])

    # ------------------------------------------------------------------ motion
    def motion_limits(self, speed_fraction: float | None = None) -> JointLimits:
        return station_motion_limits(self.station, speed_fraction)

    def move_to(self, q_target, *, speed_fraction: float | None = None, settle: bool = True,
                record_every: float | None = None, until: float | None = None, record_states: bool = False,
                on_sample=None, stop_if=None) -> MotionTrace:
        """Move all robots along a straight joint-space segment under the time law; STEPS_PER_SAMPLE implicit steps
        of every cable per sample (``record_every`` s, default 0.05 s), measures (and with ``record_states`` every
        cable's segment states) recorded at each when asked. ``until``, ``stop_if`` and ``on_sample`` as in
        :meth:`CableSimulator.move_to <dresspack_gym.physics.simulation.CableSimulator.move_to>`."""
        target = self._as_q(q_target, "q_target")
        frac = self.config.speed_fraction if speed_fraction is None else float(speed_fraction)
        if not 0.0 < frac <= 1.0:
            raise ConfigError("speed_fraction", f"must be in (0, 1], got {frac}")
        sample = DEFAULT_SAMPLE if record_every is None else float(record_every)
        start = self.q.copy()
        delta = target - start
        fractions, sample = whole_samples(SegmentMotion(delta, self.motion_limits(frac)), sample)
        trace = MotionTrace()
        for k, f in enumerate(fractions, start=1):
            q = start + f * delta
            self._sample(q, sample)
            now = self.motion_time + k * sample
            if record_every:
                trace.time.append(now)
                trace.q.append(q.copy())
                measures, states = self.measures_and_states(sample)
                trace.measures.append(measures)
                if record_states:
                    trace.states.append(states)
                if on_sample is not None:
                    on_sample(now)
                trace.stopped = stop_if is not None and bool(stop_if(now, measures))
            if trace.stopped or until is not None and now >= until:  # frozen mid-motion, unsettled
                self.motion_time = now
                return trace
        self.q = target.copy()
        self.motion_time += len(fractions) * sample
        if settle:
            self.settle()
        if record_every and not len(fractions):  # a move of no length records where it stands
            trace.time.append(self.motion_time)
            trace.q.append(self.q.copy())
            measures, states = self.measures_and_states()
            trace.measures.append(measures)
            if record_states:
                trace.states.append(states)
            trace.stopped = stop_if is not None and bool(stop_if(self.motion_time, measures))
        return trace

    def follow(self, schedule_at, duration: float, *, record_every: float, on_sample=None) -> tuple[list, list]:
        """:meth:`CableSimulator.follow <dresspack_gym.physics.simulation.CableSimulator.follow>` on the rod
        engine: every robot driven along ``schedule_at(times) -> (q, qdot)`` ((N, n_robots, 6) each) for
        ``duration`` seconds from the current motion time, never settled in between, one sample (STEPS_PER_SAMPLE
        implicit steps of every cable) at a time: a whole number of equal samples of at most ``record_every`` s, so
        a run ends, and its integral stops, at ``duration`` exactly. Returns the sample times and per sample the
        wear measures of each cable."""
        if not record_every > 0.0:
            raise ConfigError("record_every", f"must be a positive number of seconds, got {record_every}")
        if not duration >= 0.0:
            raise ConfigError("duration", f"must be a non-negative number of seconds, got {duration}")
        t_start = self.motion_time
        n = int(np.ceil(duration / record_every - 1e-9))
        h = duration / n if n else 0.0
        ends = np.arange(1, n + 1) * h
        times, samples = [], []
        if n:
            q_at, _ = schedule_at(t_start + ends)
            for end, q in zip(ends, q_at):
                self._sample(np.asarray(q, dtype=float).reshape(self.q.shape), h)
                self.motion_time = t_start + float(end)
                times.append(self.motion_time)
                samples.append(self.cable_measures(h))
                if on_sample is not None:
                    on_sample(self.motion_time)
        return times, samples

    def hold(self, seconds: float) -> None:
        """Simulate on for ``seconds`` with the robots still (motion steps, not a settle: what rest must survive)."""
        if not seconds >= 0.0:
            raise ConfigError("seconds", f"must be a non-negative number of seconds, got {seconds}")
        for _ in range(int(round(seconds / DEFAULT_SAMPLE))):
            for cable, rod, scene in zip(self.cables, self.rods, self.scenes):
                self._advance(cable, rod, scene, self.q, self.q, DEFAULT_SAMPLE)
            self.motion_time += DEFAULT_SAMPLE

    def timed_move(self, q_target) -> tuple[float, float, int]:
        """A recorded move to ``q_target`` timed by part: (wall seconds in the solves, in the measures, samples)."""
        import time

        target = self._as_q(q_target, "q_target")
        start, delta = self.q.copy(), target - self.q
        fractions, sample = whole_samples(SegmentMotion(delta, self.motion_limits()), DEFAULT_SAMPLE)
        solve = measure = 0.0
        for f in fractions:
            q = start + f * delta
            t0 = time.perf_counter()
            self._sample(q, sample)
            t1 = time.perf_counter()
            self.measures_and_states(sample)
            solve, measure = solve + t1 - t0, measure + time.perf_counter() - t1
        self.motion_time += len(fractions) * sample
        return solve, measure, len(fractions)

    def _sample(self, q: np.ndarray, sample: float) -> None:
        """Every cable through one sample of ``sample`` s to the robots' joints ``q``: STEPS_PER_SAMPLE implicit
        steps, the sample's robot motion split evenly between them."""
        for j in range(1, STEPS_PER_SAMPLE + 1):
            qj = self.q + (q - self.q) / (STEPS_PER_SAMPLE - j + 1)
            for cable, rod, scene in zip(self.cables, self.rods, self.scenes):
                self._advance(cable, rod, scene, self.q, qj, sample / STEPS_PER_SAMPLE)
            self.q = qj
        self.q = q.copy()

    def _advance(self, cable: StationCable, rod: Rod, scene: StationScene, q0: np.ndarray, q1: np.ndarray,
                 h: float) -> None:
        """One sample of ``h`` s from joints q0 to q1. The solve starts with the vertices a link may reach carried
        along with it; where that start is not outside every primitive (a vertex between two links, an edge
        spanning a carried and a left vertex), in sub-steps in which no link closes more than half its gap, so
        every solve starts outside every primitive."""
        if len(scene.kind) and len(rod.primitives) == len(scene.kind):  # the whole step in one compiled call
            scene.pose(q1)
            d, c = scene.data, rod.contact
            ok, x, ref, _, _, converged, tau, static, pos, rot, _, dirs = carried_step(
                rod.x, rod.v, rod.ref, *rod.step_constants, d.xpos, d.xmat, d.geom_xpos, d.geom_xmat, scene.geoms,
                scene.kind, scene.size, scene.mask, scene.held_body, scene.held_local, scene.clamp_body,
                scene.clamp_local, rod.primitives.pos, rod.primitives.rot, True, rod.radius, c.activation,
                c.stiffness, c.friction, c.slip, CARRY_REACH * c.activation, h, STEP_TOLERANCE, MAX_ITERATIONS,
                rod.settled_step)
            if ok:
                rod.take_step(x, ref, h, static=static, twists=tau, clamp_directors=dirs,
                              primitives=Primitives(scene.kind, pos, rot, scene.size, scene.mask))
                self.unconverged_steps += int(not converged)
                return
        end = scene.at(q1)
        if len(end):
            pos, dirs = scene.targets()
            start = scene.carried_start(following(rod.x, rod.v, h, rod.model.held_array, pos), rod.radius,
                                        rod.primitives, end, CARRY_REACH * rod.contact.activation)
            if rod.outside(start, pos, end):
                result = rod.step(pos, h, clamp_directors=dirs, tolerance=STEP_TOLERANCE, primitives=end,
                                  start=start, start_outside=True)
                self.unconverged_steps += int(not result.converged)
                return
        done = 0.0
        for _ in range(MAX_SUBSTEPS):
            step = 1.0 - done if not len(end) else (1.0 - done) * scene.advance_fraction(
                rod.x, rod.radius, rod.primitives, end)
            if step <= 1e-9:
                break
            done = 1.0 if done + step >= 1.0 - 1e-12 else done + step
            q = q0 + (q1 - q0) * done
            prims = scene.at(q)
            pos, dirs = scene.targets()
            result = rod.step(pos, h * step, clamp_directors=dirs, tolerance=STEP_TOLERANCE, primitives=prims)
            self.unconverged_steps += int(not result.converged)
            if done == 1.0:
                return
        # the links did not get through in MAX_SUBSTEPS: they are jammed against the cable; say so, and jump
        scene.at(q1)
        pos, dirs = scene.targets()
        result = rod.step(pos, h * (1.0 - done), clamp_directors=dirs, tolerance=STEP_TOLERANCE, primitives=end)
        self.unconverged_steps += int(not result.converged)
        self.jammed_samples += 1

    def settle(self) -> SettleResult:
        """Every cable at rest where its robot stands: a converged static Newton solve (or flagged as not)."""
        worst = 0.0
        converged = True
        for cable, rod, scene in zip(self.cables, self.rods, self.scenes):
            primitives = scene.at(self.q)
            pos, dirs = scene.targets()
            result = rod.solve_rest(pos, clamp_directors=dirs, tolerance=self.config.equilibrium_tolerance,
                                    primitives=primitives)
            worst = max(worst, result.residual)
            converged &= result.converged
        self.last_settle = SettleResult(0.0, Equilibrium(worst, 0.0, 0.0, converged))
        return self.last_settle

    # ------------------------------------------------------------------ measures
    def cable_points(self, robot: int = 0) -> np.ndarray:
        return self.rods[robot].x.copy()

    def mujoco_qpos(self) -> np.ndarray:
        """MuJoCo's positions of the station (``station.model``) with the robots where they stand and every
        dresspack node on its link: what draws the robots. MuJoCo's cables stay on their straight rest line (this
        engine's cables are :meth:`cable_points`, drawn from their points)."""
        qpos = self.station.model.qpos0.copy()
        qpos[self.station.robot_qpos] = self.q.ravel()
        qpos[self.station.load_qpos] = self.station.load_values
        return qpos

    def cable_measures(self, h: float | None = None) -> list[WearMeasures]:
        """Every cable's WearMeasures, the worst segment's damage rate included (as the MuJoCo simulator's)."""
        return self._cable_measures(self._states(h))

    def _cable_measures(self, states: list) -> list[WearMeasures]:
        out = []
        for cable, rod, state in zip(self.cables, self.rods, states):
            out.append(replace(self._measure(cable, rod),
                               **worst_rates(state, self.station.config.robots[cable.robot].dresspack)))
        return out

    def measures(self) -> WearMeasures:
        return self.measures_and_states()[0]

    def measures_and_states(self, h: float | None = None) -> tuple[WearMeasures, list]:
        """The station-level measures and every cable's segment states (``h``: the step just taken, for the
        sliding speeds; None at rest)."""
        states = self._states(h)
        return WearMeasures.worst(self._cable_measures(states)), states

    def _states(self, h: float | None) -> list:
        return [segment_state(rod, rod.previous_x if h else None, h, previous_primitives=rod.previous_primitives)
                for rod in self.rods]

    def segment_states(self) -> list:
        return self.measures_and_states()[1]

    def _measure(self, cable: StationCable, rod: Rod) -> WearMeasures:
        """The cable's WearMeasures: the largest Menger curvature; the largest tension of an edge (EA times its
        strain) or where the cable enters a node (the node's load along the cable); the clearance to the obstacles
        (the contact kernels' exact capsule gaps, 0 in contact); the twist rate of its spans; what its nodes carry."""
        h = cable.model.segment_length
        scene, k = self.scenes[cable.robot], self.scenes[cable.robot].n_obstacles
        prims = rod.primitives
        members, vertex, neighbour, node = self._tension_taps[cable.robot]
        spans = cable.model.span_edges
        twists = rod.twists() if len(spans) else np.zeros(0)
        moments = cable.model.torsional_stiffness * twists / cable.model.span_lengths if len(spans) else twists
        kappa, at_k, tension, at_t, compression, gap, edge, prim, node_force, node_torque = measure(
            rod.x, rod._rest, cable.model.tensile_stiffness, rod.radius, rod.static_forces(), members,
            self._anchors[cable.robot], spans, moments, vertex, neighbour, node, prims.kind[:k], prims.pos[:k],
            prims.rot[:k], prims.size[:k], MAX_CLEARANCE)
        rates = np.abs(twists) / cable.model.span_lengths if len(spans) else np.zeros(1)
        # a node's tension is placed at the node (its point's arc length), an edge's at its middle
        tension_at = (at_t + 0.5) * h if at_t >= 0 else self._anchors[cable.robot][node[-at_t - 1]] * h
        return WearMeasures(float(kappa), float(max(tension, 0.0)), float(max(gap, 0.0)), float(rates.max()),
                            curvature_at=at_k * h, tension_at=tension_at,
                            clearance_at=(edge + 0.5) * h if edge >= 0 else 0.0,
                            nearest_obstacle=scene.obstacle_names[prim] if prim >= 0 else "",
                            total_twist=float(np.abs(twists).max()) if len(spans) else 0.0,
                            max_compression=float(compression), max_node_force=float(node_force),
                            max_node_torque=float(node_torque))

    def equilibrium(self) -> Equilibrium:
        worst = max(rod.equilibrium_residual() for rod in self.rods)
        return Equilibrium(worst, 0.0, 0.0, worst < self.config.equilibrium_tolerance)

    def _as_q(self, q, field: str) -> np.ndarray:
        return station_joints(self.station, q, field)

    # ------------------------------------------------------------------ robustness maps
    def move_quasi_static(self, q_target, *, speed_fraction: float) -> MotionTrace:
        """:meth:`CableSimulator.move_to <dresspack_gym.physics.simulation.CableSimulator.move_to>` with
        ``settle=False, quasi_static=True``: the full-speed motion slowed down in time by ``speed_fraction``
        (accelerations by its square), one implicit step of every cable per DEFAULT_SAMPLE, not settled. The trace's
        ``max_acceleration_ratio`` is the largest change of a free vertex's velocity over one sample, over g times
        the sample (the net force on the vertex in units of its weight, as MuJoCo's averaged indicator)."""
        target = self._as_q(q_target, "q_target")
        frac = float(speed_fraction)
        if not 0.0 < frac <= 1.0:
            raise ConfigError("speed_fraction", f"must be in (0, 1], got {frac}")
        start, delta = self.q.copy(), target - self.q
        limits = station_motion_limits(self.station, frac, quasi_static=True)
        fractions, _ = SegmentMotion(delta, limits).on_steps(DEFAULT_SAMPLE)
        g_sample = max(float(self.config.gravity), 1.0) * DEFAULT_SAMPLE
        free = [np.setdiff1d(np.arange(c.model.segments + 1), c.model.held_array) for c in self.cables]
        trace = MotionTrace()
        for f in fractions:
            q = start + f * delta
            for cable, rod, scene, idx in zip(self.cables, self.rods, self.scenes, free):
                v0 = rod.v[idx].copy()
                self._advance(cable, rod, scene, self.q, q, DEFAULT_SAMPLE)
                if len(idx):
                    accel = float(np.linalg.norm(rod.v[idx] - v0, axis=1).max()) / g_sample
                    trace.max_acceleration_ratio = max(trace.max_acceleration_ratio, accel)
            self.q = q
        self.q = target.copy()
        self.motion_time += len(fractions) * DEFAULT_SAMPLE
        return trace


def whole_samples(motion: SegmentMotion, sample: float) -> tuple[np.ndarray, float]:
    """The motion's fractions after each of its samples, and their length: at most ``sample``, a whole number of
    them in the motion's duration, so the engine runs the time law's motion and times it exactly (MuJoCo, whose step
    the model fixes, slows the motion by a hair to end on a step instead, SegmentMotion.on_steps)."""
    if motion.duration <= 0:
        return np.zeros(0), sample
    h = motion.duration / int(np.ceil(motion.duration / sample - 1e-9))
    return motion.on_steps(h)[0], h


def _tension_taps(cable: StationCable) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where node tensions are read: a (nodes, vertices) 0/1 matrix of the vertices each node holds, and per tap
    the held vertex, its free neighbour and the node."""
    held = {hp.vertex: hp.node for hp in cable.held}
    nodes = sorted(set(held.values()))
    members = np.zeros((len(nodes), cable.model.segments + 1))
    taps = []
    for row, k in enumerate(nodes):
        for v, owner in held.items():
            if owner != k:
                continue
            members[row, v] = 1.0
            taps += [(v, w, row) for w in (v - 1, v + 1) if 0 <= w <= cable.model.segments and w not in held]
    vertex, neighbour, node = (np.array(col, dtype=int) for col in zip(*taps)) if taps else (np.zeros(0, int),) * 3
    return members, vertex, neighbour, node
