"""The rod engine's SegmentState against closed forms: an arc's bend in a known material frame, uniform twist,
axial strain, contact on a plane at rest and dragged; the same fields as MuJoCo's reader on the default station."""

import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.segment_state import SegmentState
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.rod.model import RodModel
from dresspack_gym.rod.rod import Rod
from dresspack_gym.rod.scene import PLANE, ContactSettings, Primitives
from dresspack_gym.rod.segments import material_directors, segment_state
from dresspack_gym.rod.simulator import RodSimulator
from dresspack_gym.stations.station import Station

G = 9.81
RESOLUTIONS = [12, 24, 48]
Z = np.array([0.0, 0.0, 1.0])


def arc(segments, radius, *, spans=(), held=None):
    """A rod on a counter-clockwise half circle of ``radius`` in the xy plane, reference directors along +z (the
    binormal), weightless; (rod, the turn angle per edge)."""
    phi = np.linspace(0.0, np.pi, segments + 1)
    pts = radius * np.stack([np.cos(phi), np.sin(phi), 0 * phi], axis=1)
    length = segments * 2 * radius * np.sin(phi[1] / 2)  # the chords: every edge at rest length
    held = (0, segments) if held is None else held
    model = RodModel(length, segments, 1.0, 1e4, 0.1, 0.1, held=held, spans=spans, gravity=(0.0, 0.0, 0.0))
    return model, pts, phi[1]


def outward(pts):
    """Each edge's outward radial direction (at its midpoint) of an arc about the origin."""
    mid = 0.5 * (pts[1:] + pts[:-1])
    return mid / np.linalg.norm(mid, axis=1, keepdims=True)


