"""Lagged smoothed Coulomb friction: mollifier, sliding force, relative motion, derivatives."""

import ipctk
import numpy as np
import pytest
from contact_shapes import KINDS, SIZES, rotation

from dresspack_gym.rod.contact.barrier import barrier_d1
from dresspack_gym.rod.contact.friction import (
    f0,
    f1,
    friction_accumulate,
    friction_energy,
    friction_force,
    friction_lag,
    friction_relag,
    friction_settled,
)
from dresspack_gym.rod.contact.primitives import CYLINDER, PLANE
from dresspack_gym.rod.contact.warm import compile_kernels

R, DHAT, KAPPA, MU, EPS = 0.01, 0.2, 10.0, 0.4, 1e-3

compile_kernels()  # one worker compiles, the others load numba's cache


def rot_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def prims_of(kind, pos, rot):
    return np.array([kind], np.int64), np.array([pos], float), np.array([rot], float), np.array([SIZES[kind]], float)


def lag(x_prev, prims_prev, prims_now):
    kind, pos_prev, rot_prev, size = prims_prev
    _, pos, rot, _ = prims_now
    mask = np.ones((len(x_prev) - 1, 1), bool)
    return friction_lag(x_prev, R, kind, pos_prev, rot_prev, size, pos, rot, mask, DHAT, KAPPA)


def accumulate(x, lagged, kd=5):
    g = np.zeros_like(x)
    band = np.zeros((kd + 1, x.size))
    e = friction_accumulate(x, *lagged, MU, EPS, g, band)
    return e, g, band


def dense(band):
    n = band.shape[1]
    h = np.zeros((n, n))
    for d in range(band.shape[0]):
        for c in range(n - d):
            h[c + d, c] = h[c, c + d] = band[d, c]
    return h


def test_mollifier_against_ipctk():
    for y in np.linspace(0.0, 3.0, 31) * EPS:
        assert f0(y, EPS) == pytest.approx(ipctk.smooth_friction_f0(y, EPS), rel=1e-12)
        assert f1(y, EPS) == pytest.approx(ipctk.smooth_friction_f1(y, EPS), rel=1e-12, abs=1e-15)
        step = 1e-9
        if y > step and abs(y - EPS) > step:
            assert (f0(y + step, EPS) - f0(y - step, EPS)) / (2 * step) == pytest.approx(f1(y, EPS), abs=1e-6)


def test_sliding_on_a_plane_feels_mu_lam_beyond_eps_and_the_ramp_inside():
    x_prev = np.array([[0.0, 0.0, 0.05], [0.3, 0.0, 0.08]])
    lam = 2.0
    lagged = (np.array([0]), np.array([0.0]), np.array([[0.0, 0.0, 1.0]]), np.array([lam]), x_prev[:1].copy())
    for slide in np.array([0.1, 0.5, 0.9, 1.5, 10.0]) * EPS:
        x = x_prev.copy()
        x[:, 0] += slide
        x[:, 2] -= 0.01  # normal motion is not friction's business
        _, g, _ = accumulate(x, lagged)
        force = -g[0]
        expected = MU * lam * (1.0 if slide >= EPS else 2 * slide / EPS - (slide / EPS) ** 2)
        np.testing.assert_allclose(force, [-expected, 0.0, 0.0], atol=1e-12)
        assert not g[1].any()  # t* = 0: all on the first vertex
        assert friction_force(x, *lagged, MU, EPS)[0] == pytest.approx(expected)


def test_at_rest_friction_is_static_stiffness_without_force():
    x = np.array([[0.0, 0.0, 0.05], [0.3, 0.0, 0.3]])  # only the first end within the barrier's reach
    still = prims_of(PLANE, np.zeros(3), np.eye(3))
    lagged = lag(x, still, still)
    e, g, band = accumulate(x, lagged)
    assert e == pytest.approx(MU * lagged[3][0] * EPS / 3) and not g.any()
    # tangential stiffness mu lam f1'(0) = 2 mu lam / eps on the touching vertex, none along the normal
    np.testing.assert_allclose(dense(band)[:3, :3], np.diag([2.0, 2.0, 0.0]) * MU * lagged[3][0] / EPS)


