"""The rod engine on a station: the same settled cable as MuJoCo at Home, and a weld cycle measured alike."""

from dataclasses import replace

import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.rod.simulator import RodSimulator
from dresspack_gym.stations.station import Station


def station_at(segments):
    cfg = load_station("default")
    robots = tuple(replace(r, dresspack=replace(r.dresspack, segments=segments)) for r in cfg.robots)
    return Station(replace(cfg, robots=robots))


@pytest.mark.parametrize("segments", [24, 48])
def test_home_equilibrium_matches_mujoco(segments):
    station = station_at(segments)
    fast, dynamic = RodSimulator(station), CableSimulator(station)
    assert fast.last_settle.converged and dynamic.last_settle.converged
    gap = np.linalg.norm(fast.cable_points() - dynamic.cable_points(), axis=1).max()
    assert gap < 2e-3  # both converged to their residual tolerance
    assert fast.rods[0].twists() == pytest.approx([0.0], abs=1e-9)  # installed untwisted at Home
    assert fast.measures().max_curvature == pytest.approx(dynamic.measures().max_curvature, rel=0.03)


def test_weld_cycle_runs_and_rests():
    station = station_at(24)
    sim = RodSimulator(station)
    weld = station.weld_configurations["sill_front"][0]
    trace = sim.move_to(weld, record_every=0.05)
    assert sim.last_settle.converged and sim.unconverged_steps == 0 and sim.jammed_samples == 0
    assert len(trace.measures) > 10 and all(np.isfinite(m.max_tension) for m in trace.measures)
    settled = sim.cable_points()
    sim.move_to(weld, record_every=0.05)  # a motion of no length: rest stays rest
    assert np.abs(sim.cable_points() - settled).max() < 1e-6
