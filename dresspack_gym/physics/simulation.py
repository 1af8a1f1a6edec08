"""Quasi-static simulation of robots carrying dresspacks: kinematic joint motion plus cable settling.

The robots (and the nodes' load cells) are position-driven: their joint positions and velocities are
written before every physics step, so the cable never pushes them. Motions follow straight joint-space
segments under the robots' time law (jerk-limited, :mod:`time_law`) at a program speed fraction; the cable is damped
(viscous drag on its free vertices) so that its shape stays near equilibrium while still depending on
the path travelled. A settle ends when the equilibrium residual says so, never on time alone.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..errors import ConfigError, SimulationError
from ..robots.joint_limits import check_within_limits
from ..robots.time_law import JointLimits, SegmentMotion
from ..stations.station import Station, as_slice
from .damage import worst_rates
from .measures import CableSample, ClearanceProbe, WearMeasures, cable_points, node_loads
from .segment_state import SegmentState, SegmentStateReader

STATE_SPEC = mujoco.mjtState.mjSTATE_INTEGRATION | mujoco.mjtState.mjSTATE_PLASTIC
# Settling checks the equilibrium residual every this many steps (one extra forward pass each).
SETTLE_CHECK_EVERY = 10


@dataclass(frozen=True)
class Equilibrium:
    """How far a cable state is from static equilibrium.

    ``force_residual``: the largest net static force (elastic, gravity, contact, constraint; velocities
    zeroed) on any free vertex divided by that vertex's weight; ``torque_residual``: the largest net
    torque on a twist hinge divided by the weight torque of one segment at the cable radius (rho h g r;
    g taken as at least 1 m/s^2 so that a weightless cable has a scale too); ``kinetic_energy`` [J] of the
    cables. ``converged`` when all are within the station's tolerances (``simulation.equilibrium_tolerance``
    and ``simulation.equilibrium_speed``).
    """

    force_residual: float
    torque_residual: float
    kinetic_energy: float
    converged: bool


@dataclass(frozen=True)
class SettleResult:
    """What a settle did: simulated seconds, and the equilibrium it ended in (``converged`` or not)."""

    time: float
    equilibrium: Equilibrium

    @property
    def converged(self) -> bool:
        return self.equilibrium.converged


@dataclass
class MotionTrace:
    """Samples recorded along a motion: time [s], robot joints [rad] and station-level measures."""

    time: list[float] = field(default_factory=list)
    q: list[np.ndarray] = field(default_factory=list)
    measures: list[WearMeasures] = field(default_factory=list)
    states: list[list[SegmentState]] = field(default_factory=list)  # per sample, per cable (if recorded)
    # The dynamic indicator of a quasi-static motion: the largest free-vertex acceleration over g, averaged
    # over SETTLE_CHECK_EVERY steps (the net force on a vertex in units of its weight; the averaging removes
    # the integrator's stiff jitter).
    max_acceleration_ratio: float = 0.0
    stopped: bool = False  # ended mid-motion by move_to's ``stop_if``

    def extend(self, other: "MotionTrace") -> None:
        self.time += other.time
        self.q += other.q
        self.measures += other.measures
        self.max_acceleration_ratio = max(self.max_acceleration_ratio, other.max_acceleration_ratio)


def _residual_gravity(gravity: float) -> float:
    """The acceleration that turns masses into the residual's force scale: g, or 1 m/s^2 when g is smaller
    (a weightless cable still needs a scale to call a force small)."""
    return max(float(gravity), 1.0)


def station_joints(station: Station, q, field: str) -> np.ndarray:
    """``q`` as every robot's joint angles, (n_robots, 6) [rad] ((6,) for a one-robot station), checked: shape,
    finite, within each robot's limits; a ConfigError names ``field`` otherwise. Both cable engines' check."""
    q = np.asarray(q, dtype=float)
    n = station.n_robots
    if q.shape == (6,) and n == 1:
        q = q[None, :]
    if q.shape != (n, 6):
        raise ConfigError(field, f"expected joint angles of shape (6,) or ({n}, 6) in radians, got {q.shape}")
    if not np.isfinite(q).all():
        raise ConfigError(field, "joint angles must be finite")
    for i, r in enumerate(station.config.robots):
        check_within_limits(q[i], r.robot.joint_limits, field if n == 1 else f"{field}[{i}]", digits=2,
                            owner=f" of robot {r.name!r}")
    return q


def station_motion_limits(station: Station, speed_fraction: float | None = None, *,
                          quasi_static: bool = False) -> JointLimits:
    """The time law's joint limits of all robots, (n_robots, 6) each, at ``speed_fraction`` (default: the
    simulation's) of the rated speeds; ``quasi_static`` slows the full-speed motion down in time instead, so
    accelerations shrink too (f^2)."""
    frac = station.config.simulation.speed_fraction if speed_fraction is None else float(speed_fraction)
    full = JointLimits.stack(r.robot.joint_motion_limits for r in station.config.robots)
    return full.slowed(frac) if quasi_static else full.at_speed(frac)


class CableSimulator:
    """One station's physics: move robots, let cables settle, measure wear, save/restore state."""

    engine = "dynamic"  # its name among physics.profiles.ENGINES

    def __init__(self, station: Station):
        self.station = station
        self.model = station.model
        self.data = mujoco.MjData(self.model)
        self._scratch = mujoco.MjData(self.model)  # static-force evaluations for the equilibrium residual
        self._state_buffer = np.empty(mujoco.mj_stateSize(self.model, STATE_SPEC))
        self.config = station.config.simulation
        self.probe = ClearanceProbe(station)
        self._segment_readers: list[SegmentStateReader] | None = None
        self.q = station.home.copy()  # commanded robot joints, (n_robots, 6)
        self.motion_time = 0.0  # simulated seconds spent in robot motion (the cycle time)
        self.last_settle: SettleResult | None = None
        cables = station.cables
        self._free_dof = np.concatenate([c.free_dof.ravel() for c in cables])
        self._free_dof_mass = np.concatenate([np.repeat(c.free_mass, 3) for c in cables])
        self._free_weight = np.concatenate([c.free_mass for c in cables]) * _residual_gravity(self.config.gravity)
        self._twist_dof = np.concatenate([p.twist_dof[p.twist_dof >= 0] for c in cables for p in c.pieces])
        self._twist_scale = np.concatenate([
            np.full(int((p.twist_dof >= 0).sum()), self._torque_scale(station, i))
            for i, c in enumerate(cables) for p in c.pieces])
        self._twist_inertia = self.model.dof_M0[self._twist_dof].copy() if len(self._twist_dof) else np.zeros(0)
        self._drag = -self.config.cable_damping * self._free_dof_mass  # f = -c m v on every free vertex dof
        self._robot_qpos = as_slice(station.robot_qpos)  # a slice writes faster than an index array
        self._robot_dof = as_slice(station.robot_dof)
        self._load_qpos = as_slice(station.load_qpos)
        self._load_dof = as_slice(station.load_dof)
        self._load_values = station.load_values
        self._free_dof_idx = as_slice(self._free_dof)
        self._cable_mass = float(self._free_dof_mass.sum() / 3.0)
        self._kinetic_tolerance = 0.5 * self._cable_mass * self.config.equilibrium_speed ** 2  # [J]
        self._body_pos0 = [self.model.body_pos[c.free_bodies].copy() for c in cables]
        self.reset()

    @staticmethod
    def _torque_scale(station: Station, robot: int) -> float:
        dp = station.config.robots[robot].dresspack
        return dp.linear_density * dp.segment_length * _residual_gravity(station.config.simulation.gravity) * dp.radius

    # ------------------------------------------------------------------------------ state
    def reset(self, q=None, *, settle: bool = True) -> None:
        """Place the robots at ``q`` (default Home), pose every cable smoothly through its nodes, settle."""
        q = self._as_q(self.station.home if q is None else q, "q")
        m, d = self.model, self.data
        timers = [(t.duration, t.number) for t in d.timer]
        mujoco.mj_resetData(m, d)
        for t, (duration, number) in zip(d.timer, timers):  # profiling timers span resets (benchmarks)
            t.duration, t.number = duration, number
        self.q = q.copy()
        self._drive(q, np.zeros_like(q))
        at_home = np.array_equal(q, self.station.home)
        shapes = self.station.home_cable_shapes if at_home else self.station.initial_cable_shapes(q)
        for cable, shape, pos0 in zip(self.station.cables, shapes, self._body_pos0):
            d.qpos[cable.free_qpos] = shape[cable.free_vertices] - pos0
        mujoco.mj_forward(m, d)
        self.motion_time = 0.0
        self.last_settle = None
        if settle:
            self.settle()

    def get_state(self) -> np.ndarray:
        """Full physics state, including the DER reference frames (``mjSTATE_PLASTIC``)."""
        state = np.empty(mujoco.mj_stateSize(self.model, STATE_SPEC))
        mujoco.mj_getState(self.model, self.data, state, STATE_SPEC)
        return np.concatenate([state, self.q.ravel(), [self.motion_time]])

    def set_state(self, state: np.ndarray) -> None:
        n = mujoco.mj_stateSize(self.model, STATE_SPEC)
        nq = self.q.size
        if state.shape != (n + nq + 1,):
            raise ConfigError("state", f"expected a state vector of length {n + nq + 1} from get_state(), "
                                       f"got shape {state.shape}")
        mujoco.mj_setState(self.model, self.data, state[:n], STATE_SPEC)
        self.q = state[n:n + nq].reshape(self.q.shape).copy()
        self.motion_time = float(state[-1])
        mujoco.mj_forward(self.model, self.data)

    # ------------------------------------------------------------------------------ motion
    def motion_limits(self, speed_fraction: float | None = None, *, quasi_static: bool = False) -> JointLimits:
        """:func:`station_motion_limits` of this station."""
        return station_motion_limits(self.station, speed_fraction, quasi_static=quasi_static)

    def move_to(self, q_target, *, speed_fraction: float | None = None, settle: bool = True,
                record_every: float | None = None, until: float | None = None,
                record_states: bool = False, on_sample=None, stop_if=None, quasi_static: bool = False) -> MotionTrace:
        """Move all robots along a straight joint-space segment to ``q_target`` and (optionally) settle.

        Timing: the time law (:mod:`time_law`), every joint of every robot within its velocity, acceleration and
        jerk limits, velocities at ``speed_fraction`` of the rated speeds (a program's speed data), or with
        ``quasi_static`` the full-speed motion slowed down in time by that fraction (for probing the cable's
        static response: accelerations shrink with the square). Returns samples every ``record_every`` s.
        With ``until`` (a motion time) the motion stops there, mid-segment, without settling; so it does at the
        first recorded sample for which ``stop_if(time, measures)`` is true (the trace's ``stopped`` set).
        The settle's outcome is kept in ``last_settle``.
        """
        target = self._as_q(q_target, "q_target")
        frac = self.config.speed_fraction if speed_fraction is None else float(speed_fraction)
        if not 0.0 < frac <= 1.0:
            raise ConfigError("speed_fraction", f"must be in (0, 1], got {frac}")
        start = self.q.copy()
        delta = target - start
        dt = self.model.opt.timestep
        # The whole segment is computed up front (same arithmetic as per step) to keep the loop lean.
        frac_done, rate = SegmentMotion(delta, self.motion_limits(frac, quasi_static=quasi_static)).on_steps(dt)
        steps = len(frac_done)
        trace = MotionTrace()
        stride = max(1, int(round(record_every / dt))) if record_every else 0
        path = start.ravel() + frac_done[:, None] * delta.ravel()
        vel = rate[:, None] * delta.ravel()
        v_before = self.data.qvel[self._free_dof_idx].copy()
        g_window = _residual_gravity(self.config.gravity) * SETTLE_CHECK_EVERY * dt
        for k in range(1, steps + 1):
            self._step(path[k - 1], vel[k - 1])
            if k % SETTLE_CHECK_EVERY == 0:
                v_now = self.data.qvel[self._free_dof_idx]
                accel = float(np.max(np.linalg.norm((v_now - v_before).reshape(-1, 3), axis=1))) / g_window
                trace.max_acceleration_ratio = max(trace.max_acceleration_ratio, accel)
                v_before = v_now.copy()
            if stride and (k % stride == 0 or k == steps):
                self._record(trace, self.motion_time + k * dt, path[k - 1].reshape(start.shape), record_states)
                if on_sample is not None:
                    on_sample(self.motion_time + k * dt)
                if stop_if is not None and stop_if(self.motion_time + k * dt, trace.measures[-1]):
                    trace.stopped = True
            if trace.stopped or until is not None and self.motion_time + k * dt >= until:  # frozen mid-motion
                self.q = path[k - 1].reshape(start.shape).copy()
                self.motion_time += k * dt
                return trace
        self.q = target.copy()
        self.motion_time += steps * dt
        self._drive(self.q, np.zeros_like(self.q))
        self._check_finite()
        if settle:
            self.settle()
        if stride and steps == 0:
            self._record(trace, self.motion_time, self.q, record_states)
            trace.stopped = stop_if is not None and bool(stop_if(self.motion_time, trace.measures[-1]))
        return trace

    def follow(self, schedule_at, duration: float, *, record_every: float, on_sample=None) -> tuple[list, list]:
        """Drive every robot along a timed program for ``duration`` seconds from the current motion time:
        ``schedule_at(times) -> (q, qdot)`` with shapes (N, n_robots, 6) (a station schedule's ``at``). The cables
        are never settled in between: robots that stand still (welding, waiting) let them relax on the clock.
        Returns the sample times and per sample the wear measures of each cable (every ``record_every`` s)."""
        dt = self.model.opt.timestep
        steps = int(np.ceil(duration / dt))
        stride = max(1, int(round(record_every / dt)))
        t_start = self.motion_time
        times, samples = [], []
        chunk = 2000  # steps computed per call of the program (bounded memory over long cycles)
        for c0 in range(0, steps, chunk):
            ks = np.arange(c0 + 1, min(steps, c0 + chunk) + 1)
            q, qd = schedule_at(t_start + ks * dt)
            for k, qk, qdk in zip(ks, q, qd):
                self._step(qk.ravel(), qdk.ravel())
                if k % stride == 0 or k == steps:
                    self.q = qk.copy()
                    self.motion_time = t_start + k * dt
                    times.append(self.motion_time)
                    samples.append(self.cable_measures())
                    if on_sample is not None:
                        on_sample(self.motion_time)
            self._check_finite()
        self.motion_time = t_start + steps * dt
        return times, samples

    def settle(self, max_time: float | None = None, *, timestep: float | None = None) -> SettleResult:
        """Hold the robots still until the cables are in static equilibrium (or ``max_time`` runs out).

        Equilibrium is checked by its residual (:meth:`equilibrium`) every few steps; the result says
        whether it was reached (``converged``) and is kept in ``last_settle``. ``timestep`` (default
        ``simulation.settle_timestep``) may exceed the motion timestep: with the robots still, only the
        relaxation is integrated, and no model parameter depends on the timestep.
        """
        max_time = self.config.settle_time if max_time is None else float(max_time)
        dt = self.config.settle_timestep if timestep is None else float(timestep)
        steps = int(np.ceil(max_time / dt))
        self._drive(self.q, np.zeros_like(self.q))
        with self._relaxation(dt):
            done, eq = self._settle_steps(steps, dt)
        self._check_finite()
        mujoco.mj_forward(self.model, self.data)
        self.last_settle = SettleResult(done * dt, eq)
        return self.last_settle

    def _settle_steps(self, steps: int, dt: float) -> tuple[int, Equilibrium]:
        done = 0
        q = self.q.ravel()
        zero = np.zeros_like(q)
        eq = self.equilibrium(timestep=dt)
        while done < steps and not eq.converged:
            n = min(SETTLE_CHECK_EVERY, steps - done)
            for _ in range(n):
                self._step(q, zero)
            done += n
            if done < steps and self.kinetic_energy() >= self._kinetic_tolerance:
                continue  # still moving: not converged whatever the static forces, so their pass is skipped
            eq = self.equilibrium(timestep=dt)
        return done, eq

    def _step(self, q_flat: np.ndarray, qdot_flat: np.ndarray) -> None:
        """One physics step with the robots at ``q_flat`` moving at ``qdot_flat`` (load cells held)."""
        d = self.data
        self._drive(q_flat, qdot_flat)
        d.qfrc_applied[self._free_dof_idx] = self._drag * d.qvel[self._free_dof_idx]
        mujoco.mj_step(self.model, d)

    # ------------------------------------------------------------------------------ queries
    def static_forces(self, *, timestep: float | None = None) -> mujoco.MjData:
        """The current configuration's static forces: a forward pass with every velocity zeroed.

        Returns a scratch ``MjData`` (same positions and DER frames as ``data``) whose constraint and
        elastic forces are those of the cable at rest in this shape: what the equilibrium residual, the
        tensions and the node loads are read from. Stiff soft constraints and static friction act through
        MuJoCo's discrete-time model, so the pass uses the relaxation timestep (``simulation.settle_timestep``
        unless given), the step at which settled shapes are found: a state is an equilibrium when one
        relaxation step would leave it at rest.
        """
        m, s, state = self.model, self._scratch, self._state_buffer
        mujoco.mj_getState(m, self.data, state, STATE_SPEC)
        mujoco.mj_setState(m, s, state, STATE_SPEC)
        s.qvel[:] = 0.0
        s.qfrc_applied[:] = 0.0
        with self._relaxation(self.config.settle_timestep if timestep is None else float(timestep)):
            mujoco.mj_forward(m, s)
        return s

    def equilibrium(self, *, timestep: float | None = None) -> Equilibrium:
        """The equilibrium residual of the current state (see :class:`Equilibrium` and :meth:`static_forces`)."""
        s = self.static_forces(timestep=timestep)
        net = s.qfrc_spring + s.qfrc_constraint - s.qfrc_bias
        force = np.linalg.norm(net[self._free_dof].reshape(-1, 3), axis=1) / self._free_weight
        torque = np.abs(net[self._twist_dof]) / self._twist_scale if len(self._twist_dof) else np.zeros(1)
        kinetic = self.kinetic_energy()
        tol = self.config.equilibrium_tolerance
        f, t = float(force.max()), float(torque.max())
        return Equilibrium(f, t, kinetic, bool(f < tol and t < tol and kinetic < self._kinetic_tolerance))

    def measures(self) -> WearMeasures:
        """Station-level wear measures of the current configuration (worst over all cables)."""
        return self.measures_and_states()[0]

    def measures_and_states(self) -> tuple[WearMeasures, list[SegmentState]]:
        """The station-level measures and every cable's segment states, from one static-force pass."""
        static = self.static_forces()
        samples = self._samples(static)
        states = self._segment_states(static, samples)
        return WearMeasures.worst(self._cable_measures(static, samples, states)), states

    def cable_measures(self) -> list[WearMeasures]:
        """Wear measures of every cable in its current shape; forces are the shape's static forces."""
        static = self.static_forces()
        samples = self._samples(static)
        return self._cable_measures(static, samples, self._segment_states(static, samples))

    def _samples(self, static: mujoco.MjData) -> list[CableSample]:
        """Every cable's shape, edge forces and twists, read once for its segment state and its measures."""
        return [reader.arrays.sample(static) for reader in self._readers()]

    def _cable_measures(self, static: mujoco.MjData, samples: list[CableSample],
                        states: list[SegmentState]) -> list[WearMeasures]:
        out = []
        for reader, r, sample, s in zip(self._readers(), self.station.config.robots, samples, states):
            out.append(reader.arrays.measure(self.station, static, self.probe, sample, **worst_rates(s, r.dresspack)))
        return out

    def node_loads(self, robot: int = 0):
        """Force [N] and torque [N m] each node of a cable carries, in the node frame (see measures.node_loads)."""
        return node_loads(self.model, self.static_forces(), self.station.cables[robot])

    def cable_points(self, robot: int = 0) -> np.ndarray:
        return cable_points(self.data, self.station.cables[robot])

    def kinetic_energy(self) -> float:
        """Kinetic energy of the cables [J]: free vertices and twist hinges."""
        v = self.data.qvel[self._free_dof_idx]
        kinetic = 0.5 * float(self._free_dof_mass @ (v * v))
        if len(self._twist_dof):
            w = self.data.qvel[self._twist_dof]
            kinetic += 0.5 * float(self._twist_inertia @ (w * w))
        return kinetic

    def max_vertex_speed(self) -> float:
        return float(np.max(np.abs(self.data.qvel[self._free_dof])))

    # ------------------------------------------------------------------------------ internals
    @contextmanager
    def _relaxation(self, timestep: float):
        """The relaxation phase's timestep, restored afterwards. Nothing in the model is derived from the timestep
        (constraint stiffness is set in force units), so only the integration step changes; the solver's tolerance
        is the model's (``stations.station.SOLVER_TOLERANCE``), the same for motions and settles."""
        opt = self.model.opt
        before = opt.timestep
        opt.timestep = timestep
        try:
            yield
        finally:
            opt.timestep = before

    def _drive(self, q: np.ndarray, qdot: np.ndarray) -> None:
        """Write the robots' joints (and hold the load cells): the kinematic part of the state."""
        self.data.qpos[self._robot_qpos] = q.ravel()
        self.data.qvel[self._robot_dof] = qdot.ravel()
        self.data.qpos[self._load_qpos] = self._load_values
        self.data.qvel[self._load_dof] = 0.0

    def _record(self, trace: MotionTrace, t: float, q: np.ndarray, states: bool = False) -> None:
        trace.time.append(t)
        trace.q.append(np.array(q, dtype=float))
        measures, segments = self.measures_and_states()
        trace.measures.append(measures)
        if states:
            trace.states.append(segments)

    def segment_states(self) -> list[SegmentState]:
        """Per cable, the state of every segment now (bending, twist, strain, contact; see segment_state)."""
        static = self.static_forces()
        return self._segment_states(static, self._samples(static))

    def _readers(self) -> list[SegmentStateReader]:
        if self._segment_readers is None:
            self._segment_readers = [SegmentStateReader(self.model, c, r.dresspack.tensile_stiffness)
                                     for c, r in zip(self.station.cables, self.station.config.robots)]
        return self._segment_readers

    def _segment_states(self, static: mujoco.MjData, samples: list[CableSample]) -> list[SegmentState]:
        return [reader.state(static, self.data, sample) for reader, sample in zip(self._readers(), samples)]

    def _as_q(self, q, field: str) -> np.ndarray:
        return station_joints(self.station, q, field)

    def _check_finite(self) -> None:
        if not (np.isfinite(self.data.qpos).all() and np.isfinite(self.data.qvel).all()):
            raise SimulationError("the simulation diverged (non-finite state); reduce simulation.timestep "
                                  "or the motion speed")
