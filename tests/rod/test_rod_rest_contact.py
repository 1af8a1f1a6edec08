"""Rest with contact: a cable lying flat on the floor or on a box settles to a converged equilibrium and stays."""

import numpy as np
import pytest

from dresspack_gym.rod.contact.report import contact_report
from dresspack_gym.rod.model import RodModel
from dresspack_gym.rod.rod import Rod
from dresspack_gym.rod.scene import BOX, PLANE, ContactSettings, Primitives

RADIUS = 0.02


def lying(segments, kind):
    """A cable held at both ends just above a floor (plane) or a wide box's top face, its middle free to sag."""
    model = RodModel(1.0, segments, 1.25, 1400.0, 0.1, 0.1, held=(0, segments))
    s = np.linspace(0.0, 1.0, segments + 1)
    top = 0.3 if kind == BOX else 0.0
    pts = np.stack([s * 0.98, 0 * s, top + RADIUS + 0.01 + 0.0 * s], axis=1)
    size = [[2.0, 2.0, 0.3]] if kind == BOX else [[0.0, 0.0, 0.0]]
    prims = Primitives(np.array([kind]), np.array([[0.5, 0.0, 0.0]]), np.eye(3)[None].copy(), np.array(size, float),
                       np.ones((segments, 1), dtype=np.bool_))
    return Rod(model, pts, radius=RADIUS, contact=ContactSettings()), prims, top


@pytest.mark.parametrize("segments", [12, 24, 48])
@pytest.mark.parametrize("kind", [PLANE, BOX])
def test_a_cable_lying_flat_settles_and_stays(segments, kind):
    rod, prims, top = lying(segments, kind)
    result = rod.solve_rest(tolerance=1e-4, primitives=prims)
    assert result.converged, result
    c = rod.contact
    normal, _, gaps, _ = contact_report(rod.x, rod.x, RADIUS, prims.kind, prims.pos, prims.rot, prims.size, prims.pos,
                                        prims.rot, prims.mask, c.activation, c.stiffness, c.friction, c.slip)
    middle = slice(segments // 4, -segments // 4)  # the ends rise to the holders, the middle lies on the surface
    assert gaps.min() > 0.0 and (gaps[middle] < c.activation).all()  # lying on it, not in it
    supported = normal.sum()
    held = -rod.static_forces()[[0, -1], 2].sum()  # what the two holders carry upward
    assert supported + held == pytest.approx(rod.model.masses.sum() * 9.81, rel=1e-3)
    settled = rod.x.copy()
    for _ in range(10):
        assert rod.step(rod.x[[0, -1]], 0.05, tolerance=1e-4, primitives=prims).converged
    assert np.abs(rod.x - settled).max() < 1e-6  # rest is rest on the floor too
