"""Robot-obstacle collision queries: the fast yes/no check agrees with the exact minimum distance."""

import math

import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.robots.kinematics import weld_pose
from dresspack_gym.stations.collision import RobotCollisionChecker
from dresspack_gym.stations.station import Station


def test_collides_agrees_with_exact_min_distance():
    station = Station(load_station("default"))
    checker = RobotCollisionChecker(station)
    lim = station.config.robots[0].robot.joint_limits
    qs = np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], size=(600, 6))
    fast = checker.collides_batch(qs)
    exact = np.array([checker.min_distance(q) < 0.0 for q in qs])
    np.testing.assert_array_equal(fast, exact)
    assert 0.02 < fast.mean() < 0.9  # both outcomes occur


def test_pair_bounds_never_exceed_exact_distances_and_min_distance_is_the_brute_force_minimum():
    """The per-pair lower bounds that let a query skip exact distances (spheres, boxes, the floor, parked robots,
    the dresspack hardware against its own links) stay below every pair's exact distance, so the fast minimum equals
    the minimum over every pair, on a station with parked robots and box parts; penetrating configurations
    included (their depth is the deepest pair's, not cut short by the pairs queried before it)."""
    import mujoco
    checked = penetrating = plane_bounded = 0
    for name, robot in (("side_framing_4r", 0), ("side_framing_4r", 3), ("default", 0)):
        station = Station(load_station(name))
        checker = RobotCollisionChecker(station, robot, margin=0.01)
        m, d = checker.model, checker.data
        lim = station.config.robots[robot].robot.joint_limits
        qs = station.home[robot] + np.random.default_rng(robot).uniform(-1.5, 1.5, size=(60, 6))
        for q in np.clip(qs, lim[:, 0], lim[:, 1]):
            g, o, lb = checker._pose(q)
            exact = np.array([(mujoco.mj_geomDistance(m, d, int(a), int(b), 10.0, np.zeros(6)) - e) * s
                              for a, b, e, s in zip(g, o, checker.extra, checker.scale)])
            near = exact < 9.0  # beyond mj_geomDistance's cap the exact value is the cap, not the distance
            assert np.all(lb[near] <= exact[near] + 1e-9)
            assert checker.min_distance(q) == pytest.approx(exact.min(), abs=1e-9)
            checked += 1
            penetrating += exact.min() < 0.0
            plane_bounded += int(np.isfinite(lb[checker.plane]).sum())
    assert checked == 180 and 20 <= penetrating <= 160
    assert plane_bounded > 100  # the floor's pairs are bounded (not left to exact queries), and the bound holds


def test_tool_pushed_into_an_obstacle_collides_and_margin_grows_the_robot():
    station = Station(load_station("default"))
    checker = RobotCollisionChecker(station)
    kin = station.robots[0].kinematics
    inside = kin.ik(weld_pose([1.3, 0.0, 1.05], [1, 0, 0], 0.0))  # TCP 15 cm inside the B-pillar
    assert len(inside) and all(checker.collides(q) for q in inside)
    assert not checker.collides(station.home[0])
    gap = checker.min_distance(station.home[0])
    assert RobotCollisionChecker(station, margin=gap + 0.01).collides(station.home[0])


def test_joint_reach_bounds_the_displacement_of_every_robot_geom():
    """reach[j] * |delta| bounds how far any robot geom moves when joint j turns by delta."""
    import mujoco

    station = Station(load_station("default"))
    checker = RobotCollisionChecker(station)
    m, d = station.model, checker.data
    rng = np.random.default_rng(2)
    lim = station.config.robots[0].robot.joint_limits
    geoms = station.robots[0].geom_ids
    for q in rng.uniform(lim[:, 0], lim[:, 1], size=(30, 6)):
        checker.min_distance(q)
        reach = checker.joint_reach()
        before = d.geom_xpos[geoms].copy()
        for j in range(6):
            q2 = q.copy()
            q2[j] += 0.2
            d.qpos[station.robots[0].qpos] = q2
            mujoco.mj_kinematics(m, d)
            moved = np.linalg.norm(d.geom_xpos[geoms] - before, axis=1).max()
            assert moved <= reach[j] * 0.2 + 1e-12
            d.qpos[station.robots[0].qpos] = q
            mujoco.mj_kinematics(m, d)


