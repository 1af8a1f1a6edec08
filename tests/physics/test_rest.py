"""Rest is rest: a settle that reports convergence leaves a cable that stays put when simulated on, and a settle
that cannot reach rest says so (issue: cable physics v3; the full table is scripts/studies/rest_table.py)."""

import numpy as np
import pytest
from helpers import default_station_dict

from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station, station_from_dict
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import select_weld_goals
from dresspack_gym.stations.validity import MotionValidity

MORE = 20.0  # [s] simulated on after the settle, robots still
# A twist rate this small (0.6 deg per metre) is no twist worth a percentage: changes below it count as none.
TWIST_FLOOR = 0.01  # [rad/m]


def _at_weld(station: Station, weld: str) -> CableSimulator:
    sim = CableSimulator(station)
    q = select_weld_goals(station, 0, MotionValidity(station, 0, 0.005).checker.collides, [weld])[weld]
    target = station.home.copy()
    target[0] = q
    sim.move_to(target)
    return sim


def _state(sim: CableSimulator) -> dict:
    m = sim.measures()
    forces, torques = sim.node_loads()
    return {"points": sim.cable_points().copy(), "tension": m.max_tension, "twist_rate": m.max_twist_rate,
            "clamp_force": float(np.linalg.norm(forces, axis=1).max()),
            "clamp_torque": float(np.linalg.norm(torques, axis=1).max())}


def _simulate_on(sim: CableSimulator, seconds: float) -> None:
    q, zero = sim.q.ravel(), np.zeros(sim.q.size)
    for _ in range(int(round(seconds / sim.model.opt.timestep))):
        sim._step(q, zero)


@pytest.mark.parametrize("weld", ["sill_front", "sill_rear", "b_pillar_outer", "roof_rail_top"])
def test_a_converged_settle_stays_put(weld):
    sim = _at_weld(Station(load_station("default")), weld)
    assert sim.last_settle.converged
    before = _state(sim)
    _simulate_on(sim, MORE)
    after = _state(sim)
    assert np.linalg.norm(after["points"] - before["points"], axis=1).max() < 0.002  # measured 0.4-0.7 mm
    for key in ("tension", "clamp_force", "clamp_torque"):
        assert after[key] == pytest.approx(before[key], rel=0.02)  # measured <= 0.4 %
    assert abs(after["twist_rate"] - before["twist_rate"]) < max(0.02 * before["twist_rate"], TWIST_FLOOR)


def test_a_cable_creeping_along_a_rail_is_not_called_settled():
    """At floor_pan_inner the cable rests on the roof rail under a tangential load; MuJoCo's soft pyramidal contact
    lets it slide on (tens of mm in 20 s), and the settle reports that it did not reach rest."""
    sim = _at_weld(Station(load_station("default")), "floor_pan_inner")
    assert not sim.last_settle.converged
    before = sim.cable_points().copy()
    _simulate_on(sim, 5.0)
    assert np.linalg.norm(sim.cable_points() - before, axis=1).max() > 0.002  # it really is still moving


def test_elliptic_cones_hold_the_cable_on_the_rail():
    """The station option that holds it: elliptic friction cones with a high frictional impedance (impratio)."""
    d = default_station_dict()
    d["simulation"] = {"friction_cone": "elliptic", "impratio": 100}
    station = Station(station_from_dict(d))
    assert station.model.opt.cone == 1 and station.model.opt.impratio == 100
    sim = _at_weld(station, "floor_pan_inner")
    assert sim.last_settle.converged
    before = sim.cable_points().copy()
    _simulate_on(sim, MORE)
    assert np.linalg.norm(sim.cable_points() - before, axis=1).max() < 0.002  # measured 1.4 mm (pyramidal: 76 mm)


@pytest.mark.parametrize("field, value, message", [
    ("friction_cone", "round", "simulation.friction_cone: 'round' is not one of the allowed values"),
    ("impratio", 0.5, "simulation.impratio"),
])
def test_friction_settings_are_checked(field, value, message):
    d = default_station_dict()
    d["simulation"] = {field: value}
    with pytest.raises(ConfigError, match=message):
        station_from_dict(d)
