"""The rod engine's statics against closed forms: catenary, axial stretch, cantilever, uniform torsion; rest is rest."""

import numpy as np
import pytest
from scipy.optimize import brentq

from dresspack_gym.physics.measures import vertex_curvatures
from dresspack_gym.rod.loads import holder_loads
from dresspack_gym.rod.model import RodModel
from dresspack_gym.rod.rod import Rod

G = 9.81


def hanging(segments, *, span=1.6, length=2.0, ea=1e6, ei=1e-5):
    model = RodModel(length, segments, 1.25, ea, ei, 0.1, held=(0, segments))
    s = np.linspace(0.0, 1.0, segments + 1)
    pts = np.stack([s * span, 0 * s, -0.6 * 4 * s * (1 - s)], axis=1)
    return Rod(model, pts)


@pytest.mark.parametrize("segments", [12, 24, 48])
def test_catenary_sag_and_end_tension(segments):
    """A nearly inextensible, nearly limp cable hangs as a catenary: sag and the horizontal tension rho g a."""
    span, length = 1.6, 2.0
    rod = hanging(segments, span=span, length=length)
    result = rod.solve_rest(tolerance=1e-7)
    assert result.converged, result
    a = brentq(lambda a: 2 * a * np.sinh(span / (2 * a)) - length, 0.05, 100)
    sag = a * np.cosh(span / (2 * a)) - a
    # the discrete chain's sag converges to the catenary's at O(h^2)
    assert -rod.x[:, 2].min() == pytest.approx(sag, rel=2.0 / segments ** 2)
    horizontal = rod.static_forces()[0, 0]  # the cable's pull on its left support
    assert horizontal == pytest.approx(1.25 * G * a, rel=3.0 / segments ** 2)


