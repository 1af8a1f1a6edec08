"""Per-segment damage and fatigue life: each effect alone against what it must be (issue: damage and fatigue)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import settled, world_cable_station

from dresspack_gym.cable.config import FatigueConfig
from dresspack_gym.io.loading import load_station, station_from_dict
from dresspack_gym.physics.damage import accumulate
from dresspack_gym.physics.fatigue import (
    MAX_LIFE,
    count_cycles,
    cycles_to_failure,
    fatigue_life,
    miner_damage,
    strain_amplitude,
)
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import Trajectory, replay
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import make_task

CURVE = FatigueConfig()


def _arc_then_straight(extra_edges: int = 6):
    """A rod clamped into an arc of radius R (no gravity) that continues straight past the second clamp."""
    radius, n, h = 0.5, 20, 0.05
    step = 2 * np.arcsin(h / (2 * radius))
    angles = (np.arange(n + 1) - n / 2) * step
    p = [np.array([radius * np.sin(a), 0.0, 2.0 + radius * np.cos(a)]) for a in angles]
    station = world_cable_station(
        [{"name": "a", "body": "world", "pos": p[0].tolist(), "direction": (p[1] - p[0]).tolist()},
         # an interior clamp holds its vertex and the next: the arc's last chord, the cable goes on straight
         {"name": "b", "body": "world", "pos": p[-2].tolist(), "direction": (p[-1] - p[-2]).tolist(),
          "at": (n - 1) * h}],
        cable={"length": (n + extra_edges) * h, "segments": n + extra_edges}, gravity=0.0)
    return station, radius, n


def test_constant_bending_gives_constant_damage_on_the_arc_and_none_on_the_straight_part():
    station, radius, n = _arc_then_straight()
    sim = settled(station, 4.0)
    assert sim.last_settle.converged
    states, times = [], []
    for k in range(4):
        sim.settle(0.2)
        states.append(sim.segment_states()[0])
        times.append(0.5 * k)
    s = states[-1]
    interior = slice(2, n - 1)  # the arc's interior vertices (the clamps hold the end edges as chords)
    np.testing.assert_allclose(s.curvature[interior], 1 / radius, rtol=0.03)
    np.testing.assert_allclose(np.linalg.norm(s.bend, axis=1), s.curvature, rtol=1e-9, atol=1e-12)
    dp = station.config.robots[0].dresspack
    damage = accumulate(times, states, dp)
    bend = damage.terms["bend"]
    np.testing.assert_allclose(bend[interior], dp.damage.bend * times[-1] / radius, rtol=0.03)
    assert np.all(bend[n + 2:] < 1e-3 * bend[interior].mean())  # straight past the clamp: no bending damage
    rate = damage.strip / np.diff(times)[:, None]  # the damage strip's rate is constant in time on the arc
    np.testing.assert_allclose(rate[:, n // 2], rate[0, n // 2], rtol=1e-3)
    assert damage.terms["friction"].max() == 0.0 and damage.terms["contact_normal"].max() == 0.0


def test_a_cycle_replayed_twice_doubles_the_damage_and_halves_the_life():
    station = Station(load_station("default"))
    sim = CableSimulator(station)
    task = make_task(station, 0, None, ["b_pillar_outer"])
    once = Trajectory(task.waypoints(), stops=(1, 2))
    w = task.waypoints()
    twice = Trajectory(np.vstack([w, w[1:]]), stops=(1, 2, 3, 4))
    r1 = replay(sim, once)
    r2 = replay(sim, twice)
    assert r2.damage.total.max() == pytest.approx(2 * r1.damage.total.max(), rel=0.02)
    np.testing.assert_allclose(r2.damage.total, 2 * r1.damage.total, rtol=0.05, atol=0.02 * r1.damage.total.max())
    assert r2.fatigue.damage_per_cycle.max() == pytest.approx(2 * r1.fatigue.damage_per_cycle.max(), rel=0.05)
    assert r1.summary()["life_cycles"] == pytest.approx(2 * r2.summary()["life_cycles"], rel=0.05)


def test_a_closed_strain_cycle_counts_as_one_cycle_of_its_amplitude():
    t = np.linspace(0, 2 * np.pi, 201)
    for amp, mean, phase in ((0.004, 0.0, 0.0), (0.01, 0.002, 1.0)):
        cycles = count_cycles(mean + amp * np.sin(t + phase))
        total = sum(c for a, c in cycles if a == pytest.approx(amp, rel=1e-3))
        assert total == pytest.approx(1.0) and sum(c for _, c in cycles) == pytest.approx(1.0)
    # a small cycle nested in a large one: one of each (ASTM E1049)
    big_small = [0.0, 0.01, 0.004, 0.006, -0.01, 0.0]
    cycles = sorted(count_cycles(big_small))
    assert cycles[0] == (pytest.approx(0.001), 1.0) or sum(c for a, c in cycles if a == pytest.approx(0.001)) == 1.0
    assert sum(c for a, c in cycles if a == pytest.approx(0.01)) == pytest.approx(1.0)
    assert count_cycles([0.003] * 10) == []


def test_life_falls_monotonically_with_strain_amplitude_and_inverts_the_curve():
    amps = np.geomspace(2e-4, 0.05, 40)
    life = cycles_to_failure(amps, CURVE)
    assert np.all(np.diff(life) < 0)
    np.testing.assert_allclose(strain_amplitude(life, CURVE), amps, rtol=1e-6)
    assert cycles_to_failure(1e-7, CURVE)[0] == MAX_LIFE
    # Miner: two identical cycles per period fail in half the periods
    one = [0.0, 0.003, -0.003, 0.0]
    assert miner_damage(one + one[1:], CURVE) == pytest.approx(2 * miner_damage(one, CURVE))


def test_fatigue_life_of_a_bending_cycle_equals_the_curve_at_r_kappa():
    """A segment bent to curvature k and back to straight, in a fixed material frame: one cycle whose worst fibre
    sees amplitude r k / 2 about a mean r k / 2 -- the life is the curve's at that amplitude."""
    from dresspack_gym.physics.segment_state import SegmentState

    n = 3
    k = 4.0
    zeros = np.zeros(n)

    def state(kappa):
        bend = np.zeros((n, 2))
        bend[1] = (kappa, 0.0)
        return SegmentState(np.abs(bend[:, 0]), bend, zeros, zeros, zeros, zeros, zeros)

    states = [state(x) for x in (0.0, k, 0.0)]
    life = fatigue_life(states, CURVE, np.arange(n) * 0.1)
    amp = CURVE.strain_radius * k / 2
    assert life.max_strain_amplitude[1] == pytest.approx(amp, rel=1e-9)
    assert life.life_cycles[1] == pytest.approx(cycles_to_failure(amp, CURVE)[0], rel=1e-6)
    assert life.life_cycles[0] == MAX_LIFE and life.weakest_segment == 1