def test_dresspack_nodes_on_links_are_robot_geometry():
    """The tool-plate cable support (and the cable piece it clamps) is robot hardware: an obstacle touching
    only it is a robot-obstacle collision, at the distance the node geometry predicts."""
    import mujoco
    from helpers import default_station_dict

    from dresspack_gym.io.loading import station_from_dict

    probe = Station(load_station("default"))
    d = mujoco.MjData(probe.model)
    d.qpos[probe.robot_qpos] = probe.home.ravel()
    d.qpos[probe.load_qpos] = probe.load_values
    mujoco.mj_kinematics(probe.model, d)
    body = probe.model.body("r1/node_tool_support").id
    node, axis = d.xpos[body].copy(), d.xmat[body].reshape(3, 3)[:, 0]
    side = np.cross(axis, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)  # perpendicular to the clamped cable piece, at its node end
    data = default_station_dict()
    gap = 0.05
    data["obstacles"] = [{"name": "post", "type": "sphere", "pos": (node + side * (0.03 + gap + 0.02)).tolist(),
                          "radius": 0.02}]
    station = Station(station_from_dict(data))
    checker = RobotCollisionChecker(station)
    assert checker.min_distance(station.home[0]) == pytest.approx(gap, abs=2e-3)
    assert RobotCollisionChecker(station, margin=gap + 0.01).collides(station.home[0])
    assert not RobotCollisionChecker(station, margin=gap - 0.01).collides(station.home[0])


def _two_cable_station(offset: float):
    """Two robots parked far away, each with a nearly taut cable strung between world nodes; the cables cross
    at their middles, the second ``offset`` above the first (both 3 cm thick)."""
    import copy

    from helpers import THESIS_CABLE

    from dresspack_gym.io.loading import station_from_dict
    from dresspack_gym.stations.station import Station

    def cable(a, b):
        dp = copy.deepcopy(THESIS_CABLE)
        dp.update(length=1.21, segments=22)
        d = (np.asarray(b) - np.asarray(a)).tolist()
        dp["nodes"] = [{"name": "a", "body": "world", "pos": a, "direction": d},
                       {"name": "b", "body": "world", "pos": b, "direction": d}]
        return dp

    z = 1.5
    robots = [{"name": "r1", "robot": "abb_irb6700_200_260", "dresspack": cable([0, -0.6, z], [0, 0.6, z]),
               "base_pos": [-20, -20, 0], "home_deg": [0, 0, 0, 0, 0, 0]},
              {"name": "r2", "robot": "abb_irb6700_200_260",
               "dresspack": cable([-0.6, 0, z + offset], [0.6, 0, z + offset]),
               "base_pos": [20, 20, 0], "home_deg": [0, 0, 0, 0, 0, 0]}]
    return Station(station_from_dict({"name": "crossing", "robots": robots, "floor": False}))


def test_cables_of_different_robots_rest_on_each_other():
    """Crossing cables of two robots touch: at rest the upper one lies on the lower, their centre lines one
    diameter apart at the crossing (none passes through), the contact force equal on both and the nodes of each
    carrying its weight plus or minus that force."""
    from dresspack_gym.physics.simulation import CableSimulator

    station = _two_cable_station(0.05)
    sim = CableSimulator(station)
    sim.settle(6.0)
    assert sim.last_settle.converged
    lower, upper = sim.cable_points(0), sim.cable_points(1)
    i = int(np.argmin(np.abs(lower[:, 1])))  # the lower cable's vertex at the crossing (y = 0)
    j = int(np.argmin(np.abs(upper[:, 0])))
    gap = upper[j, 2] - lower[i, 2]
    assert gap == pytest.approx(2 * 0.03, abs=0.012)  # one diameter (a vertex may sit up to h/2 from the crossing)
    state = sim.segment_states()
    assert state[0].normal_force.sum() > 0.5 and state[1].normal_force.sum() > 0.5
    free = _two_cable_station(0.5)  # far apart: no contact, both sag freely and alike
    sim2 = CableSimulator(free)
    sim2.settle(6.0)
    assert sim2.segment_states()[0].normal_force.sum() == 0.0
    assert lower[i, 2] < sim2.cable_points(0)[i, 2] - 0.002  # the upper cable's weight pushes the lower one down
    # vertical balance of each cable: its nodes carry its weight plus (lower) or minus (upper) the contact force
    weight = 1.25 * 1.21 * 9.81
    contact = state[0].normal_force.sum()
    assert state[1].normal_force.sum() == pytest.approx(contact, rel=1e-9)  # action = reaction
    for r, expected in ((0, weight + contact), (1, weight - contact)):
        forces, _ = sim.node_loads(r)
        rot = [sim.data.xmat[b].reshape(3, 3) for b in station.cables[r].node_bodies]
        assert -sum((R @ f)[2] for R, f in zip(rot, forces)) == pytest.approx(expected, rel=0.02)


