"""What the cable exerts on its holders: a twisted rod's clamp torque GJ theta / L, a cantilever's weight and moment."""

import numpy as np
import pytest

from dresspack_gym.rod.loads import holder_loads
from dresspack_gym.rod.model import RodModel
from dresspack_gym.rod.rod import Rod

G = 9.81


def straight(segments, length=1.0):
    pts = np.zeros((segments + 1, 3))
    pts[:, 0] = np.linspace(0.0, length, segments + 1)
    return pts


def clamps_members(segments, near=(0, 1), far=None):
    rows = [near] + ([far] if far else [])
    members = np.zeros((len(rows), segments + 1))
    for r, verts in enumerate(rows):
        members[r, list(verts)] = 1.0
    return members


@pytest.mark.parametrize("segments", [8, 24, 48])
@pytest.mark.parametrize("angle", [0.7, -2.0])
def test_twisted_rod_clamps_carry_gj_theta_over_l(segments, angle):
    gj, length = 0.1, 1.0
    model = RodModel(length, segments, 1.25, 1400.0, 0.1, gj, held=(0, 1, segments - 1, segments),
                     spans=((0, segments - 1),), gravity=(0.0, 0.0, 0.0))
    rod = Rod(model, straight(segments), clamp_directors=np.array([[[0, 1.0, 0], [0, np.cos(angle), np.sin(angle)]]]))
    rod.ref[:] = [0.0, 1.0, 0.0]
    assert rod.solve_rest(tolerance=1e-9).converged
    forces, torques = holder_loads(rod, clamps_members(segments, (0, 1), (segments - 1, segments)),
                                   np.array([0, segments]))
    expected = gj * angle / model.span_lengths[0]
    np.testing.assert_allclose(forces, 0.0, atol=1e-9)
    np.testing.assert_allclose(torques[0], [expected, 0, 0], atol=1e-9)  # turned along +tau at the near clamp
    np.testing.assert_allclose(torques[1], [-expected, 0, 0], atol=1e-9)


@pytest.mark.parametrize("segments", [12, 24, 48])
def test_cantilever_clamp_carries_its_weight_and_moment(segments):
    """A stiff horizontal cantilever: the clamp carries the whole weight and its moment about the clamp point."""
    length, rho = 1.0, 0.5
    model = RodModel(length, segments, rho, 1e6, 50.0, 1.0, held=(0, 1))
    rod = Rod(model, straight(segments, length))
    assert rod.solve_rest(tolerance=1e-6).converged
    forces, torques = holder_loads(rod, clamps_members(segments), np.array([0]))
    weight = rho * length * G
    np.testing.assert_allclose(forces[0], [0.0, 0.0, -weight], rtol=1e-6, atol=1e-9)  # the cable pulls it down
    moment = G * (model.masses * rod.x[:, 0]).sum()  # about the clamp point, the cable's weight times its arm
    assert torques[0][1] == pytest.approx(moment, rel=0.01)  # (x forward, z up) x (-z) = +y
    assert abs(torques[0][0]) < 1e-9 and abs(torques[0][2]) < 1e-9