def _dragged_cable_station():
    """A robot holding a cable whose free end lies on the floor: turning j1 drags it across the floor."""
    cable = {"name": "drag", "length": 1.9, "radius": 0.02, "linear_density": 1.0, "bending_stiffness": 0.05,
             "tensile_stiffness": 1400, "torsional_stiffness": 0.05, "segments": 20, "collide_with_robot": False,
             "nodes": [{"name": "tool", "body": "link6", "pos": [0.0, 0.0, 0.0], "direction": [1, 0, 0]}]}
    data = {"name": "drag", "floor": True,
            "robots": [{"name": "r1", "robot": "abb_irb6700_200_260", "dresspack": cable,
                        "home_deg": [0, 10, 20, 0, 60, 0]}]}  # flange 1.49 m up, tool axis down
    return Station(station_from_dict(data))


def test_sliding_on_the_floor_adds_friction_damage_only_where_the_cable_touches():
    station = _dragged_cable_station()
    sim = CableSimulator(station)
    # At rest, with its residual checked: the part lying on the floor, held by static friction, stalls at 2.3 % of a
    # vertex weight (just above the 2 % tolerance; README Limitations: friction through discrete-time contact).
    rest_settle = sim.settle(10.0)
    assert rest_settle.equilibrium.force_residual < 0.03 and rest_settle.equilibrium.kinetic_energy < 1e-4
    rest = sim.segment_states()[0]
    touching = rest.normal_force > 0
    assert 3 <= touching.sum() < len(touching) - 5  # the end lies on the floor, the rest hangs
    # vertical balance: the floor's normal forces and the clamp carry the cable's weight rho g L
    forces, _ = sim.node_loads()
    weight = 1.0 * 9.81 * 1.9
    assert np.linalg.norm(forces[0]) + rest.normal_force.sum() == pytest.approx(weight, rel=0.03)
    q = station.home.copy()
    q[0, 0] += np.radians(40)
    traj = Trajectory(np.stack([station.home[0], q[0]]), stops=(1,))
    rep = replay(sim, traj, speed_fraction=0.3)
    friction = rep.damage.terms["friction"]
    ever = np.any([s.normal_force > 0 for s in _states(sim, traj)], axis=0)
    assert friction[ever].max() > 0.0
    assert np.all(friction[~ever] == 0.0)  # segments that never touched have no friction damage
    for st in _states(sim, traj):  # sliding contacts carry Coulomb friction mu N
        sliding = st.slip_speed > 1e-3
        np.testing.assert_allclose(st.friction_force[sliding], 1.0 * st.normal_force[sliding], rtol=1e-9)
    hanging = np.flatnonzero(~ever)
    assert len(hanging) >= 5 and rep.damage.terms["bend"][hanging].max() > 0  # they still bend


