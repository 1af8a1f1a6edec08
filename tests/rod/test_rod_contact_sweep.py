"""A link swept through a hanging cable: the cable is pushed aside, never passed through, and every solve converges."""

import numpy as np
import pytest

from dresspack_gym.rod.contact.report import contact_report
from dresspack_gym.rod.model import RodModel
from dresspack_gym.rod.rod import Rod
from dresspack_gym.rod.scene import CAPSULE, ContactSettings, Primitives
from dresspack_gym.rod.station_scene import closing_fraction

RADIUS = 0.02


def capsule_at(y, z, link_radius, n_edges):
    rot = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # local z along world x: a bar along the cable
    return Primitives(np.array([CAPSULE]), np.array([[0.8, y, z]]), rot[None].copy(),
                      np.array([[link_radius, 0.6, 0.0]]), np.ones((n_edges, 1), dtype=np.bool_))


@pytest.mark.parametrize("speed, link_radius, height", [
    (0.5, 0.05, -0.3), (2.0, 0.1, -0.4),
    # a thin bar at 4 m/s: one sub-step's Newton solve stalls at 1.15e-3 of a vertex's weight (tolerance 1e-3)
    pytest.param(4.0, 0.03, -0.2, marks=pytest.mark.xfail(strict=True, reason="Newton stalls just above tolerance "
                                                                              "on a fast thin bar")),
])
def test_swept_link_pushes_the_cable_without_passing_through(speed, link_radius, height):
    n = 24
    model = RodModel(2.0, n, 1.25, 1400.0, 0.1, 0.1, held=(0, n))
    s = np.linspace(0, 1, n + 1)
    rod = Rod(model, np.stack([1.6 * s, 0 * s, -0.6 * 4 * s * (1 - s)], axis=1), radius=RADIUS,
              contact=ContactSettings())
    start = capsule_at(-0.5, height, link_radius, n)
    assert rod.solve_rest(tolerance=1e-6, primitives=start).converged
    h = 0.02
    prims = start
    pushed = 0.0
    substeps = 0
    bound = np.array([link_radius + 0.6])
    for k in range(1, int(1.0 / speed / h) + 1):  # the bar travels 1 m across the cable's plane
        end = capsule_at(-0.5 + speed * h * k, height, link_radius, n)
        done = 0.0
        while done < 1.0:
            step = (1.0 - done) * closing_fraction(rod.x, RADIUS, prims, end, bound)
            assert step > 0.0
            done = 1.0 if done + step >= 1.0 - 1e-12 else done + step
            prims = capsule_at(-0.5 + speed * h * (k - 1 + done), height, link_radius, n)
            result = rod.step(rod.x[[0, n]], h * step, tolerance=1e-3, primitives=prims)
            substeps += 1
            assert result.converged, (k, done, result)
            c = ContactSettings()
            _, _, gaps, _ = contact_report(rod.x, rod.x, RADIUS, prims.kind, prims.pos, prims.rot, prims.size,
                                           prims.pos, prims.rot, prims.mask, c.activation, c.stiffness, c.friction,
                                           c.slip)
            assert gaps.min() > 0.0  # penetration 0 by construction
        pushed = max(pushed, rod.x[:, 1].max())
    print(f"sub-steps {substeps}")
    assert pushed > 0.1  # the bar did carry the cable along
    assert np.isfinite(rod.tensions()).all() and np.abs(rod.tensions()).max() < 2e3  # bounded forces


def test_a_still_plane_does_not_stop_the_sub_steps_of_a_moving_link():
    """The floor (a plane, unbounded) stands still while a link closes in: the link alone sets the sub-step."""
    n = 24
    s = np.linspace(0, 1, n + 1)
    x = np.stack([1.6 * s, 0 * s, 0.5 - 0.3 * 4 * s * (1 - s)], axis=1)
    floor = (np.array([0]), np.zeros((1, 3)), np.eye(3)[None], np.zeros((1, 3)))
    bar_now, bar_end = capsule_at(-0.2, 0.2, 0.05, n), capsule_at(0.0, 0.2, 0.05, n)

    def with_floor(bar):
        return Primitives(np.concatenate([floor[0], bar.kind]), np.concatenate([floor[1], bar.pos]),
                          np.concatenate([floor[2], bar.rot]), np.concatenate([floor[3], bar.size]),
                          np.ones((n, 2), dtype=np.bool_))

    fraction = closing_fraction(x, RADIUS, with_floor(bar_now), with_floor(bar_end), np.array([np.inf, 0.65]))
    assert 0.0 < fraction < 1.0