def test_relative_motion_a_moving_plane_drags_a_still_cable():
    x_prev = np.array([[0.0, 0.0, 0.05], [0.3, 0.0, 0.3]])  # only the first end within the barrier's reach
    still = prims_of(PLANE, np.zeros(3), np.eye(3))
    moved = prims_of(PLANE, np.array([0.01, 0.0, 0.0]), np.eye(3))
    lagged = lag(x_prev, still, moved)
    assert lagged[0].tolist() == [0] and lagged[1][0] == 0.0
    assert lagged[3][0] == pytest.approx(-0.5 * KAPPA * barrier_d1(0.05 - R, DHAT))  # the end's half of the pair
    _, g_plane, _ = accumulate(x_prev, lagged)  # the cable still, the plane moved +x
    x = x_prev.copy()
    x[:, 0] += 0.01
    _, g_cable, _ = accumulate(x, lag(x_prev, still, still))  # the cable moved +x, the plane still
    assert -g_plane[0, 0] == pytest.approx(MU * lagged[3][0])  # dragged along +x
    np.testing.assert_allclose(g_plane, -g_cable, atol=1e-14)


def test_a_spinning_drum_drags_a_still_vertex_along_its_surface():
    x_prev = np.array([[0.3 + R + 0.05, 0.0, 0.0], [0.3 + R + 0.05, 0.0, 0.3]])  # along the drum's side
    angle = 0.01
    lagged = lag(x_prev, prims_of(CYLINDER, np.zeros(3), np.eye(3)), prims_of(CYLINDER, np.zeros(3), rot_z(angle)))
    edge, t, normal, lam, anchor = lagged
    assert len(edge) == 2 and t.tolist() == [0.0, 1.0]  # lying on the side: a contact at each end, none between
    for c in range(2):
        u = (1 - t[c]) * x_prev[0] + t[c] * x_prev[1] - anchor[c]
        u -= (u @ normal[c]) * normal[c]
        np.testing.assert_allclose(u, [0.0, -0.3 * np.sin(angle), 0.0], atol=1e-12)
    _, g, _ = accumulate(x_prev, lagged)
    assert -(g[0, 1] + g[1, 1]) == pytest.approx(MU * lam.sum())  # the surface moves to +y and drags the cable


def relag(x_prev, x, prims_prev, prims_now):
    kind, pos_prev, rot_prev, size = prims_prev
    _, pos, rot, _ = prims_now
    mask = np.ones((len(x) - 1, 1), bool)
    return friction_relag(x_prev, x, R, kind, pos_prev, rot_prev, size, pos, rot, mask, DHAT, KAPPA)


@pytest.mark.parametrize("kind", KINDS)
def test_lagged_again_where_the_step_began_it_is_the_lag(kind):
    """Relagged at the step's start against primitives that did not move, the set is the start's own."""
    rng = np.random.default_rng(90 + kind)
    found = 0
    while found < 3:
        pos, rot = rng.normal(size=3), rotation(rng)
        x = np.cumsum(np.vstack([pos + rng.normal(scale=0.6, size=3), rng.normal(scale=0.12, size=(3, 3))]), axis=0)
        prims = prims_of(kind, pos, rot)
        start = lag(x, prims, prims)
        if len(start[0]) == 0:
            continue
        found += 1
        for a, b in zip(start, relag(x, x, prims, prims)):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)