def _states(sim, traj):
    """The segment states of a replay of ``traj`` (what rep.damage was accumulated from)."""
    out = []
    sim.reset(np.asarray(traj.waypoints[:1]))
    out.append(sim.segment_states()[0])
    trace = sim.move_to(traj.waypoints[-1], speed_fraction=0.3, record_every=0.05, record_states=True)
    out += [s[0] for s in trace.states]
    out.append(sim.segment_states()[0])
    return out


def test_damage_cost_variant_is_the_worst_segments_damage_rate():
    """On the clamped arc (pure bending, no gravity) the damage variant's C = w_bend / R, and the thesis variant
    carries no damage term."""
    from dresspack_gym.physics.wear_cost import cost_function

    station, radius, _ = _arc_then_straight()
    sim = settled(station, 4.0)
    assert sim.last_settle.converged
    m = sim.measures()
    w = station.config.robots[0].dresspack.damage
    assert m.max_damage_rate == pytest.approx(w.bend / radius, rel=0.03)
    cost = cost_function("damage")(m, station.config.wear_cost)
    assert cost.total == cost.damage == m.max_damage_rate
    assert cost_function("thesis")(m, station.config.wear_cost).damage == 0.0


def test_env_reports_episode_damage_and_life():
    from dresspack_gym.env.dresspack_env import DresspackEnv

    env = DresspackEnv(max_steps=4, settle_time=0.0, cost_variant="damage")
    _, info = env.reset(seed=0)
    assert info["damage"] == 0.0
    damage, done = [], False
    while not done:
        action = int(np.flatnonzero(env.action_masks())[0])
        _, _, term, trunc, info = env.step(action)
        damage.append(info["damage"])
        assert info["cost"] == pytest.approx(info["damage_rate"])
        done = term or trunc
    assert np.all(np.diff(damage) >= 0) and damage[-1] > 0
    assert 0 < info["life_cycles"] <= 1e15


def test_planner_leg_cost_with_the_damage_variant_integrates_the_damage_rate():
    """The planners' leg objective with cost_variant='damage': its wear part is the time integral of the worst
    segment's damage rate, which bounds each segment's value-term damage of the same leg from above."""
    pytest.importorskip("ompl")
    from dresspack.agents.planners.leg_cost import LegCost

    station = Station(load_station("default"))
    task = make_task(station, 0, None, ["b_pillar_outer"])
    legs = LegCost(station, time_weight=0.0, wear_weight=1.0, cost_variant="damage")
    start = legs.start_state(task.start)
    j, _, summary = legs.cost(start, np.stack([task.start, task.goals[0]]))
    assert j == pytest.approx(summary["cost"]) and j > 0
    rep = replay(CableSimulator(station), Trajectory(np.stack([task.start, task.goals[0]]), (1,)),
                 cost_variant="damage")
    values = sum(v for k, v in rep.damage.terms.items() if not k.endswith("_rate"))
    assert rep.integrated_cost() == pytest.approx(j, rel=1e-6)
    assert values.max() <= j * (1 + 1e-6)
    assert values.max() >= 0.5 * j  # the worst segment stays the same most of the time


