"""Point- and segment-primitive distances: analytic values, finite differences, ipctk and dense sampling."""

import ipctk
import numpy as np
import pytest
from contact_shapes import SIZES, rotation

from dresspack_gym.rod.contact.primitives import BOX, CAPSULE, CYLINDER, PLANE, SPHERE, point_distance
from dresspack_gym.rod.contact.segment import segment_gap
from dresspack_gym.rod.contact.warm import compile_kernels

compile_kernels()  # one worker compiles, the others load numba's cache


def prim(kind, rng):
    return kind, rng.normal(size=3), rotation(rng), np.array(SIZES[kind], float)


def dist(kind, pos, rot, size, p):
    n, h = np.empty(3), np.empty((3, 3))
    d = point_distance(kind, pos, rot, size, np.ascontiguousarray(p, dtype=float), n, h)
    return d, n, h


def local_sdf(kind, size, q):
    """An independent numpy signed distance (vectorised over rows of q, local frame)."""
    if kind == PLANE:
        return q[:, 2]
    if kind == SPHERE:
        return np.linalg.norm(q, axis=1) - size[0]
    if kind == CAPSULE:
        z = np.clip(q[:, 2], -size[1], size[1])
        return np.hypot(np.hypot(q[:, 0], q[:, 1]), q[:, 2] - z) - size[0]
    if kind == BOX:
        e = np.abs(q) - size
        return np.linalg.norm(np.maximum(e, 0.0), axis=1) + np.minimum(e.max(axis=1), 0.0)
    e = np.stack([np.hypot(q[:, 0], q[:, 1]) - size[0], np.abs(q[:, 2]) - size[1]], axis=1)
    return np.linalg.norm(np.maximum(e, 0.0), axis=1) + np.minimum(e.max(axis=1), 0.0)


# (kind, local point, expected signed distance, expected local normal)
ANALYTIC = [
    (PLANE, (0.3, -2.0, 0.7), 0.7, (0, 0, 1)),
    (PLANE, (0.3, -2.0, -0.2), -0.2, (0, 0, 1)),
    (SPHERE, (0.0, 0.6, 0.8), 0.7, (0, 0.6, 0.8)),
    (SPHERE, (0.1, 0.0, 0.0), -0.2, (1, 0, 0)),
    (CAPSULE, (0.5, 0.0, 0.3), 0.3, (1, 0, 0)),  # side
    (CAPSULE, (0.0, 0.3, 0.9), 0.3, (0, 0.6, 0.8)),  # cap sphere
    (CAPSULE, (0.0, 0.0, 0.6), -0.1, (0, 0, 1)),  # inside the cap
    (BOX, (0.9, 0.0, 0.1), 0.5, (1, 0, 0)),  # face
    (BOX, (0.7, 0.5, 0.0), 0.5, (0.6, 0.8, 0)),  # edge
    (BOX, (0.6, 0.3, 0.45), np.sqrt(0.12), np.array((0.2, 0.2, 0.2)) / np.sqrt(0.12)),  # corner
    (BOX, (0.1, -0.05, 0.0), -0.05, (0, -1, 0)),  # inside, nearest face -y
    (CYLINDER, (0.0, 0.5, 0.1), 0.2, (0, 1, 0)),  # side
    (CYLINDER, (0.1, 0.1, -0.7), 0.3, (0, 0, -1)),  # cap
    (CYLINDER, (0.6, 0.0, 0.8), 0.5, (0.6, 0, 0.8)),  # rim
    (CYLINDER, (0.0, 0.25, 0.0), -0.05, (0, 1, 0)),  # inside, nearest the side
    (CYLINDER, (0.0, 0.0, 0.35), -0.05, (0, 0, 1)),  # inside, nearest the cap
]


@pytest.mark.parametrize("kind, q, expected, normal", ANALYTIC)
def test_point_distance_analytic(kind, q, expected, normal):
    rng = np.random.default_rng(kind)
    _, pos, rot, size = prim(kind, rng)
    d, n, _ = dist(kind, pos, rot, size, pos + rot @ np.array(q))
    assert d == pytest.approx(expected, abs=1e-12)
    np.testing.assert_allclose(n, rot @ np.array(normal, float), atol=1e-12)


