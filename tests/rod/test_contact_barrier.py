"""The IPC barrier on edge-primitive gaps: scalar function, gradient and Hessian blocks, band format, PSD projection."""

import ipctk
import numpy as np
import pytest
from contact_shapes import KINDS, SIZES, rotation

from dresspack_gym.rod.contact.barrier import (
    barrier,
    barrier_accumulate,
    barrier_d1,
    barrier_d2,
    barrier_energy,
    point_hessian,
)
from dresspack_gym.rod.contact.primitives import BOX, CAPSULE, PLANE, SPHERE, point_distance
from dresspack_gym.rod.contact.segment import segment_gap
from dresspack_gym.rod.contact.warm import compile_kernels

R, DHAT, KAPPA = 0.01, 0.2, 10.0

compile_kernels()  # one worker compiles, the others load numba's cache


def single(kind, rng):
    """One primitive as the flat arrays."""
    return (np.array([kind], np.int64), rng.normal(size=(1, 3)), rotation(rng)[None].copy(),
            np.array([SIZES[kind]], float))


def gaps(x, prims):
    kind, pos, rot, size = prims
    p, n, h = np.empty(3), np.empty(3), np.empty((3, 3))
    return np.array([segment_gap(x[i], x[i + 1], R, kind[0], pos[0], rot[0], size[0], p, n, h)
                     for i in range(len(x) - 1)])


def near_cable(kind, rng, n_v=4, active=2):
    """A cable whose gaps are each either clear of dhat or inside (0.1 dhat, 0.9 dhat), at least `active` inside."""
    while True:
        prims = single(kind, rng)
        x = np.empty((n_v, 3))
        x[0] = prims[1][0] + rng.normal(scale=0.6, size=3)
        for i in range(1, n_v):
            x[i] = x[i - 1] + rng.normal(scale=0.12, size=3)
        d = gaps(x, prims)[:, 0]
        inside = (d > 0.1 * DHAT) & (d < 0.9 * DHAT)
        if np.all(inside | (d > 1.1 * DHAT)) and inside.sum() >= active:
            return x, prims


def assemble(x, prims, project=True, kd=8):
    g = np.zeros_like(x)
    band = np.zeros((kd + 1, x.size))
    mask = np.ones((len(x) - 1, 1), bool)
    e = barrier_accumulate(x, R, *prims, mask, DHAT, KAPPA, g, band, project)
    return e, g, band


def dense(band):
    n = band.shape[1]
    h = np.zeros((n, n))
    for d in range(band.shape[0]):
        for c in range(n - d):
            h[c + d, c] = h[c, c + d] = band[d, c]
    return h


def energy(x, prims):
    return barrier_energy(x, R, *prims, np.ones((len(x) - 1, 1), bool), DHAT, KAPPA)


def test_scalar_barrier_against_ipctk():
    for d in np.linspace(0.01, 0.99, 23) * DHAT:
        assert barrier(d, DHAT) == pytest.approx(ipctk.barrier(d, DHAT), rel=1e-12)
        assert barrier_d1(d, DHAT) == pytest.approx(ipctk.barrier_first_derivative(d, DHAT), rel=1e-12)
        assert barrier_d2(d, DHAT) == pytest.approx(ipctk.barrier_second_derivative(d, DHAT), rel=1e-12)


def test_barrier_is_c2_at_dhat_and_zero_beyond():
    assert barrier(DHAT, DHAT) == barrier_d1(DHAT, DHAT) == barrier_d2(DHAT, DHAT) == 0.0
    assert barrier(2 * DHAT, DHAT) == 0.0
    below = DHAT * (1 - 1e-4)
    assert barrier(below, DHAT) == pytest.approx(0.0, abs=1e-12)
    assert barrier_d1(below, DHAT) == pytest.approx(0.0, abs=1e-8)
    assert barrier_d2(below, DHAT) == pytest.approx(0.0, abs=1e-3)
    assert barrier_d1(0.5 * DHAT, DHAT) < 0.0 < barrier_d2(0.5 * DHAT, DHAT)


@pytest.mark.parametrize("kind", KINDS)
def test_energy_inf_on_penetration_and_zero_when_far(kind):
    rng = np.random.default_rng(kind)
    prims = single(kind, rng)
    pos, rot = prims[1][0], prims[2][0]
    through = np.array([pos - 2 * rot[:, 0] - 0.05 * rot[:, 2], pos + 2 * rot[:, 0] - 0.05 * rot[:, 2]])
    assert energy(through, prims) == np.inf
    assert assemble(through, prims)[0] == np.inf
    far = through + 5.0 * rot[:, 2]
    e, g, band = assemble(far, prims)
    assert e == 0.0 and energy(far, prims) == 0.0 and not g.any() and not band.any()


def test_disabled_pairs_are_not_seen():
    rng = np.random.default_rng(9)
    kind, pos, rot, size = (np.concatenate(parts) for parts in zip(single(SPHERE, rng), single(BOX, rng)))
    x = np.array([pos[0] - 2 * rot[0][:, 0], pos[0] + 2 * rot[0][:, 0]])  # through the sphere (held by its clamp)
    mask = np.array([[False, True]])
    g = np.zeros_like(x)
    e = barrier_accumulate(x, R, kind, pos, rot, size, mask, DHAT, KAPPA, g, np.zeros((6, 6)), True)
    assert np.isfinite(e) and np.isfinite(barrier_energy(x, R, kind, pos, rot, size, mask, DHAT, KAPPA))
    assert barrier_energy(x, R, kind, pos, rot, size, np.ones((1, 2), bool), DHAT, KAPPA) == np.inf


