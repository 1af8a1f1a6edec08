"""Contact forces per vertex and clearances per edge; the displacement bound of moving primitives."""

import numpy as np
import pytest

from dresspack_gym.rod.contact.barrier import barrier_accumulate, barrier_d1
from dresspack_gym.rod.contact.motion import pose_displacement, pose_displacements, rotation_angle
from dresspack_gym.rod.contact.primitives import BOX, PLANE, SPHERE, bounding_radii
from dresspack_gym.rod.contact.report import contact_report
from dresspack_gym.rod.contact.warm import compile_kernels

R, DHAT, KAPPA, MU, EPS = 0.01, 0.05, 100.0, 0.3, 1e-4

compile_kernels()  # one worker compiles, the others load numba's cache


def scene():
    kind = np.array([PLANE, SPHERE, BOX], np.int64)
    pos = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.2], [5.0, 0.0, 0.5]])
    rot = np.repeat(np.eye(3)[None], 3, axis=0)
    size = np.array([[0, 0, 0], [0.1, 0, 0], [0.5, 0.5, 0.5]], float)
    return kind, pos, rot, size


def report(x, x_prev, mask=None, cap=10.0):
    kind, pos, rot, size = scene()
    mask = np.ones((len(x) - 1, 3), bool) if mask is None else mask
    return contact_report(x, x_prev, R, kind, pos, rot, size, pos, rot, mask, DHAT, KAPPA, MU, EPS, cap)


def pushing(d):
    return -KAPPA * barrier_d1(d, DHAT) if d < DHAT else 0.0


def test_normal_force_goes_to_the_vertices_by_the_contact_parameter():
    floor_edge = np.array([[1.0, 0.0, 0.03], [1.2, 0.0, 0.04]])  # a plane: a contact at each end, half weight each
    ball_edge = np.array([[-0.1, 0.0, 0.32], [0.1, 0.0, 0.32]])  # touches the ball at its middle
    floor_force = [0.5 * pushing(0.03 - R), 0.5 * pushing(0.04 - R)]
    ball_force = [0.5 * pushing(0.02 - R), 0.5 * pushing(0.02 - R)]
    for x, force, clear in [(floor_edge, floor_force, 0.03 - R), (ball_edge, ball_force, 0.02 - R)]:
        normal, fric, gap, nearest = report(x, x)
        np.testing.assert_allclose(normal, force, rtol=1e-12)
        assert not fric.any()  # nothing moved
        assert gap[0] == pytest.approx(clear, rel=1e-12) and nearest[0] == (0 if x is floor_edge else 1)
        g = np.zeros_like(x)
        barrier_accumulate(x, R, *scene(), np.ones((1, 3), bool), DHAT, KAPPA, g, np.zeros((6, 6)), True)
        np.testing.assert_allclose(np.linalg.norm(g, axis=1), normal, rtol=1e-12)  # one pair per vertex here


def test_friction_force_of_a_sliding_edge():
    x_prev = np.array([[1.0, 0.0, 0.03], [1.2, 0.0, 0.04]])
    x = x_prev + [0.01, 0.0, 0.0]
    normal, fric, _, _ = report(x, x_prev)
    lam = [0.5 * pushing(0.03 - R), 0.5 * pushing(0.04 - R)]  # each end's share of the plane contact
    np.testing.assert_allclose(fric, MU * np.array(lam), rtol=1e-12)
    np.testing.assert_allclose(normal, lam, rtol=1e-12)


def test_masked_and_far_primitives():
    x = np.array([[100.0, 0.0, 0.5], [100.2, 0.0, 0.5]])
    _, _, gap, nearest = report(x, x)
    assert gap[0] == pytest.approx(0.5 - R) and nearest[0] == 0
    _, _, gap, nearest = report(x, x, mask=np.array([[False, True, True]]))
    assert gap[0] == 10.0 and nearest[0] == -1  # the floor disabled, the rest beyond the cap
    x = np.array([[5.0, 0.0, 1.3], [5.1, 0.0, 1.3]])
    _, _, gap, nearest = report(x, x, mask=np.array([[True, True, False]]))
    assert nearest[0] == 0  # the box (nearer) is disabled, the floor is next
    assert gap[0] == pytest.approx(1.3 - R)


def rot_axis(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def test_rotation_angle_is_accurate_near_zero_and_pi():
    for angle in [0.0, 1e-9, 1e-4, 0.5, 3.0, np.pi - 1e-7, np.pi]:
        base = rot_axis([0.3, -1.0, 0.2], 0.7)
        assert rotation_angle(base, base @ rot_axis([1.0, 2.0, 3.0], angle)) == pytest.approx(angle, abs=1e-12)


def test_pose_displacement_bounds_every_point_of_the_primitive():
    rng = np.random.default_rng(5)
    for _ in range(50):
        pos_prev, pos = rng.normal(size=3), rng.normal(size=3)
        rot_prev = rot_axis(rng.normal(size=3), rng.uniform(0, np.pi))
        rot = rot_prev @ rot_axis(rng.normal(size=3), rng.uniform(0, 1.0))
        radius = rng.uniform(0.1, 2.0)
        bound = pose_displacement(pos_prev, rot_prev, pos, rot, radius)
        local = rng.normal(size=(200, 3))
        local *= radius * rng.uniform(0, 1, size=(200, 1)) / np.linalg.norm(local, axis=1, keepdims=True)
        moved = np.linalg.norm((pos + local @ rot.T) - (pos_prev + local @ rot_prev.T), axis=1)
        assert moved.max() <= bound + 1e-12
    assert pose_displacement(np.zeros(3), np.eye(3), np.array([0.3, 0.4, 0.0]), np.eye(3), 2.0) == pytest.approx(0.5)
    kind, pos, rot, size = scene()
    turned = np.array([r @ rot_axis([0, 0, 1], 0.1) for r in rot])
    radii = bounding_radii(kind, size)
    np.testing.assert_allclose(pose_displacements(pos, rot, pos, turned, np.where(np.isfinite(radii), radii, 0.0)),
                               [0.0, 0.01, 0.1 * np.sqrt(0.75)], rtol=1e-12)