def test_axial_strain_follows_the_conductors_axial_stiffness():
    """A pull cycle of strain e (tension e EA): one cycle of amplitude e/2 with the bundle's EA, and of
    e/2 * EA / axial_stiffness when the conductors carry the pull with their own stiffness."""
    from dataclasses import replace as dc_replace

    from dresspack_gym.physics.segment_state import SegmentState

    n, e, ea = 3, 0.004, 1400.0
    zeros = np.zeros(n)

    def state(strain):
        return SegmentState(zeros, np.zeros((n, 2)), zeros, np.full(n, strain), zeros, zeros, zeros)

    states = [state(x) for x in (0.0, e, 0.0)]
    own = fatigue_life(states, CURVE, np.arange(n) * 0.1, ea)
    assert own.max_strain_amplitude[1] == pytest.approx(e / 2, rel=1e-9)
    stiff = fatigue_life(states, dc_replace(CURVE, axial_stiffness=10 * ea), np.arange(n) * 0.1, ea)
    assert stiff.max_strain_amplitude[1] == pytest.approx(e / 20, rel=1e-9)
    assert stiff.life_cycles[1] > own.life_cycles[1]


def test_segment_state_twist_and_material_frame_follow_a_twisted_rod():
    """Clamped-clamped straight rod, one end turned theta (no gravity, no bending): each segment's twist rate is
    theta / L_eff, and the material frame the fibres are counted in turns linearly from one clamp's frame to the
    other's (so a fibre keeps its identity while the cable twists)."""
    from test_physics_v2_validation import _wrist_axis_station

    length, segments, theta = 1.0, 20, np.radians(90.0)
    station = _wrist_axis_station(length, segments)
    sim = CableSimulator(station)
    q = station.home.copy()
    q[0, 5] = theta
    sim.move_to(q)
    assert sim.last_settle.converged
    state = sim.segment_states()[0]
    h = length / segments
    l_eff = length - h
    interior = np.abs(state.twist_rate) > 0
    assert interior.sum() == segments - 1
    np.testing.assert_allclose(np.abs(state.twist_rate[interior]), theta / l_eff, rtol=0.02)
    d1 = sim._segment_readers[0]._material_d1(sim.data)
    t = np.diff(sim.cable_points(), axis=0)
    t /= np.linalg.norm(t, axis=1)[:, None]
    angle = np.unwrap([np.arctan2(np.dot(np.cross(d1[0], d), tk), np.dot(d1[0], d)) for d, tk in zip(d1, t)])
    np.testing.assert_allclose(np.abs(angle[-1]), theta, atol=np.radians(1.0))  # the turned clamp's frame
    steps = np.diff(angle[1:-1])  # equal turns between consecutive free edges
    np.testing.assert_allclose(steps, steps.mean(), atol=np.radians(0.5))
    np.testing.assert_allclose(np.linalg.norm(state.bend, axis=1), 0.0, atol=1e-6)  # pure twist, no bending


def test_segment_state_strain_of_a_hanging_cable_is_its_weight_below_over_ea():
    """A taut hanging cable: the strain of the segment at arc s is rho g (L - s) / EA (each effect alone: no
    bending, no twist, no contact)."""
    from test_physics_v2_validation import TIGHT

    ea, rho, length, segments = 300.0, 1.25, 1.74, 24
    station = world_cable_station([{"name": "top", "body": "world", "pos": [0, 0, 3.0], "direction": [0, 0, -1]}],
                                  cable={"tensile_stiffness": ea, "segments": segments},
                                  simulation={"timestep": 0.002, "settle_timestep": 0.008, **TIGHT})
    sim = settled(station, 10.0)
    assert sim.last_settle.converged
    state = sim.segment_states()[0]
    s = np.arange(segments + 1) * length / segments
    free = slice(2, segments - 3)  # below the clamp's rigid edge, where the pull is well above the residual
    np.testing.assert_allclose(state.strain[free] * ea, rho * 9.81 * (length - s[free]), rtol=0.05)
    assert np.abs(state.normal_force).max() == 0.0
