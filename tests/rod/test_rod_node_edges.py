"""An edge leaving a node is not pushed by the other links of its own robot (station_scene.pair_mask_of)."""

from dataclasses import replace

import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.rod.contact.barrier import barrier_energy
from dresspack_gym.rod.contact.primitives import point_distance
from dresspack_gym.rod.simulator import RodSimulator
from dresspack_gym.stations.station import Station

# The robustness map's folded wrist that jammed (thesis_24336 row 0's j4 - 100 deg, j5 at its -130 deg limit): the tool
# support (the dresspack's end node on link 6, 0.3 m off the tool axis) lies inside the forearm's (link 4's) capsule.
FOLDED = np.radians([0.0, -65.0, -180.0, -280.0, -130.0, -250.0])


@pytest.fixture(scope="module")
def sim():
    config = load_station("default")
    robots = tuple(replace(r, dresspack=replace(r.dresspack, collide_with_robot=True)) for r in config.robots)
    return RodSimulator(Station(replace(config, robots=robots)))


def _names(sim):
    m = sim.station.model
    return [m.geom(int(g)).name for g in sim.scenes[0].geoms]


def test_only_edges_leaving_a_node_lose_the_other_links_of_their_robot(sim):
    scene, cable = sim.scenes[0], sim.cables[0]
    held = {hp.vertex: hp.link for hp in cable.held}
    own = {int(g): int(k) for g, k in zip(sim.station.robots[0].geom_ids, sim.station.robots[0].geom_links)}
    for e in range(cable.model.segments):
        for j, g in enumerate(scene.geoms):
            ends = [held.get(e), held.get(e + 1)]
            if None not in ends:  # a clamp's own edge: part of its node
                expected = False
            elif ends == [None, None] or int(g) not in own:  # a free edge, or an obstacle / another robot
                expected = True
            else:  # leaving a node: only the node's own link
                expected = own[int(g)] == next(k for k in ends if k is not None)
            assert scene.mask[e, j] == expected, (e, _names(sim)[j])
    # the default dresspack: clamp edges 0 (link 3) and 23 (link 6), edges 1 and 22 leave them
    assert not scene.mask[[0, 23]].any()
    link4 = _names(sim).index("r1/link4_geom4")
    assert not scene.mask[1, link4] and not scene.mask[22, link4] and scene.mask[2:22, link4].all()


def test_the_folded_wrist_puts_the_support_inside_the_forearm_and_the_barrier_stays_finite(sim):
    """Analytic check of the case the rule is for: at FOLDED the held vertices of the tool support lie inside link
    4's capsule (signed distance < 0), so with the edge leaving the support checked against link 4 the barrier
    would be infinite whatever the free vertices did; with the rule the energy of a cable whose free vertices keep
    clear of every link is finite (and zero beyond the activation)."""
    scene, cable = sim.scenes[0], sim.cables[0]
    prims = scene.at(FOLDED[None])
    pos, _ = scene.targets()
    link4 = _names(sim).index("r1/link4_geom4")
    n, h = np.empty(3), np.empty((3, 3))
    gaps = [point_distance(prims.kind[link4], prims.pos[link4], prims.rot[link4], prims.size[link4], p, n, h)
            - cable.radius for p in pos[-2:]]
    assert max(gaps) < -0.02  # the cable at the support's two vertices: over 2 cm inside the forearm's capsule
    # a cable of two held ends at their places, its free vertices far from every link (2 m out along the support)
    x = np.zeros((cable.model.segments + 1, 3))
    held = list(cable.model.held)
    x[held] = pos
    out = pos[-1] + np.array([0.0, 0.0, 2.0])
    for v in range(cable.model.segments + 1):
        if v not in held:
            x[v] = out + 0.01 * v * np.array([1.0, 0.0, 0.0])
    k = [link4]  # the forearm alone (the long edges to the far vertices would cross the station's body)
    args = (x, cable.radius, prims.kind[k], prims.pos[k], prims.rot[k], prims.size[k])
    free_edges = np.ones((cable.model.segments, 1), dtype=bool)
    free_edges[[0, 23]] = False  # the clamps' own edges, as before the rule
    assert np.isinf(barrier_energy(*args, free_edges, 2e-3, 1e4))  # the support's edge against the forearm
    assert barrier_energy(*args, np.ascontiguousarray(prims.mask[:, k]), 2e-3, 1e4) == 0.0
