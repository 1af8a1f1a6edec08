"""The dynamic engine's cable in motion against analytic dynamics: torsional waves, the hanging chain's swing and the
drag that damps it, each alone (the other effects switched off or made negligible) and at several resolutions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import world_cable_station

from dresspack_gym.physics.measures import vertex_twists
from dresspack_gym.physics.simulation import CableSimulator

G = 9.81
RHO, RADIUS = 1.25, 0.03  # the thesis cable's linear density [kg/m] and radius [m] (tests/helpers.THESIS_CABLE)
UNDAMPED = {"cable_damping": 0.0, "bending_damping": 0.0}


def _period(t: np.ndarray, x: np.ndarray) -> float:
    """The mean period of a one-mode oscillation from its upward zero crossings (linearly interpolated)."""
    x = x - x.mean()
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    crossings = t[up] - x[up] * (t[up + 1] - t[up]) / (x[up + 1] - x[up])
    assert len(crossings) >= 3, "fewer than two whole periods recorded"
    return float(np.diff(crossings).mean())


def _run(sim: CableSimulator, seconds: float, read) -> tuple[np.ndarray, np.ndarray]:
    """Step the cable with the robots still for ``seconds``; ``read(sim)`` after every step."""
    dt = sim.model.opt.timestep
    q, still = sim.q.ravel().copy(), np.zeros(sim.q.size)
    values = []
    for _ in range(int(round(seconds / dt))):
        sim._step(q, still)
        values.append(read(sim))
    return dt * np.arange(1, len(values) + 1), np.array(values)


def _twisting_station(length: float, segments: int, gj: float, timestep: float):
    """A straight rod along the wrist's j6 axis, clamped in the world at one end and on link 6 at the other
    (turning j6 turns that clamp about the rod), no gravity, no damping."""
    probe = world_cable_station([{"name": "a", "body": "world", "pos": [0, 0, 3], "direction": [0, 0, -1]}])
    wrist = probe.robots[0].kinematics.link_frames(np.zeros(6))[6][:3, 3]
    tip = 0.3
    start = wrist + np.array([tip + length, 0.0, 0.0])
    return world_cable_station(
        [{"name": "world_clamp", "body": "world", "pos": start.tolist(), "direction": [-1, 0, 0]},
         {"name": "wrist_clamp", "body": "link6", "pos": [tip, 0, 0], "direction": [-1, 0, 0], "at": "end"}],
        cable={"length": length, "segments": segments, "torsional_stiffness": gj, "bending_stiffness": 0.1},
        gravity=0.0, simulation={**UNDAMPED, "timestep": timestep})


@pytest.mark.parametrize("segments", [10, 20, 40])
def test_torsional_waves_cross_the_rod_at_the_speed_of_gj_over_its_polar_inertia(segments):
    """A rod twisted by its clamp, then the clamp turned back at once: the rod rings at the clamped-clamped torsional
    period 2 L / c, c = sqrt(GJ / (rho r^2 / 2)) (the wave equation rho J phi_tt = G J phi_xx of a solid circular
    section), L the twisting length between the clamped edges."""
    length, gj = 1.0, 0.01
    station = _twisting_station(length, segments, gj, timestep=0.002)
    sim = CableSimulator(station)
    q = station.home.copy()
    q[0, 5] = math.radians(30)
    sim.move_to(q)
    assert sim.last_settle.converged  # twisted at rest (its residual checked) before the clamp turns back
    sim.q = station.home.copy()  # the clamp turned back within one step
    cable = station.cables[0]

    def mid_span_angle(s):
        twists = np.concatenate(vertex_twists(station.model, s.data, cable))
        return twists[: len(twists) // 2].sum()

    t, angle = _run(sim, 1.6, mid_span_angle)
    wave_speed = math.sqrt(gj / (0.5 * RHO * RADIUS ** 2))
    twisting_length = length - length / segments
    assert abs(angle[0]) > 0.1  # the rod was twisted when released
    assert _period(t, angle) == pytest.approx(2 * twisting_length / wave_speed, rel=0.02)


def _hanging_station(segments: int, drag: float):
    """The thesis cable hanging from a clamp in the world, nearly as limp as a chain (EI 1e-4 N m^2: its bending
    length (EI / rho g)^(1/3) = 2 cm against 1.74 m), undamped but for ``drag``."""
    return world_cable_station([{"name": "top", "body": "world", "pos": [0, 0, 3], "direction": [0, 0, -1]}],
                               cable={"segments": segments, "bending_stiffness": 1e-4},
                               simulation={**UNDAMPED, "cable_damping": drag})


def _swing(segments: int, drag: float, seconds: float) -> tuple[np.ndarray, np.ndarray]:
    """The free end's sideways swing once the cable, settled (damped) under gravity tilted by 2 degrees, is let go
    on the undamped cable (but for ``drag``) under vertical gravity."""
    tilted = CableSimulator(_hanging_station(segments, 5.0))
    tilt = math.radians(2.0)
    tilted.model.opt.gravity[:] = (G * math.sin(tilt), 0.0, -G * math.cos(tilt))
    assert tilted.settle(30.0).converged
    sim = CableSimulator(_hanging_station(segments, drag))
    sim.set_state(tilted.get_state())
    return _run(sim, seconds, lambda s: s.cable_points()[-1, 0])


def _frequency(t: np.ndarray, x: np.ndarray, near: float) -> float:
    """The strongest frequency [Hz] of ``x`` within a factor 1.5 of ``near`` (Hann window, spectrum zero-padded
    64-fold so that its peak falls between the record's own frequency bins)."""
    dt = t[1] - t[0]
    n = 64 * len(x)
    spectrum = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(len(x)), n))
    f = np.fft.rfftfreq(n, dt)
    band = (f > near / 1.5) & (f < near * 1.5)
    return float(f[band][np.argmax(spectrum[band])])


@pytest.mark.parametrize("segments", [12, 24, 48])
def test_a_hanging_cable_swings_at_the_hanging_chains_frequency(segments):
    """A chain hanging from a point swings in its first mode at omega = (j_0,1 / 2) sqrt(g / l), j_0,1 = 2.4048 the
    first zero of the Bessel function J0 (Bernoulli; Euler). The clamp holds the first edge, so the chain that swings
    is l = L - h long; the frequency converges on the whole cable's as h shrinks."""
    length = 1.74
    t, x = _swing(segments, 0.0, 30.0)
    chain = length - length / segments
    omega = 2.404826 / 2 * math.sqrt(G / chain)
    assert np.ptp(x) > 0.1  # it swings: the end starts 61 mm to the side
    assert _frequency(t, x, omega / (2 * math.pi)) == pytest.approx(omega / (2 * math.pi), rel=0.01)


def test_drag_damps_the_swing_at_half_its_rate():
    """Viscous drag f = -c m v on every vertex damps every mode as exp(-c t / 2): against the same swing undamped
    (whose slow decay is the integrator's own), the swing's height falls at the rate c / 2."""
    drag, window = 0.3, 2.2  # [1/s], [s]: about one period
    t, undamped = _swing(24, 0.0, 12.0)
    _, damped = _swing(24, drag, 12.0)
    k = int(round(window / (t[1] - t[0])))
    starts = range(0, len(t) - k + 1, k)
    centres = np.array([t[i: i + k].mean() for i in starts])
    ratio = np.array([np.ptp(damped[i: i + k]) / np.ptp(undamped[i: i + k]) for i in starts])
    rate = -np.polyfit(centres, np.log(ratio), 1)[0]
    assert rate == pytest.approx(drag / 2, rel=0.05)