def test_lagged_again_a_pressed_cable_feels_the_normal_force_at_the_steps_end():
    """A plane rises into a still cable within the step: lagged at the start the pair is far (a small normal force),
    lagged again at the end the normal force is the end's and the anchor still the start's (the cable rode along
    with the surface: no tangential slip)."""
    x_prev = np.array([[0.0, 0.0, 0.15], [0.3, 0.0, 0.4]])  # only the first end within the barrier's reach
    before = prims_of(PLANE, np.zeros(3), np.eye(3))
    after = prims_of(PLANE, np.array([0.002, 0.0, 0.1]), np.eye(3))  # 10 cm up, 2 mm along x
    x = x_prev.copy()
    x[:, 0] += 0.002  # carried along x with the surface
    start, end = lag(x_prev, before, after), relag(x_prev, x, before, after)
    gap = 0.15 - 0.1 - R
    assert end[3][0] == pytest.approx(-0.5 * KAPPA * barrier_d1(gap, DHAT))  # the end's normal force, half the pair
    assert end[3][0] > start[3][0]
    u = x[0] - end[4][0]
    u -= (u @ end[2][0]) * end[2][0]
    np.testing.assert_allclose(u, 0.0, atol=1e-12)  # no slip relative to the surface's material point
    assert friction_force(x, *end, MU, EPS)[0] == pytest.approx(0.0, abs=1e-12)


def test_a_step_is_solved_again_only_where_a_friction_bound_moves_by_the_tolerance():
    """friction_settled compares per vertex the bounds mu lam shared by weights 1 - t*, t*; a pair moved to another
    edge or a new pair counts in full."""
    scale, tol = np.full(4, 2.0), 0.1  # a bound may move by 0.2 N at each vertex
    edge, t, lam = np.array([1]), np.array([0.25]), np.array([1.0])

    def settled(edge2, t2, lam2):
        return friction_settled(4, edge, t, lam, np.array(edge2, np.int64), np.array(t2, float), np.array(lam2, float),
                                MU, scale, tol)

    assert settled([1], [0.25], [1.0])
    assert settled([1], [0.25], [1.0 + 0.19 / (MU * 0.75)])  # vertex 1 takes 3/4 of the change: 0.19 N
    assert not settled([1], [0.25], [1.0 + 0.21 / (MU * 0.75)])
    assert not settled([2], [0.25], [1.0])  # the same force one edge on
    assert not settled([], [], [])  # the contact is gone


@pytest.mark.parametrize("kind", KINDS)
def test_gradient_and_hessian_match_finite_differences(kind):
    rng = np.random.default_rng(60 + kind)
    checked = 0
    step = 1e-8
    while checked < 4:
        pos_prev, rot_prev = rng.normal(size=3), rotation(rng)
        x_prev = np.empty((4, 3))
        x_prev[0] = pos_prev + rng.normal(scale=0.6, size=3)
        for i in range(1, 4):
            x_prev[i] = x_prev[i - 1] + rng.normal(scale=0.12, size=3)
        pos, rot = pos_prev + rng.normal(scale=EPS, size=3), rot_prev @ rot_z(rng.normal(scale=0.002))
        lagged = lag(x_prev, prims_of(kind, pos_prev, rot_prev), prims_of(kind, pos, rot))
        if len(lagged[0]) < 2:
            continue
        x = x_prev + rng.normal(scale=EPS, size=x_prev.shape)
        e, g, band = accumulate(x, lagged, kd=7)
        assert e == pytest.approx(friction_energy(x, *lagged, MU, EPS), rel=1e-14)
        h = dense(band)
        assert np.linalg.eigvalsh(h).min() > -1e-10 * np.abs(h).max()
        fd_g = np.empty(x.size)
        fd_h = np.empty((x.size, x.size))
        for c in range(x.size):
            xp, xm = x.copy(), x.copy()
            xp.flat[c] += step
            xm.flat[c] -= step
            fd_g[c] = (friction_energy(xp, *lagged, MU, EPS) - friction_energy(xm, *lagged, MU, EPS)) / (2 * step)
            fd_h[:, c] = (accumulate(xp, lagged, kd=7)[1] - accumulate(xm, lagged, kd=7)[1]).ravel() / (2 * step)
        np.testing.assert_allclose(g.ravel(), fd_g, rtol=1e-5, atol=1e-6 * np.abs(g).max())
        np.testing.assert_allclose(h, fd_h, rtol=1e-4, atol=1e-5 * np.abs(h).max())
        checked += 1
