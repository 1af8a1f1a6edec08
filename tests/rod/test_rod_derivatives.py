"""The rod energy's analytic gradients and Hessians against finite differences (stretch, bend, twist, assembled)."""

import numpy as np
import pytest

from dresspack_gym.rod import elastic as el
from dresspack_gym.rod import frames as fr
from dresspack_gym.rod.newton import assemble, total_energy

RNG = np.random.default_rng(0)


def fd_gradient(fun, z, h=1e-6):
    g = np.zeros_like(z)
    for i in range(len(z)):
        zp, zm = z.copy(), z.copy()
        zp[i] += h
        zm[i] -= h
        g[i] = (fun(zp) - fun(zm)) / (2 * h)
    return g


@pytest.mark.parametrize("seed", range(3))
def test_bend_and_stretch_derivatives(seed):
    rng = np.random.default_rng(seed)
    e = rng.normal(size=3)
    f = e + 0.7 * rng.normal(size=3)
    z = np.concatenate([e, f])
    energy = lambda z: el.bend_vertex(z[:3], z[3:], 0.7, True)[0]  # noqa: E731
    grad = lambda z: el.bend_vertex(z[:3], z[3:], 0.7, True)[1]  # noqa: E731
    np.testing.assert_allclose(grad(z), fd_gradient(energy, z), atol=1e-8)
    hess_fd = np.stack([fd_gradient(lambda q: grad(q)[i], z) for i in range(6)])
    np.testing.assert_allclose(el.bend_vertex(z[:3], z[3:], 0.7, True)[2], hess_fd, atol=1e-7)
    kb = el.curvature_binormal(e, f)
    assert energy(z) == pytest.approx(0.7 / 4 * kb @ kb, rel=1e-12)  # 2EI/lv (P-s)/(P+s) = EI|kb|^2/(2 lv)
    jac_fd = np.stack([fd_gradient(lambda q: el.curvature_binormal(q[:3], q[3:])[i], z) for i in range(3)])
    np.testing.assert_allclose(el.curvature_binormal_jacobian(e, f), jac_fd, atol=1e-8)
    gn = el.bend_vertex(e, f, 0.7, False)[2]
    assert np.linalg.eigvalsh(gn).min() > -1e-12  # the Gauss-Newton Hessian is PSD
    s_energy = lambda d: el.stretch_edge(d, 1.3, 50.0, True)[0]  # noqa: E731
    s_grad = lambda d: el.stretch_edge(d, 1.3, 50.0, True)[1]  # noqa: E731
    np.testing.assert_allclose(s_grad(e), fd_gradient(s_energy, e), atol=1e-7)
    np.testing.assert_allclose(el.stretch_edge(e, 1.3, 50.0, True)[2],
                               np.stack([fd_gradient(lambda d: s_grad(d)[i], e) for i in range(3)]), atol=1e-6)


def _polyline(seed, n=4):
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(size=(n, 3)) * 0.3 + np.array([1.0, 0, 0]), axis=0)
    t, _ = fr.unit_tangents(x)
    ref = np.array([np.cross(tt, [0, 0, 1.0]) for tt in t])
    return x, t, ref / np.linalg.norm(ref, axis=1)[:, None]


@pytest.mark.parametrize("seed", range(3))
def test_reference_twist_gradient_and_hessian_with_frames_rebased(seed):
    """m_i with the frames carried in time from the base shape: its gradient is kb/(2|e|), and the Hessian formula
    is its exact second derivative at the base (the solver re-bases the frames on every iterate)."""
    x0, t0, ref0 = _polyline(seed)

    def m_at(flat, i):
        x = flat.reshape(-1, 3)
        t, _ = fr.unit_tangents(x)
        return fr.reference_twist(fr.transport_frames(ref0, t0, t), t, i)

    for i in (1, 2):
        g6, h6 = el.twist_vertex(x0[i] - x0[i - 1], x0[i + 1] - x0[i])
        full = np.zeros(x0.size)
        full[3 * (i - 1):3 * (i - 1) + 9] = el.edges_to_vertices_grad(g6)
        np.testing.assert_allclose(fd_gradient(lambda z: m_at(z, i), x0.ravel()), full, atol=1e-8)
        hess_fd = np.stack([fd_gradient(lambda q: fd_gradient(lambda r: m_at(r, i), q)[a], x0.ravel(), 1e-4)
                            for a in range(x0.size)])
        block = hess_fd[3 * (i - 1):3 * (i - 1) + 9, 3 * (i - 1):3 * (i - 1) + 9]
        np.testing.assert_allclose(el.edges_to_vertices_hess(h6), block, atol=1e-5)


def test_assembled_gradient_and_band_match_the_energy():
    """The whole incremental potential (stretch, bend, twist span, gravity, inertia, drag) against differences."""
    n = 8
    x, t, ref = _polyline(5, n + 1)
    rest = np.full(n, 0.9)
    vor = np.full(n + 1, 0.9)
    mass = np.full(n + 1, 0.3)
    spans = np.array([[0, n - 1]], dtype=np.int64)
    dirs = np.array([[ref[0], ref[-1]]])
    span_len = np.array([(n - 1) * 0.9])
    g = np.array([0, 0, -9.81])
    x_hat, x0 = x + 0.01, x - 0.02
    none = (0.0, np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((0, 3)),
            np.zeros((n, 0), np.bool_), 1e-3, 1.0, np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3)), np.zeros(0),
            np.zeros((0, 3)), 0.5, 1e-4, False)
    args = (rest, vor, mass, 1400.0, 0.3, 0.2, g, 400.0, 100.0, x_hat, x0, spans, dirs, span_len)
    energy, grad, band, tau, twist_dirs, _ = assemble(x, ref, *args, True, none)

    def e_of(flat):
        return total_energy(flat.reshape(-1, 3), ref, t, x_hat, x0, rest, vor, mass, 1400.0, 0.3, 0.2, g, 400.0,
                            100.0, spans, dirs, span_len, none)

    assert e_of(x.ravel()) == pytest.approx(energy, rel=1e-12)
    np.testing.assert_allclose(grad.ravel(), fd_gradient(e_of, x.ravel()), rtol=1e-6, atol=1e-6)
    full = np.zeros((x.size, x.size))
    for d in range(band.shape[0]):
        for c in range(x.size - d):
            full[c + d, c] = full[c, c + d] = band[d, c]
    full += 0.2 / span_len[0] * np.outer(twist_dirs[0].ravel(), twist_dirs[0].ravel())
    hess_fd = np.stack([fd_gradient(lambda z: fd_gradient(e_of, z, 1e-5)[a], x.ravel(), 1e-4) for a in range(x.size)])
    np.testing.assert_allclose(full, hess_fd, atol=2e-3 * np.abs(hess_fd).max())