@pytest.mark.parametrize("kind", KINDS)
def test_gradient_matches_finite_differences(kind):
    rng = np.random.default_rng(30 + kind)
    step = 1e-7
    for _ in range(4):
        x, prims = near_cable(kind, rng)
        e, g, _ = assemble(x, prims)
        assert e == pytest.approx(energy(x, prims), rel=1e-14)
        fd = np.empty_like(x)
        for idx in np.ndindex(*x.shape):
            xp, xm = x.copy(), x.copy()
            xp[idx] += step
            xm[idx] -= step
            fd[idx] = (energy(xp, prims) - energy(xm, prims)) / (2 * step)
        np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-6 * np.abs(g).max())


def fixed_t_gradient(x, prims, ts):
    """Gradient of sum kappa b(dist(p(t_i; x)) - r) with every edge's t held at ts."""
    kind, pos, rot, size = prims
    g = np.zeros_like(x)
    n, h = np.empty(3), np.empty((3, 3))
    for i, t in enumerate(ts):
        # a plane touches each edge at both ends, half weight each; other kinds at the edge's closest point
        contacts = [(0.0, 0.5), (1.0, 0.5)] if kind[0] == 0 else [(t, 1.0)]
        for tc, w in contacts:
            p = (1 - tc) * x[i] + tc * x[i + 1]
            d = point_distance(kind[0], pos[0], rot[0], size[0], p, n, h) - R
            if d >= DHAT:
                continue
            g[i] += (1 - tc) * w * KAPPA * barrier_d1(d, DHAT) * n
            g[i + 1] += tc * w * KAPPA * barrier_d1(d, DHAT) * n
    return g


# kinds whose contacts are fixed points of the edge once t is held (a plane's two ends, a sphere's or capsule's closest
# point); a box or cylinder adds a blended closest point, its weight's slope without a Hessian term (pair_contacts)
FIXED_T_KINDS = [PLANE, SPHERE, CAPSULE]


@pytest.mark.parametrize("kind", FIXED_T_KINDS)
def test_unprojected_hessian_matches_finite_differences_with_t_fixed(kind):
    rng = np.random.default_rng(40 + kind)
    step = 1e-7
    for _ in range(4):
        x, prims = near_cable(kind, rng)
        ts = gaps(x, prims)[:, 1]
        _, g, band = assemble(x, prims, project=False)
        np.testing.assert_allclose(fixed_t_gradient(x, prims, ts), g, rtol=1e-12, atol=1e-14)
        h = dense(band)
        fd = np.empty_like(h)
        for c in range(x.size):
            xp, xm = x.copy(), x.copy()
            xp.flat[c] += step
            xm.flat[c] -= step
            fd[:, c] = (fixed_t_gradient(xp, prims, ts) - fixed_t_gradient(xm, prims, ts)).ravel() / (2 * step)
        np.testing.assert_allclose(h, fd, rtol=1e-4, atol=1e-5 * np.abs(h).max())


@pytest.mark.parametrize("kind", KINDS)
def test_gradient_matches_finite_differences_of_the_energy(kind):
    """The barrier's gradient is the exact slope of its energy for every kind, the box's and cylinder's blended
    closest point included."""
    rng = np.random.default_rng(45 + kind)
    step = 1e-7
    for _ in range(4):
        x, prims = near_cable(kind, rng)
        _, g, _ = assemble(x, prims, project=True)
        fd = np.empty(x.size)
        for c in range(x.size):
            xp, xm = x.copy(), x.copy()
            xp.flat[c] += step
            xm.flat[c] -= step
            fd[c] = (energy(xp, prims) - energy(xm, prims)) / (2 * step)
        np.testing.assert_allclose(g.ravel(), fd, rtol=1e-5, atol=1e-6 * np.abs(g).max())


@pytest.mark.parametrize("kind", KINDS)
def test_projected_blocks_are_the_psd_part_and_give_descent(kind):
    rng = np.random.default_rng(50 + kind)
    for _ in range(4):
        x, prims = near_cable(kind, rng, n_v=2, active=1)
        e, g, band = assemble(x, prims, project=True, kd=5)
        _, _, raw = assemble(x, prims, project=False, kd=5)
        lam, vec = np.linalg.eigh(dense(raw))
        if kind in FIXED_T_KINDS and kind != PLANE:  # one contact: the projection is the raw block's PSD part
            np.testing.assert_allclose(dense(band), (vec * np.maximum(lam, 0.0)) @ vec.T,
                                       atol=1e-9 * np.abs(lam).max())
        assert np.linalg.eigvalsh(dense(band)).min() > -1e-9 * np.abs(lam).max()  # a sum of PSD blocks
        h = dense(band) + 1e-8 * np.abs(lam).max() * np.eye(x.size)
        dx = -np.linalg.solve(h, g.ravel()).reshape(x.shape)
        assert g.ravel() @ dx.ravel() < 0.0
        assert energy(x + 1e-3 * dx, prims) < e


def test_point_hessian_projection_is_the_eigenvalue_clamp():
    rng = np.random.default_rng(7)
    for kind in KINDS:
        _, pos, rot, size = single(kind, rng)
        for _ in range(20):
            p = pos[0] + rng.normal(scale=0.6, size=3)
            n, h = np.empty(3), np.empty((3, 3))
            d = point_distance(kind, pos[0], rot[0], size[0], p, n, h) - R
            if not 0.0 < d < DHAT:
                continue
            raw, projected = np.empty((3, 3)), np.empty((3, 3))
            point_hessian(d, n, h, DHAT, KAPPA, False, raw)
            point_hessian(d, n, h, DHAT, KAPPA, True, projected)
            lam, vec = np.linalg.eigh(raw)
            np.testing.assert_allclose(projected, (vec * np.maximum(lam, 0.0)) @ vec.T, atol=1e-10 * np.abs(lam).max())
