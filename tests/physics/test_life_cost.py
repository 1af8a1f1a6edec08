"""The life cost variant: a state's fatigue damage of one excursion against the strain-life curve, filled alike by
both engines from their segment states, and C = w_life x that damage."""

import math

import numpy as np
import pytest

from dresspack_gym.cable.config import FatigueConfig
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.fatigue import MAX_LIFE, cycles_to_failure, excursion_damage, peak_excursion_damage
from dresspack_gym.physics.measures import WearMeasures
from dresspack_gym.physics.profiles import make_simulator
from dresspack_gym.physics.segment_state import SegmentState
from dresspack_gym.physics.wear_cost import COST_VARIANTS, cost_function
from dresspack_gym.stations.config import WearCostConfig
from dresspack_gym.stations.station import Station

CURVE = FatigueConfig(strain_radius=3e-4, torsion_radius=2e-3)


def state(kappa=0.0, twist=0.0, strain=0.0, n=3):
    z = np.zeros(n)
    k, t, e = z.copy(), z.copy(), z.copy()
    k[1], t[1], e[1] = kappa, twist, strain
    return SegmentState(k, np.zeros((n, 2)), t, e, z, z, z)


def test_one_excursion_is_one_cycle_of_half_the_strain():
    """Bent to kappa: amplitude r kappa / 2; twisted to tau: r_t tau / (2 sqrt 3); pulled: strain / 2 on the fibre
    already bent (both add); the worst segment's damages add (Miner). The curve is read from its interpolated table
    (within 1e-5 of the bisection's inverse)."""
    life = lambda a: cycles_to_failure(a, CURVE)[0]  # noqa: E731
    assert excursion_damage(state(kappa=4.0), CURVE) == pytest.approx(1 / life(3e-4 * 4.0 / 2), rel=1e-5)
    tau = math.radians(150.0)
    assert excursion_damage(state(twist=-tau), CURVE) == pytest.approx(1 / life(2e-3 * tau / (2 * math.sqrt(3))),
                                                                       rel=1e-5)
    both = excursion_damage(state(kappa=4.0, twist=tau, strain=0.001), CURVE)
    assert both == pytest.approx(1 / life((3e-4 * 4.0 + 0.001) / 2) + 1 / life(2e-3 * tau / (2 * math.sqrt(3))),
                                 rel=1e-5)
    # across the curve: the table's lives within 1e-5 of the bisection's, from the longest life counted to N = 1
    amps = np.logspace(-6, -0.5, 500)
    amps = amps[cycles_to_failure(amps, CURVE) < MAX_LIFE]
    assert amps[0] < 1e-4
    table = np.array([1 / excursion_damage(state(kappa=2 * a / 3e-4), CURVE) for a in amps])
    exact = cycles_to_failure(amps, CURVE)
    np.testing.assert_allclose(table, exact, rtol=1e-5)
    assert excursion_damage(state(), CURVE) == 0.0
    # more strain, more damage
    assert excursion_damage(state(kappa=8.0), CURVE) > excursion_damage(state(kappa=4.0), CURVE)


def test_the_life_variant_charges_w_life_times_the_excursion_damage():
    m = WearMeasures(5.0, 100.0, 0.0, 3.0, excursion_damage=2e-5)
    cfg = WearCostConfig(w_life=1e4)
    cost = cost_function("life")(m, cfg)
    assert cost.total == cost.damage == pytest.approx(0.2)
    assert cost.curvature == cost.tension == cost.distance == cost.twist == 0.0
    assert "life" in COST_VARIANTS
    # the station's measure is its worst cable's
    other = WearMeasures(1.0, 10.0, 0.5, 1.0, excursion_damage=7e-5)
    assert WearMeasures.worst([m, other]).excursion_damage == 7e-5
    with pytest.raises(ConfigError, match="wear_cost.w_life"):
        WearCostConfig.from_dict({"w_life": -1.0})


def test_a_wear_maps_peaks_bound_the_excursion_damage_at_one_segment():
    dp = Station(load_station("default")).config.robots[0].dresspack
    peak = peak_excursion_damage(5.0, 1.0, 40.0, dp)
    assert peak == pytest.approx(excursion_damage(state(kappa=5.0, twist=1.0, strain=40.0 / dp.tensile_stiffness),
                                                  dp.fatigue, dp.tensile_stiffness), rel=1e-12)


@pytest.mark.parametrize("engine", ["dynamic", "fast"])
def test_both_engines_fill_the_excursion_damage_from_their_segment_states(engine):
    station = Station(load_station("default"))
    sim = make_simulator(station, engine)
    sim.reset(station.home)
    m, states = sim.measures_and_states()
    dp = station.config.robots[0].dresspack
    expected = excursion_damage(states[0], dp.fatigue, dp.tensile_stiffness)
    assert m.excursion_damage == pytest.approx(expected, rel=1e-12) and expected > 0
    assert cost_function("life")(m, station.config.wear_cost).total == pytest.approx(
        station.config.wear_cost.w_life * expected)


def test_the_planners_leg_cost_and_the_station_planners_option_rates_take_the_life_variant():
    """LegCost (ompl-wear, thesis-local, ppo-search) with cost_variant='life': J = T + w_life x the worst segment's
    fatigue damage over the leg (its rainflow count); the station planner's settled option rate is w_life x the
    excursion damage."""
    pytest.importorskip("ompl")
    from dresspack.agents.planners.leg_cost import LegCost
    from dresspack.agents.stations.option_costs import OptionCosts

    from dresspack_gym.physics.simulation import CableSimulator
    from dresspack_gym.physics.trajectory import Trajectory, replay
    from dresspack_gym.stations.tasks import make_task

    station = Station(load_station("default"))
    task = make_task(station, 0, None, ["b_pillar_outer"])
    legs = LegCost(station, time_weight=1.0, wear_weight=1.0, cost_variant="life")
    waypoints = np.stack([task.start, task.goals[0]])
    j, _, summary = legs.cost(legs.start_state(task.start), waypoints)
    rep = replay(CableSimulator(station), Trajectory(waypoints, (1,)), cost_variant="life")
    w = station.config.wear_cost.w_life
    leg_damage = rep.fatigue.damage_per_cycle.max()
    assert leg_damage > 0 and summary["cost"] > 0
    assert j == pytest.approx(rep.cycle_time + w * leg_damage, rel=1e-9)
    # a bound below J gives the leg up (once simulated: J needs the whole leg's history); one above returns J itself
    legs.reset()
    assert legs.cost(legs.start_state(task.start), waypoints, bound=0.5 * j)[0] == math.inf and legs.given_up == 1
    assert legs.cost(legs.start_state(task.start), waypoints, bound=2 * j)[0] == j
    rate = OptionCosts(station, "life").rate(0, station.home[0])
    sim = CableSimulator(station)
    sim.reset(station.home)
    dp = station.config.robots[0].dresspack
    assert rate == pytest.approx(w * excursion_damage(sim.segment_states()[0], dp.fatigue, dp.tensile_stiffness),
                                 rel=1e-6)