@pytest.mark.parametrize("segments", RESOLUTIONS)
def test_arc_bends_by_one_over_r_along_the_known_material_direction(segments):
    radius = 0.3
    model, pts, _ = arc(segments, radius)
    # directors along the binormal: the bend is all on d1; radial outward directors: all on d2 = t x d1 = -z
    for frames, expected in [(np.tile(Z, (segments, 1)), [1.0, 0.0]), (outward(pts), [0.0, -1.0])]:
        s = segment_state(Rod(model, pts, frames=frames), None, None)
        np.testing.assert_allclose(s.curvature[1:-1], 1 / radius, rtol=1e-12)
        assert s.curvature[0] == s.curvature[-1] == 0.0
        np.testing.assert_allclose(np.linalg.norm(s.bend, axis=1), s.curvature, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(s.bend[1:-1], np.tile(expected, (segments - 1, 1)) / radius, atol=1e-9)
        assert not s.twist_rate.any() and not s.normal_force.any() and not s.slip_speed.any()


@pytest.mark.parametrize("segments", RESOLUTIONS)
@pytest.mark.parametrize("alpha", [0.8, -2.5])
def test_twisted_arc_material_frame_turns_linearly_between_the_clamps(segments, alpha):
    """Clamps on the first and last edge, the far one turned by alpha about its edge: the material angle grows
    linearly along the span (the twist is uniform), so at vertex i the bend lies at the mean of its edges' angles,
    theta_i = alpha (i - 1/2) / (n - 1), seen through the projection onto the vertex's normal plane (which shrinks
    the in-plane component by cos(delta/2), delta the turn per edge: theta_i + O(delta^2))."""
    radius = 0.3
    n = segments
    model, pts, delta = arc(n, radius, spans=((0, n - 1),), held=(0, 1, n - 1, n))
    radial = outward(pts)
    far = np.cos(alpha) * Z + np.sin(alpha) * radial[-1]  # turned about t_(n-1): t x z = the outward radial
    rod = Rod(model, pts, frames=np.tile(Z, (n, 1)), clamp_directors=np.array([[Z, far]]))
    s = segment_state(rod, None, None)
    span = (n - 1) * model.segment_length
    assert rod.twists()[0] == pytest.approx(alpha, abs=1e-12)
    np.testing.assert_allclose(s.twist_rate[1:n], alpha / span, rtol=1e-12)
    assert s.twist_rate[0] == s.twist_rate[n] == 0.0
    theta = alpha * (np.arange(1, n) - 0.5) / (n - 1)
    seen = np.arctan2(np.cos(delta / 2) * np.sin(theta), np.cos(theta))
    assert np.abs(seen - theta).max() <= delta ** 2
    # kb = +z: bend = kappa (z.d1, z.d2) with d1 = cos z + sin r, d2 = t x d1 = cos r - sin z
    np.testing.assert_allclose(s.bend[1:-1], np.stack([np.cos(seen), -np.sin(seen)], axis=1) / radius, atol=1e-9)
    m1 = material_directors(rod)
    np.testing.assert_allclose(m1[[0, -1]], [Z, far], atol=1e-12)  # the clamps hold the frame


@pytest.mark.parametrize("segments", RESOLUTIONS)
@pytest.mark.parametrize("angle", [0.5, -2.0])
def test_uniform_twist_between_clamps_none_on_the_free_ends(segments, angle):
    """Clamps on edges 2 and n-3 of a straight rod, the far one turned by ``angle``: rate angle/L on the span's
    vertices 3..n-3, 0 on the free ends, whose material frames are twist-free continuations of their clamp's."""
    n, length = segments, 1.0
    ea, eb = 2, n - 3
    model = RodModel(length, n, 1.25, 1400.0, 0.1, 0.1, held=(ea, ea + 1, eb, eb + 1), spans=((ea, eb),),
                     gravity=(0.0, 0.0, 0.0))
    pts = np.zeros((n + 1, 3))
    pts[:, 0] = np.linspace(0, length, n + 1)
    near, far = np.array([0.0, 1.0, 0.0]), np.array([0.0, np.cos(angle), np.sin(angle)])
    rod = Rod(model, pts, frames=np.tile(near, (n, 1)), clamp_directors=np.array([[near, far]]))
    s = segment_state(rod, None, None)
    expected = np.zeros(n + 1)
    expected[ea + 1:eb + 1] = angle / ((eb - ea) * model.segment_length)
    np.testing.assert_allclose(s.twist_rate, expected, rtol=1e-12, atol=0.0)
    m1 = material_directors(rod)
    np.testing.assert_allclose(m1[:ea + 1], np.tile(near, (ea + 1, 1)), atol=1e-12)
    np.testing.assert_allclose(m1[eb:], np.tile(far, (n - eb, 1)), atol=1e-12)
    turned = np.arctan2(m1[:, 2], m1[:, 1])[ea:eb + 1]
    np.testing.assert_allclose(np.diff(turned), angle / (eb - ea), atol=1e-12)  # linear in arc length
    assert not s.curvature.any() and not s.bend.any()


@pytest.mark.parametrize("segments", RESOLUTIONS)
def test_stretched_rod_strain_everywhere_clamp_edges_as_mujoco(segments):
    ea, length, eps = 1400.0, 1.0, 0.01
    n = segments
    pts = np.zeros((n + 1, 3))
    pts[:, 0] = np.linspace(0, length, n + 1)
    pinned = Rod(RodModel(length, n, 1.25, ea, 0.1, 0.1, held=(0, n), gravity=(0.0, 0.0, 0.0)), pts)
    assert pinned.solve_rest(held_pos=[[0, 0, 0], [length * (1 + eps), 0, 0]], tolerance=1e-8).converged
    np.testing.assert_allclose(segment_state(pinned, None, None).strain, eps, rtol=1e-9)
    # clamped ends: a clamp's own edge (both vertices held) counts 0, as MuJoCo's reader fills its rigid edges
    h = length / n * (1 + eps)
    clamped = Rod(RodModel(length, n, 1.25, ea, 0.1, 0.1, held=(0, 1, n - 1, n), gravity=(0.0, 0.0, 0.0)), pts)
    held = np.array([[0.0, 0, 0], [h, 0, 0], [(n - 1) * h, 0, 0], [n * h, 0, 0]])
    assert clamped.solve_rest(held_pos=held, tolerance=1e-8).converged
    expected = np.full(n + 1, eps)
    expected[[0, -1]] = 0.0
    expected[[1, -2]] = eps / 2
    np.testing.assert_allclose(segment_state(clamped, None, None).strain, expected, rtol=1e-9, atol=1e-15)


def leaning_cantilever(segments, *, length=0.5, rho=0.5, radius=0.01, slope=np.radians(30)):
    """A stiff cable clamped at its top end, pointing down at ``slope`` onto the floor (z = 0), at rest on it by
    its tip (a point contact: a cable lying flat on a plane is a non-smooth contact the rest solve does not
    settle, see the report); (rod, floor)."""
    n = segments
    contact = ContactSettings()
    model = RodModel(length, n, rho, 1e4, 1.0, 1.0, held=(0, 1))
    way = np.array([np.cos(slope), 0.0, -np.sin(slope)])
    top = np.array([0.0, 0.0, radius + 0.8 * contact.activation + length * np.sin(slope)])
    rod = Rod(model, top + np.linspace(0, length, n + 1)[:, None] * way, radius=radius, contact=contact)
    floor = Primitives(np.array([PLANE]), np.zeros((1, 3)), np.eye(3)[None], np.zeros((1, 3)), np.ones((n, 1), bool))
    assert rod.solve_rest(primitives=floor, tolerance=1e-6).converged
    return rod, floor


@pytest.mark.parametrize("segments", RESOLUTIONS)
def test_cable_resting_on_a_plane_carries_its_supported_weight_without_friction(segments):
    rod, _ = leaning_cantilever(segments)
    s = segment_state(rod, None, None)
    weight = rod.model.masses.sum() * G
    supported = weight + rod.static_forces()[list(rod.model.held), 2].sum()  # what the clamp does not carry
    assert 0.2 * weight < supported < weight
    assert s.normal_force.sum() == pytest.approx(supported, rel=1e-2)
    assert np.flatnonzero(s.normal_force).tolist() == [segments]  # the tip alone touches
    assert not s.friction_force.any() and not s.slip_speed.any()
    # a step that did not move: friction lagged from the same shape is zero, and so is sliding
    still = segment_state(rod, rod.x.copy(), 0.02)
    assert not still.friction_force.any() and not still.slip_speed.any()


@pytest.mark.parametrize("segments", RESOLUTIONS)
def test_cable_dragged_along_a_plane_slides_at_the_drag_speed_with_coulomb_friction(segments):
    rod, floor = leaning_cantilever(segments)
    speed, h = 0.1, 0.02
    held = rod.x[list(rod.model.held)].copy()
    for _ in range(20):  # the clamp drags the tip behind it until it slides steadily
        previous = rod.x.copy()
        held = held - [speed * h, 0.0, 0.0]
        assert rod.step(held, h, tolerance=1e-6).converged
    s = segment_state(rod, previous, h)
    tip = segments
    assert np.flatnonzero(s.slip_speed).tolist() == [tip]
    assert s.slip_speed[tip] == pytest.approx(speed, rel=1e-3)
    assert s.friction_force[tip] == pytest.approx(rod.contact.friction * s.normal_force[tip], rel=1e-3)
    np.testing.assert_allclose(s.friction_power, s.friction_force * s.slip_speed)
    # without a step length friction is still known, sliding speed is not
    assert not segment_state(rod, previous, None).slip_speed.any()
    # a floor that moved with the tip: no relative sliding, no friction
    carried = Primitives(floor.kind, floor.pos + [speed * h, 0.0, 0.0], floor.rot, floor.size, floor.mask)
    riding = segment_state(rod, previous, h, previous_primitives=carried)
    assert riding.slip_speed[tip] < 1e-3 * speed and riding.friction_force[tip] < 1e-3 * s.friction_force[tip]


def test_same_fields_as_mujocos_reader_on_the_default_station():
    """The same dataclass, shapes and dtypes as CableSimulator.segment_states() for the station's cable; at Home
    (both at rest, installed untwisted) the same values within the two engines' 3 % agreement."""
    station = Station(load_station("default"))
    reference = CableSimulator(station).segment_states()
    fast = RodSimulator(station)
    states = [segment_state(rod, None, None) for rod in fast.rods]
    assert len(states) == len(reference)
    for mine, theirs in zip(states, reference):
        assert isinstance(mine, SegmentState)
        for field in SegmentState.__dataclass_fields__:
            a, b = getattr(mine, field), getattr(theirs, field)
            assert (a.shape, a.dtype) == (b.shape, b.dtype), field
            assert np.isfinite(a).all(), field
        for field in ("curvature", "bend", "strain"):
            a, b = getattr(mine, field), getattr(theirs, field)
            np.testing.assert_allclose(a, b, atol=0.03 * np.abs(b).max(), err_msg=field)
        assert np.abs(mine.twist_rate).max() < 1e-6 and np.abs(theirs.twist_rate).max() < 1e-6
