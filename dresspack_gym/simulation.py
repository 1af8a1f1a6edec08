"""Quasi-static simulation of robots carrying dresspacks: kinematic joint motion plus cable settling.

The robots are position-driven: their joint positions and velocities are written before every
physics step, so the cable never pushes them. Motions follow straight joint-space segments with a
smooth (cubic) time law at a fraction of the rated joint speeds; the cable is damped so that its
shape stays near equilibrium while still depending on the path travelled.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from .errors import ConfigError, SimulationError
from .measures import ClearanceProbe, WearMeasures, cable_points, measure_cable
from .station import Station

STATE_SPEC = mujoco.mjtState.mjSTATE_INTEGRATION | mujoco.mjtState.mjSTATE_PLASTIC
# Settling checks vertex speeds every this many steps (cheap, and settling is never shorter).
SETTLE_CHECK_EVERY = 10


@dataclass
class MotionTrace:
    """Samples recorded along a motion: time [s], robot joints [rad] and station-level measures."""

    time: list[float] = field(default_factory=list)
    q: list[np.ndarray] = field(default_factory=list)
    measures: list[WearMeasures] = field(default_factory=list)

    def extend(self, other: "MotionTrace") -> None:
        self.time += other.time
        self.q += other.q
        self.measures += other.measures


def _as_slice(index: np.ndarray):
    """``index`` as a slice when it is a contiguous ascending range, else unchanged."""
    index = np.asarray(index)
    if len(index) and np.array_equal(index, np.arange(index[0], index[0] + len(index))):
        return slice(int(index[0]), int(index[0]) + len(index))
    return index


class CableSimulator:
    """One station's physics: move robots, let cables settle, measure wear, save/restore state."""

    def __init__(self, station: Station):
        self.station = station
        self.model = station.model
        self.data = mujoco.MjData(self.model)
        self.config = station.config.simulation
        self.probe = ClearanceProbe(station)
        self.q = station.home.copy()  # commanded robot joints, (n_robots, 6)
        self.motion_time = 0.0  # simulated seconds spent in robot motion (the cycle time)
        self._vertex_dofs = np.concatenate([c.vertex_dof.ravel() for c in station.cables])
        self._robot_qpos = _as_slice(station.robot_qpos)  # a slice writes faster than an index array
        self._robot_dof = _as_slice(station.robot_dof)
        self._body_pos0 = [self.model.body_pos[c.vertex_bodies].copy() for c in station.cables]
        self.reset()

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
            d.qpos[cable.vertex_qpos] = shape - pos0
        mujoco.mj_forward(m, d)
        self.motion_time = 0.0
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
    def move_to(self, q_target, *, speed_fraction: float | None = None, settle: bool = True,
                record_every: float | None = None, until: float | None = None) -> MotionTrace:
        """Move all robots along a straight joint-space segment to ``q_target`` and (optionally) settle.

        Duration: the slowest joint at ``speed_fraction`` of its rated speed, stretched by 1.5 for the
        cubic time law (whose peak speed is 1.5x the mean). Returns samples every ``record_every`` s.
        With ``until`` (a motion time) the motion stops there, mid-segment, without settling.
        """
        target = self._as_q(q_target, "q_target")
        frac = self.config.speed_fraction if speed_fraction is None else float(speed_fraction)
        if not 0.0 < frac <= 1.0:
            raise ConfigError("speed_fraction", f"must be in (0, 1], got {frac}")
        start = self.q.copy()
        delta = target - start
        speeds = np.stack([r.robot.joint_speed for r in self.station.config.robots]) * frac
        duration = 1.5 * float(np.max(np.abs(delta) / speeds)) if np.any(delta) else 0.0
        dt = self.model.opt.timestep
        steps = int(np.ceil(duration / dt)) if duration > 0 else 0
        trace = MotionTrace()
        stride = max(1, int(round(record_every / dt))) if record_every else 0
        # The whole segment is computed up front (same arithmetic as per step) to keep the loop lean.
        taus = [k / steps for k in range(1, steps + 1)]
        path = start.ravel() + np.array([3 * t**2 - 2 * t**3 for t in taus])[:, None] * delta.ravel()
        vel = np.array([(6 * t - 6 * t**2) / duration for t in taus])[:, None] * delta.ravel()
        qpos, qvel = self.data.qpos, self.data.qvel
        iq, iv = self._robot_qpos, self._robot_dof
        for k in range(1, steps + 1):
            qpos[iq] = path[k - 1]
            qvel[iv] = vel[k - 1]
            mujoco.mj_step(self.model, self.data)
            if stride and (k % stride == 0 or k == steps):
                self._record(trace, self.motion_time + k * dt, path[k - 1].reshape(start.shape))
            if until is not None and self.motion_time + k * dt >= until:  # frozen mid-motion (e.g. to render)
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
            self._record(trace, self.motion_time, self.q)
        return trace

    def follow(self, path, *, speed_fraction: float | None = None, settle_each: bool = False,
               record_every: float | None = None) -> MotionTrace:
        """Move through the waypoints of ``path`` (K x 6, or K x n_robots x 6) in order, settle at the end."""
        path = np.asarray(path, dtype=float)
        trace = MotionTrace()
        for i, q in enumerate(path):
            last = i == len(path) - 1
            trace.extend(self.move_to(q, speed_fraction=speed_fraction, settle=settle_each or last,
                                      record_every=record_every))
        return trace

    def settle(self, max_time: float | None = None, *, timestep: float | None = None) -> float:
        """Hold the robots still until the cables are in equilibrium; returns the simulated seconds used.

        Equilibrium: every vertex slower than ``settle_speed`` and accelerating less than ``settle_accel``
        (a slow longitudinal bounce of the cable has small speeds but large accelerations). ``timestep``
        may exceed the motion timestep: with the robots still, only the (stable) relaxation is integrated.
        """
        max_time = self.config.settle_time if max_time is None else max_time
        dt_motion = self.model.opt.timestep
        dt = dt_motion if timestep is None else float(timestep)
        steps = int(np.ceil(max_time / dt))
        self._drive(self.q, np.zeros_like(self.q))
        self.model.opt.timestep = dt
        try:
            done = self._settle_steps(steps)
        finally:
            self.model.opt.timestep = dt_motion
        self._check_finite()
        mujoco.mj_forward(self.model, self.data)
        return done * dt

    def _settle_steps(self, steps: int) -> int:
        done = 0
        while done < steps:
            n = min(SETTLE_CHECK_EVERY, steps - done)
            q = self.q.ravel()
            for _ in range(n):
                self.data.qpos[self._robot_qpos] = q
                self.data.qvel[self._robot_dof] = 0.0
                mujoco.mj_step(self.model, self.data)
            done += n
            if (np.max(np.abs(self.data.qvel[self._vertex_dofs])) < self.config.settle_speed
                    and np.max(np.abs(self.data.qacc[self._vertex_dofs])) < self.config.settle_accel):
                break
        return done

    # ------------------------------------------------------------------------------ queries
    def measures(self) -> WearMeasures:
        """Station-level wear measures of the current configuration (worst over all cables)."""
        return WearMeasures.worst(self.cable_measures())

    def cable_measures(self) -> list[WearMeasures]:
        return [measure_cable(self.station, self.data, c, self.probe) for c in self.station.cables]

    def cable_points(self, robot: int = 0) -> np.ndarray:
        return cable_points(self.data, self.station.cables[robot])

    def max_vertex_speed(self) -> float:
        return float(np.max(np.abs(self.data.qvel[self._vertex_dofs])))

    # ------------------------------------------------------------------------------ internals
    def _drive(self, q: np.ndarray, qdot: np.ndarray) -> None:
        self.data.qpos[self._robot_qpos] = q.ravel()
        self.data.qvel[self._robot_dof] = qdot.ravel()

    def _record(self, trace: MotionTrace, t: float, q: np.ndarray) -> None:
        mujoco.mj_forward(self.model, self.data)
        trace.time.append(t)
        trace.q.append(np.array(q, dtype=float))
        trace.measures.append(self.measures())

    def _as_q(self, q, field: str) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        n = self.station.n_robots
        if q.shape == (6,) and n == 1:
            q = q[None, :]
        if q.shape != (n, 6):
            raise ConfigError(field, f"expected joint angles of shape (6,) or ({n}, 6) in radians, got {q.shape}")
        if not np.isfinite(q).all():
            raise ConfigError(field, "joint angles must be finite")
        for i, r in enumerate(self.station.config.robots):
            lim = r.robot.joint_limits
            bad = np.where((q[i] < lim[:, 0] - 1e-9) | (q[i] > lim[:, 1] + 1e-9))[0]
            if len(bad):
                j = int(bad[0])
                raise ConfigError(f"{field}[{j}]" if n == 1 else f"{field}[{i}][{j}]",
                                  f"{np.degrees(q[i, j]):.2f} deg is outside joint {j + 1}'s limits "
                                  f"[{np.degrees(lim[j, 0]):.0f}, {np.degrees(lim[j, 1]):.0f}] deg of robot {r.name!r}")
        return q

    def _check_finite(self) -> None:
        if not (np.isfinite(self.data.qpos).all() and np.isfinite(self.data.qvel).all()):
            raise SimulationError("the simulation diverged (non-finite state); reduce simulation.timestep "
                                  "or the motion speed")