def test_dresspack_hardware_is_checked_against_its_own_robots_links():
    """A wrist bent to 90 deg (a weld drawn on the car body, q below) turns the tool support into the forearm; the
    flex contact of the edge it holds then reported tens of MN as cable tension. Such configurations collide."""
    import mujoco

    station = Station(load_station("default"))
    checker = RobotCollisionChecker(station, margin=0.005)
    m, name = station.model, lambda g: m.geom(int(g)).name
    own = {(name(a), name(b)) for (a, b), s in zip(checker.pairs, checker.scale) if s < 1.0}
    assert {("r1/node_tool_support_geom", "r1/link4_geom4"), ("r1/node_arm_clamp_geom", "r1/link6_geom6")} <= own
    # links next to the carrying one are not checked (joint housings touch by design), nor the hardware itself
    assert not {("r1/node_tool_support_geom", "r1/link5_geom5"), ("r1/node_arm_clamp_geom", "r1/link4_geom4")} & own
    assert not any("node" in b for _, b in own)
    bent = np.radians([-58.0, 52.0, 17.0, 296.0, -94.0, 109.0])
    assert checker.collides(bent) and not checker.collides(station.home[0])
    checker.min_distance(bent)  # poses the robot
    to_station = min(mujoco.mj_geomDistance(m, checker.data, int(g), int(o), 10.0, np.zeros(6))
                     for g in station.robots[0].geom_ids for o in station.obstacle_geoms if name(o) != "floor")
    assert to_station > 0.05  # clear of the station: only the own-link check catches it
    # the pair counts half its surface distance (both geoms move), read against MuJoCo's exact distance
    d = checker.data
    support, forearm = m.geom("r1/node_tool_support_geom").id, m.geom("r1/link4_geom4").id
    for q in (bent, station.home[0]):
        checker.min_distance(q)
        exact = mujoco.mj_geomDistance(m, d, support, forearm, 10.0, np.zeros(6))
        assert checker.min_distance(q) <= 0.5 * exact + 1e-12
    assert checker.min_distance(bent) == pytest.approx(0.5 * exact_at(checker, bent, support, forearm), abs=1e-9)


def exact_at(checker, q, g1, g2):
    import mujoco

    checker.min_distance(q)  # poses the robot
    return mujoco.mj_geomDistance(checker.model, checker.data, g1, g2, 10.0, np.zeros(6))


def test_batched_distances_and_lockstep_segments_answer_as_one_at_a_time():
    """min_distances equals min_distance per configuration, and segments_clear (segments advanced in lockstep,
    queries batched) equals conservative advancement run on each segment alone, query for query (their common first
    query once)."""
    from dresspack_gym.stations.validity import MotionValidity

    station = Station(load_station("default"))
    validity = MotionValidity(station, 0, margin=0.005)
    checker = validity.checker
    home = station.config.robots[0].home
    rng = np.random.default_rng(1)
    qs = home + rng.uniform(-1.5, 1.5, size=(400, 6))
    batched = checker.min_distances(qs)
    np.testing.assert_array_equal(batched, [checker.min_distance(q) for q in qs])
    # the batch's lower bounds are the one-configuration ones (same pairs pruned and ordered, up to rounding)
    np.testing.assert_allclose(checker._pose_batch(qs)[2], [checker._pose(q)[2] for q in qs], rtol=0, atol=1e-12)
    assert (batched < 0).any() and (batched > 0.05).any()

    def alone(q0, q1):  # conservative advancement of one segment, as the checker's contract states it
        reach, t, queries = float(checker.chain_reach() @ np.abs(q1 - q0)), 0.0, 0
        while True:
            queries += 1
            d = checker.min_distance(q0 + t * (q1 - q0))
            if d < checker.margin:
                return False, queries
            if t >= 1.0 or reach == 0.0:
                return True, queries
            t = min(1.0, t + (d - 0.5 * checker.margin) / reach)

    q0 = home.copy()
    q1s = q0 + rng.uniform(-1.2, 1.2, size=(40, 6))
    expected = [alone(q0, q1) for q1 in q1s]
    n = validity.n_checks
    np.testing.assert_array_equal(validity.segments_clear(q0, q1s), [ok for ok, _ in expected])
    # query for query, except that the segments' shared first query (q0's) is made once
    assert validity.n_checks - n == sum(k for _, k in expected) - (len(q1s) - 1)
    assert 0 < sum(ok for ok, _ in expected) < len(expected)  # both outcomes occur
    assert validity.segment_clear(q0, q1s[0]) == expected[0][0]
    hit = qs[int(np.argmin(batched))]  # from a configuration in collision no segment is clear, after one query
    n = validity.n_checks
    assert not validity.segments_clear(hit, hit + rng.uniform(-0.3, 0.3, size=(10, 6))).any()
    assert validity.n_checks - n == 1


def test_bench_collision_compares_lockstep_and_one_by_one_segment_checks_in_one_run():
    from dresspack_gym.cli.bench import collision_benchmark

    out = collision_benchmark(repeats=1, n_configs=20)
    assert out["segments_lockstep_vs_one_by_one"] > 0 and 0 < out["segments_clear_fraction"] < 1
    # a ratio of two times measured in one run (compiled kinematics make a query cheaper than MuJoCo's posing, so
    # its size is the machine's, not a property to test) and a count: a segment takes several advancement steps
    assert 0 < out["stepping_query_vs_kinematics"] < math.inf and out["stepping_queries_per_segment"] > 2.0
