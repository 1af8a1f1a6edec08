"""The CCD step bound: never through anything (thin boxes, fast steps), and no needless shortening."""

import numpy as np
import pytest
from contact_shapes import rotation

from dresspack_gym.rod.contact.ccd import KEEP, MAX_ITER, max_step
from dresspack_gym.rod.contact.mask import pair_mask
from dresspack_gym.rod.contact.primitives import BOX, CAPSULE, CYLINDER, PLANE, SPHERE
from dresspack_gym.rod.contact.report import contact_report
from dresspack_gym.rod.contact.warm import compile_kernels

R = 0.005

compile_kernels()  # one worker compiles, the others load numba's cache


def scene(rng):
    """Thin boxes, small spheres and capsules, a cylinder and a floor around the origin."""
    kind = np.array([BOX, BOX, BOX, SPHERE, SPHERE, CAPSULE, CAPSULE, CYLINDER, PLANE], np.int64)
    size = np.array([[0.3, 0.3, 1e-3], [0.5, 2e-3, 0.4], [0.05, 0.05, 0.05], [0.02, 0, 0], [0.1, 0, 0],
                     [0.01, 0.3, 0], [0.06, 0.2, 0], [0.08, 0.3, 0], [0, 0, 0]])
    pos = rng.uniform(-0.6, 0.6, size=(len(kind), 3))
    pos[-1] = (0.0, 0.0, -1.5)
    rot = np.array([rotation(rng) for _ in kind])
    rot[-1] = np.eye(3)
    return kind, pos, rot, size


def gaps(x, prims, mask):
    kind, pos, rot, size = prims
    return contact_report(x, x, R, kind, pos, rot, size, pos, rot, mask, 1e-3, 1.0, 0.0, 1e-3, 10.0)[2]


def test_far_primitives_allow_the_full_step():
    rng = np.random.default_rng(0)
    prims = scene(rng)
    x = np.stack([np.linspace(0, 1, 12), np.zeros(12), np.full(12, 20.0)], axis=1)
    dx = rng.normal(scale=0.5, size=x.shape)
    assert max_step(x, dx, R, *prims, pair_mask(11, len(prims[0])), KEEP, MAX_ITER) == 1.0


def test_head_on_steps_stop_near_the_kept_fraction_of_the_gap():
    for kind, size in [(SPHERE, (0.1, 0, 0)), (BOX, (0.2, 0.2, 0.2)), (CYLINDER, (0.1, 0.2, 0)), (PLANE, (0, 0, 0))]:
        prims = (np.array([kind], np.int64), np.zeros((1, 3)), np.eye(3)[None].copy(), np.array([size], float))
        top = 0.0 if kind == PLANE else 0.2 if kind == BOX else 0.2 if kind == CYLINDER else 0.1
        x = np.array([[0.0, 0.0, 0.5], [0.0, 0.0, 0.6]])
        dx = np.tile([0.0, 0.0, -2.0], (2, 1))
        g0 = 0.5 - top - R
        alpha = max_step(x, dx, R, *prims, np.ones((1, 1), bool), KEEP, MAX_ITER)
        assert 0.9 * g0 / 2.0 * 0.99 <= alpha <= 0.9 * g0 / 2.0 + 1e-12  # within the 5 % settling band of 0.1 g0


def test_random_fast_steps_never_pass_through():
    rng = np.random.default_rng(2)
    n_v = 10
    limited = 0
    for case in range(40):
        prims = scene(rng)
        mask = pair_mask(n_v - 1, len(prims[0]))
        while True:  # a feasible start
            x = rng.uniform(-0.8, 0.8, size=3) + np.cumsum(rng.normal(scale=0.04, size=(n_v, 3)), axis=0)
            if gaps(x, prims, mask).min() > 0.0:
                break
        towards = prims[1][rng.integers(len(prims[0]) - 1)] - x.mean(axis=0)
        dx = 3.0 * towards + rng.normal(scale=0.3, size=x.shape)  # through a primitive, fast and distorting
        alpha = max_step(x, dx, R, *prims, mask, KEEP, MAX_ITER)
        assert 0.0 < alpha <= 1.0
        limited += alpha < 1.0
        for s in np.linspace(0.0, alpha, 120):
            assert gaps(x + s * dx, prims, mask).min() > 0.0, (case, s, alpha)
    assert limited > 30


def test_thin_plate_between_the_ends_of_a_step():
    plate = (np.array([BOX], np.int64), np.zeros((1, 3)), np.eye(3)[None].copy(), np.array([[1.0, 1.0, 1e-4]]))
    x = np.array([[0.0, 0.0, 0.2], [0.1, 0.0, 0.2], [0.2, 0.0, 0.2]])
    dx = np.tile([0.0, 0.0, -0.4], (3, 1))  # start and end are both 0.2 from the plate, on either side
    alpha = max_step(x, dx, R, *plate, np.ones((2, 1), bool), KEEP, MAX_ITER)
    assert alpha == pytest.approx(0.9 * (0.2 - 1e-4 - R) / 0.4)
    assert max_step(x, dx, R, *plate, np.zeros((2, 1), bool), KEEP, MAX_ITER) == 1.0  # the pair disabled


def test_an_infeasible_start_gives_zero():
    plate = (np.array([SPHERE], np.int64), np.zeros((1, 3)), np.eye(3)[None].copy(), np.array([[0.1, 0, 0]]))
    x = np.array([[-0.2, 0.0, 0.0], [0.2, 0.0, 0.0]])
    assert max_step(x, np.ones_like(x), R, *plate, np.ones((1, 1), bool), KEEP, MAX_ITER) == 0.0


def test_mask_helper_excludes_clamped_stretches():
    mask = pair_mask(6, 3, [(0, 2, 1), (5, 6, -1)])
    assert mask.sum() == 18 - 2 - 3
    assert not mask[0, 1] and not mask[1, 1] and mask[2, 1] and not mask[5].any()