@pytest.mark.parametrize("segments", [8, 24, 48])
def test_axial_stretch_is_ea_strain(segments):
    ea, length, strain = 1400.0, 1.0, 0.01
    model = RodModel(length, segments, 1.25, ea, 0.1, 0.1, held=(0, segments), gravity=(0.0, 0.0, 0.0))
    pts = np.zeros((segments + 1, 3))
    pts[:, 0] = np.linspace(0, length, segments + 1)
    rod = Rod(model, pts)
    result = rod.solve_rest(held_pos=[[0, 0, 0], [length * (1 + strain), 0, 0]], tolerance=1e-8)
    assert result.converged
    np.testing.assert_allclose(rod.tensions(), ea * strain, rtol=1e-9)
    np.testing.assert_allclose(rod.static_forces()[-1], [-ea * strain, 0, 0], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("segments", [12, 24, 48])
def test_cantilever_tip_deflection_under_own_weight(segments):
    """Small deflection of a clamped-free beam under its weight q: w_tip = q L^4 / (8 EI)."""
    length, rho, ei = 1.0, 0.1, 10.0
    model = RodModel(length, segments, rho, 1e5, ei, 1.0, held=(0, 1))
    pts = np.zeros((segments + 1, 3))
    pts[:, 0] = np.linspace(0, length, segments + 1)
    rod = Rod(model, pts)
    assert rod.solve_rest(tolerance=1e-7).converged
    expected = rho * G * length ** 4 / (8 * ei)
    # the clamp holds the first edge, so the beam is shorter by half an edge at the root: O(h) error
    assert -rod.x[-1, 2] == pytest.approx(expected, rel=3.0 / segments)


@pytest.mark.parametrize("segments", [6, 24, 48])
@pytest.mark.parametrize("angle", [0.5, 2.0, -3.0])
def test_torsion_is_uniform_and_gj_theta_over_l(segments, angle):
    """A straight rod whose far clamp is turned by theta holds twist theta, energy GJ theta^2 / (2 L)."""
    gj, length = 0.1, 1.0
    model = RodModel(length, segments, 1.25, 1400.0, 0.1, gj, held=(0, 1, segments - 1, segments),
                     spans=((0, segments - 1),), gravity=(0.0, 0.0, 0.0))
    pts = np.zeros((segments + 1, 3))
    pts[:, 0] = np.linspace(0, length, segments + 1)
    near = [0.0, 1.0, 0.0]
    far = [0.0, np.cos(angle), np.sin(angle)]
    rod = Rod(model, pts, clamp_directors=np.array([[near, far]]))
    rod.ref[:] = near
    assert rod.solve_rest(tolerance=1e-9).converged
    assert rod.twists()[0] == pytest.approx(angle, abs=1e-12)
    span = (segments - 1) * length / segments
    assert rod.twist_rates()[0] == pytest.approx(angle / span, rel=1e-12)
    np.testing.assert_allclose(rod.x[:, 1:], 0.0, atol=1e-12)  # below buckling: stays straight


def test_rest_is_rest():
    """A settled cable simulated on with its holders still does not move."""
    rod = hanging(24, ea=1400.0, ei=0.1)
    assert rod.solve_rest(tolerance=1e-8).converged
    settled = rod.x.copy()
    for _ in range(20):
        result = rod.step(rod.x[[0, 24]], 0.05, tolerance=1e-6)
        assert result.converged
    assert np.abs(rod.x - settled).max() < 1e-9


def test_energy_does_not_rise_without_drag():
    """Implicit Euler dissipates: a swinging cable's mechanical energy never rises from step to step."""
    model = RodModel(1.0, 24, 1.25, 1400.0, 0.1, 0.1, held=(0,), damping=0.0)
    pts = np.zeros((25, 3))
    pts[:, 0] = np.linspace(0, 1.0, 25)
    rod = Rod(model, pts)

    def energy():
        t = rod.tensions()
        stretch = 0.5 * (t ** 2 / model.tensile_stiffness * model.segment_length).sum()
        x = rod.x
        e, f = x[1:-1] - x[:-2], x[2:] - x[1:-1]
        p, s = np.linalg.norm(e, axis=1) * np.linalg.norm(f, axis=1), (e * f).sum(axis=1)
        bend = (2 * model.bending_stiffness / model.segment_length * (p - s) / (p + s)).sum()
        return stretch + bend + G * (model.masses @ x[:, 2]) + rod.kinetic_energy()

    before = energy()
    for _ in range(60):
        assert rod.step([[0, 0, 0]], 0.01, tolerance=1e-8).converged
        now = energy()
        assert now <= before + 1e-9
        before = now
    assert rod.x[:, 2].min() < -0.5  # it did swing down


@pytest.mark.parametrize("segments", [12, 24, 48])
def test_rod_clamped_on_a_semicircle_rests_on_the_circle(segments):
    """Both ends clamped on a circle of radius R along its tangents, no gravity: the rest shape is the arc, the
    curvature 1/R everywhere and every clamp carries the moment EI / R (no force)."""
    radius, ei = 0.4, 0.1
    s = np.linspace(0.0, np.pi, segments + 1)
    arc = np.stack([radius * np.sin(s), np.zeros_like(s), radius * (1 - np.cos(s))], axis=1)
    # the discrete arc's chords are shorter than its arc length: the rest lengths of the polygon through it
    chord = 2 * radius * np.sin(np.pi / segments / 2)
    model = RodModel(chord * segments, segments, 1.25, 1e5, ei, 0.1, held=(0, 1, segments - 1, segments),
                     gravity=(0.0, 0.0, 0.0))
    start = arc.copy()
    start[2:-2, 1] += 0.02 * np.sin(np.linspace(0, np.pi, segments - 3))  # pushed out of its plane
    rod = Rod(model, start)
    rod.ref[:] = [0.0, 1.0, 0.0]
    assert rod.solve_rest(held_pos=arc[[0, 1, segments - 1, segments]], tolerance=1e-8).converged
    np.testing.assert_allclose(rod.x, arc, atol=1e-7)  # back on the polygon inscribed in the circle
    np.testing.assert_allclose(vertex_curvatures(rod.x), 1 / radius, rtol=1e-9)  # Menger: exact on an arc
    members = np.zeros((2, segments + 1))
    members[0, [0, 1]] = members[1, [segments - 1, segments]] = 1.0
    forces, torques = holder_loads(rod, members, np.array([0, segments]))
    np.testing.assert_allclose(forces, 0.0, atol=1e-7)
    # the discrete bend moment 2 EI tan(phi/2) / lv converges to EI / R at O(h^2)
    assert np.linalg.norm(torques, axis=1) == pytest.approx(ei / radius, rel=4.0 / segments ** 2)  # 2.6 % at 12