@pytest.mark.parametrize("kind", [PLANE, SPHERE, CAPSULE, BOX, CYLINDER])
def test_point_distance_derivatives(kind):
    rng = np.random.default_rng(10 + kind)
    _, pos, rot, size = prim(kind, rng)
    step = 1e-6
    checked = 0
    while checked < 20:
        p = pos + rng.normal(scale=0.8, size=3)
        d, n, h = dist(kind, pos, rot, size, p)
        if d <= 0.02:
            continue
        fd_g = np.empty(3)
        fd_h = np.empty((3, 3))
        for a in range(3):
            e = np.zeros(3)
            e[a] = step
            dp, np_, _ = dist(kind, pos, rot, size, p + e)
            dm, nm, _ = dist(kind, pos, rot, size, p - e)
            fd_g[a] = (dp - dm) / (2 * step)
            fd_h[:, a] = (np_ - nm) / (2 * step)
        np.testing.assert_allclose(n, fd_g, atol=1e-7)
        np.testing.assert_allclose(h, fd_h, atol=2e-5 * max(1.0, np.abs(h).max()))
        np.testing.assert_allclose(h, h.T, atol=1e-12)
        assert local_sdf(kind, size, (rot.T @ (p - pos))[None])[0] == pytest.approx(d, abs=1e-12)
        checked += 1


def random_segment(rng, pos, spread=1.2, length=1.0):
    a = pos + rng.normal(scale=spread, size=3)
    return a, a + rng.normal(scale=length, size=3)


def gap(a, b, r, kind, pos, rot, size):
    p, n, h = np.empty(3), np.empty(3), np.empty((3, 3))
    return segment_gap(a, b, r, kind, pos, rot, size, p, n, h)


def test_segment_capsule_and_sphere_against_ipctk():
    rng = np.random.default_rng(3)
    r = 0.02
    for _ in range(200):
        _, pos, rot, size = prim(CAPSULE, rng)
        a, b = random_segment(rng, pos)
        axis = rot[:, 2] * size[1]
        expected = np.sqrt(ipctk.edge_edge_distance(a, b, pos - axis, pos + axis)) - size[0] - r
        assert gap(a, b, r, CAPSULE, pos, rot, size)[0] == pytest.approx(expected, abs=1e-10)
        _, pos, rot, size = prim(SPHERE, rng)
        expected = np.sqrt(ipctk.point_edge_distance(pos, a, b)) - size[0] - r
        assert gap(a, b, r, SPHERE, pos, rot, size)[0] == pytest.approx(expected, abs=1e-10)


def test_segment_parallel_to_capsule_axis():
    rot = np.eye(3)
    pos, size = np.zeros(3), np.array([0.1, 0.5, 0.0])
    a, b = np.array([0.3, 0.0, -0.2]), np.array([0.3, 0.0, 0.4])
    d, t = gap(a, b, 0.01, CAPSULE, pos, rot, size)
    assert d == pytest.approx(0.19, abs=1e-12) and 0.0 <= t <= 1.0


def test_segment_plane_against_ipctk():
    rng = np.random.default_rng(4)
    for _ in range(100):
        _, pos, rot, size = prim(PLANE, rng)
        a, b = random_segment(rng, pos)
        normal = rot[:, 2]
        heights = [np.sign((v - pos) @ normal) * np.sqrt(ipctk.point_plane_distance(v, pos, normal)) for v in (a, b)]
        assert gap(a, b, 0.01, PLANE, pos, rot, size)[0] == pytest.approx(min(heights) - 0.01, abs=1e-12)


@pytest.mark.parametrize("kind", [BOX, CYLINDER, SPHERE, CAPSULE])
def test_segment_against_dense_sampling(kind):
    rng = np.random.default_rng(20 + kind)
    samples = np.linspace(0.0, 1.0, 4001)
    for _ in range(60):
        _, pos, rot, size = prim(kind, rng)
        a, b = random_segment(rng, pos, spread=0.7)
        pts = (1 - samples)[:, None] * a + samples[:, None] * b
        sampled = local_sdf(kind, size, (pts - pos) @ rot)
        d, t = gap(a, b, 0.0, kind, pos, rot, size)
        slack = np.linalg.norm(b - a) / (len(samples) - 1)  # the sampled minimum is at most this far above the true
        assert sampled.min() - slack - 1e-12 <= d <= sampled.min() + 1e-12
        p = (1 - t) * a + t * b
        assert local_sdf(kind, size, ((p - pos) @ rot)[None])[0] == pytest.approx(d, abs=1e-12)
