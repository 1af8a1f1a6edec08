"""Robot clearance queries against a straightforward reference (each configuration on its own: the pairs queried in
the order of plain bounds, itself checked against every pair's exact distance) and conservative advancement run on
it. The queries' shortcuts (the bounds, the nearest pairs each query hands to the next, segments kept from earlier
checks) must give the same distances and the same answers."""

import mujoco
import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.stations import validity as validity_module
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.validity import PLANNER_MARGIN, MotionValidity


def exact_min_distance(model, data, rows) -> float:
    """The clearance at the posed configuration, as defined: every pair's exact (distance - extra) x scale."""
    return min((mujoco.mj_geomDistance(model, data, g, o, 10.0, None) - e) * s for g, o, e, s in rows)


class Reference:
    """A robot's clearance, straightforwardly: posed by MuJoCo's kinematics on an MjData of its own, the pairs the
    checker lists queried exactly in the order of a plain bound (bounding spheres; the moving geom's bounding
    sphere to a static box or plane, where the sphere is clear of it) until that bound reaches the smallest
    distance found. Checked against every pair's exact distance below."""

    def __init__(self, station: Station, robot: int, checker):
        self.model, self.data = station.model, station.data_at_home()
        self.qpos = station.robots[robot].qpos
        self.rows = [(int(g), int(o), float(e), float(s))
                     for (g, o), e, s in zip(checker.pairs, checker.extra, checker.scale)]
        self.g, self.o = checker.pairs[:, 0], checker.pairs[:, 1]
        self.extra, self.scale = checker.extra, checker.scale
        self.plane = self.model.geom_type[self.o] == mujoco.mjtGeom.mjGEOM_PLANE
        static = ~np.isin(self.o, station.robots[robot].geom_ids)
        self.surface = self.plane | static & (self.model.geom_type[self.o] == mujoco.mjtGeom.mjGEOM_BOX)
        self.radius, self.other_radius = self.model.geom_rbound[self.g], self.model.geom_rbound[self.o]
        self.size = self.model.geom_size[self.o]
        self.chain = checker.chain_reach()
        self.margin = checker.margin

    def pose(self, q) -> None:
        self.data.qpos[self.qpos] = q
        mujoco.mj_kinematics(self.model, self.data)

    def min_distance(self, q) -> float:
        self.pose(q)
        m, d = self.model, self.data
        xpos = d.geom_xpos
        gap = xpos[self.g] - xpos[self.o]
        frames = d.geom_xmat.reshape(-1, 3, 3)[self.o]
        spheres = np.linalg.norm(gap, axis=1) - self.radius - self.other_radius
        heights = np.einsum("pk,pk->p", gap, frames[:, :, 2]) - self.radius
        outside = np.maximum(np.abs(np.einsum("pk,pkj->pj", gap, frames)) - self.size, 0.0)
        boxes = np.linalg.norm(outside, axis=1) - self.radius
        surface = np.where(self.plane, heights, boxes)
        bound = (np.where(self.surface, np.where(surface > 0.0, surface, -np.inf), spheres) - self.extra) * self.scale
        best = np.inf
        for k in np.argsort(bound):
            if bound[k] >= best:
                break
            g, o, e, s = self.rows[k]
            best = min(best, (mujoco.mj_geomDistance(m, d, g, o, 10.0, None) - e) * s)
        return best

    def segment_clear(self, q0, q1) -> tuple[bool, int]:
        """Conservative advancement as MotionValidity states it: (clear, distance queries made)."""
        dq = q1 - q0
        reach, t, queries = float(self.chain @ np.abs(dq)), 0.0, 0
        while True:
            queries += 1
            d = self.min_distance(q0 + t * dq)
            if d < self.margin:
                return False, queries
            if t >= 1.0 or reach == 0.0:
                return True, queries
            t = min(1.0, t + (d - 0.5 * self.margin) / reach)


def random_segments(station: Station, robot: int, n: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """What planners ask: mostly steps that go on from the last one's end (a path, a tree's branch), some from
    the same start, some again (a path re-checked), and jumps to elsewhere near Home, into collisions too."""
    rng = np.random.default_rng(seed)
    lim = station.config.robots[robot].robot.joint_limits
    home = station.home[robot]
    segments, q = [], home.copy()
    while len(segments) < n:
        r = rng.random()
        if r < 0.05 and segments:
            segments.append(segments[rng.integers(len(segments))])
            continue
        if r < 0.1:
            q = np.clip(home + rng.uniform(-1.5, 1.5, 6), lim[:, 0], lim[:, 1])
        size = 0.2 if r < 0.12 else 0.02  # long moves (many steps) and short ones (a step or two)
        q0 = q if r < 0.9 or not segments else segments[-1][0]
        q1 = np.clip(q0 + rng.normal(0.0, size, 6), lim[:, 0], lim[:, 1])
        segments.append((q0, q1))
        q = q1
    return segments


@pytest.mark.parametrize("name, robot, n", [("default", 0, 10_000), ("side_framing_4r", 2, 400)])
def test_segment_answers_and_queries_are_the_references(name, robot, n):
    """Every segment gets the reference's answer after the reference's number of distance queries (the same
    distances, step for step); both answers occur, and segments that start in a collision are among them."""
    station = Station(load_station(name))
    validity = MotionValidity(station, robot, margin=PLANNER_MARGIN)
    reference = Reference(station, robot, validity.checker)
    segments = random_segments(station, robot, n, seed=robot)
    answers, queries = [], []
    for q0, q1 in segments:
        before = validity.n_checks
        answers.append(validity.segment_clear(q0, q1))
        queries.append(validity.n_checks - before)
    expected = [reference.segment_clear(q0, q1) for q0, q1 in segments]
    assert answers == [ok for ok, _ in expected]
    assert queries == [k for _, k in expected]
    assert 0.2 < np.mean(answers) < 0.9 and sum(k == 1 and not ok for ok, k in expected) > n // 100
    assert np.mean(queries) > 2.0  # steps along segments, not only one-query answers


@pytest.mark.parametrize("name, robot", [("default", 0), ("side_framing_4r", 2)])
def test_distances_along_segments_are_every_pairs_minimum_to_the_last_bit(name, robot):
    """Each query of a run of nearby configurations (where a query starts from the pairs the last one found
    nearest), and the batch of them, return the smallest exact pair distance, penetrations included; so does the
    reference the other tests compare with."""
    station = Station(load_station(name))
    checker = MotionValidity(station, robot, margin=PLANNER_MARGIN).checker
    reference = Reference(station, robot, checker)
    qs = np.array([q0 + t * (q1 - q0) for q0, q1 in random_segments(station, robot, 150, seed=7)
                   for t in np.linspace(0.0, 1.0, 8)])
    fast = np.array([checker.min_distance(q) for q in qs])
    exact = []
    for q in qs:
        reference.pose(q)
        exact.append(exact_min_distance(reference.model, reference.data, reference.rows))
    np.testing.assert_array_equal(fast, exact)
    np.testing.assert_array_equal(checker.min_distances(qs), exact)
    np.testing.assert_array_equal([reference.min_distance(q) for q in qs], exact)
    assert (np.array(exact) < 0.0).sum() > 10 and (np.array(exact) > 0.1).sum() > 100


def test_a_segment_checked_again_is_answered_from_memory_with_its_queries_counted():
    station = Station(load_station("default"))
    validity = MotionValidity(station, 0, margin=PLANNER_MARGIN)
    q0 = station.home[0]
    q1 = q0 + np.array([0.6, -0.3, 0.2, 0.5, -0.4, 0.3])
    clear = validity.segment_clear(q0, q1)
    first = validity.n_checks
    calls = []  # the checker's advancements (each a compiled run of distance queries)
    real = validity.checker.advance
    validity.checker.advance = lambda *args: calls.append(args) or real(*args)
    assert validity.segment_clear(q0.copy(), list(q1)) == clear  # the same ends, as another array or a list
    assert calls == [] and validity.n_checks == 2 * first > 2
    validity.segment_clear(q1, q0)  # the other way is another segment
    assert len(calls) > 0


def test_the_segment_memory_forgets_the_oldest_past_its_size(monkeypatch):
    monkeypatch.setattr(validity_module, "SEGMENT_MEMORY", 3)
    station = Station(load_station("default"))
    validity = MotionValidity(station, 0, margin=PLANNER_MARGIN)
    reference = Reference(station, 0, validity.checker)
    segments = random_segments(station, 0, 40, seed=3)
    for q0, q1 in segments + segments[::-1]:
        assert validity.segment_clear(q0, q1) == reference.segment_clear(q0, q1)[0]
        assert len(validity._segments) <= 3


def test_a_pairs_distance_shrinks_no_more_than_its_geoms_can_move():
    """What lets a query start from the last one's pairs: between two configurations a pair's distance shrinks by
    at most its geom's displacement bound (centre displacement plus turn times bounding radius; the turn of link
    L at most the sum of |dq| of the joints before it), or for two geoms of the robot by the relative motion of
    the joints between their links, at the pair's scale; whenever the distance was positive."""
    station = Station(load_station("default"))
    checker = MotionValidity(station, 0, margin=PLANNER_MARGIN).checker
    reference = Reference(station, 0, checker)
    m, d = reference.model, reference.data
    own = list(checker.robot.geom_ids)
    links = [int(x) for x in checker.robot.geom_links]
    rng = np.random.default_rng(5)
    lim = station.config.robots[0].robot.joint_limits
    checked = hardware = tight = 0
    for _ in range(300):
        qa = np.clip(station.home[0] + rng.uniform(-1.5, 1.5, 6), lim[:, 0], lim[:, 1])
        qb = np.clip(qa + rng.normal(0.0, 0.15, 6), lim[:, 0], lim[:, 1])
        distances, centres = [], []
        for q in (qa, qb):
            reference.pose(q)
            distances.append([(mujoco.mj_geomDistance(m, d, g, o, 10.0, None) - e) * s
                              for g, o, e, s in reference.rows])
            centres.append(d.geom_xpos[own].copy())
        turn = np.concatenate([[0.0], np.cumsum(np.abs(qb - qa))])
        moved = np.linalg.norm(centres[1] - centres[0], axis=1) + turn[links] * m.geom_rbound[own]
        for k, (row_g, row_h, scale, relative, *_) in enumerate(checker._pair_walk):
            if distances[0][k] <= 0.0:
                continue
            if row_h < 0:
                shrink = moved[row_g]
            else:
                a, b, reaches = relative
                shrink = scale * min(moved[row_g] + moved[row_h], float(np.dot(reaches, np.abs(qb - qa)[a:b])))
                hardware += 1
            assert distances[1][k] >= distances[0][k] - shrink - 1e-9
            checked += 1
            tight += distances[1][k] < distances[0][k] - 0.5 * shrink
    assert checked > 10_000 and hardware > 1000 and tight > 0  # the bound is sometimes met halfway


def test_a_pickled_motion_validity_answers_as_the_original():
    """The env pickles mid-episode: a copy's checks pose its own MjData and answer as the original's do."""
    import pickle

    station = Station(load_station("default"))
    validity = MotionValidity(station, 0, margin=PLANNER_MARGIN)
    segments = random_segments(station, 0, 300, seed=11)
    for q0, q1 in segments[:150]:
        validity.segment_clear(q0, q1)
    copy = pickle.loads(pickle.dumps(validity))
    for q0, q1 in segments[150:]:
        assert copy.segment_clear(q0, q1) == validity.segment_clear(q0, q1)
        assert copy.checker.min_distance(q1) == validity.checker.min_distance(q1)


@pytest.mark.parametrize("name, robot", [("default", 0), ("side_framing_4r", 0), ("side_framing_4r", 2),
                                         ("thesis_tension", 0)])
def test_the_compiled_kinematics_pose_the_robot_as_mj_kinematics_to_the_last_bit(name, robot):
    """The checker poses its robot with compiled kinematics (it checked them on construction): every body, joint,
    geom and site they write equals what MuJoCo's mj_kinematics writes, bit for bit, anywhere within the limits."""
    from dresspack_gym.stations import clearance_kernels as kernels

    station = Station(load_station(name))
    checker = MotionValidity(station, robot, margin=PLANNER_MARGIN).checker
    assert checker._ints[kernels.H_FK, 0] == 1  # the compiled kinematics are in use
    m, d = checker.model, checker.data
    body_i, joint_i, item_i = (np.array(rows).reshape(len(rows), -1) for rows in checker._fk_rows)
    bodies, joints = body_i[:, kernels.K_BODY], joint_i[:, kernels.J_ID]
    geoms = item_i[item_i[:, kernels.I_SITE] == 0, kernels.I_ID]
    moving = checker.robot.geom_ids[checker.robot.geom_links > 0]  # the base stands still
    assert set(moving.tolist()) <= set(geoms.tolist()) and len(bodies) >= 6

    def poses():
        return [a.copy() for a in (d.xpos[bodies], d.xquat[bodies], d.xmat[bodies], d.xipos[bodies],
                                   d.ximat[bodies], d.xanchor[joints], d.xaxis[joints], d.geom_xpos[geoms],
                                   d.geom_xmat[geoms])]

    lim = station.config.robots[robot].robot.joint_limits
    for q in np.random.default_rng(robot).uniform(lim[:, 0], lim[:, 1], size=(300, 6)):
        checker._kinematics(q)
        compiled = poses()
        mujoco.mj_kinematics(m, d)
        for a, b in zip(compiled, poses()):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("name, robot", [("default", 0), ("side_framing_4r", 2), ("thesis_tension", 0)])
def test_distances_at_random_configurations_are_every_pairs_exact_minimum(name, robot):
    """Jumps anywhere within the limits (each query far from the last) and the steps between them: one query at a
    time, in a batch and as collides answers it, the smallest exact pair distance, to the last bit."""
    station = Station(load_station(name))
    checker = MotionValidity(station, robot, margin=PLANNER_MARGIN).checker
    reference = Reference(station, robot, checker)
    lim = station.config.robots[robot].robot.joint_limits
    rng = np.random.default_rng(3)
    jumps = rng.uniform(lim[:, 0], lim[:, 1], size=(150, 6))
    qs = np.concatenate([jumps, jumps + rng.normal(0.0, 0.01, size=jumps.shape)])[np.argsort(np.tile(range(150), 2))]
    exact = []
    for q in qs:
        reference.pose(q)
        exact.append(exact_min_distance(reference.model, reference.data, reference.rows))
    np.testing.assert_array_equal([checker.min_distance(q) for q in qs], exact)
    np.testing.assert_array_equal(checker.min_distances(qs), exact)
    np.testing.assert_array_equal([checker.collides(q) for q in qs], np.array(exact) < checker.margin)
    assert (np.array(exact) < checker.margin).any() and (np.array(exact) > 0.05).any()


def test_segment_valid_answers_as_the_reference_where_the_dresspack_can_tear():
    """thesis_tension (a dresspack short enough to tear: segments check its slack too) over thousands of segments:
    segment_valid is the sampled limits, restrictions and slack with the reference's collision answer, and takes the
    reference's queries."""
    station = Station(load_station("thesis_tension"))
    validity = MotionValidity(station, 0, margin=PLANNER_MARGIN)
    reference = Reference(station, 0, validity.checker)
    assert validity._may_tear
    answers, expected = [], []
    for q0, q1 in random_segments(station, 0, 3000, seed=4):
        before = validity.n_checks
        answers.append((validity.segment_valid(q0, q1), validity.n_checks - before))
        n = max(1, int(np.ceil(np.max(np.abs(q1 - q0)) / validity.resolution)))
        qs = q0 + np.linspace(0.0, 1.0, n + 1)[1:, None] * (q1 - q0)
        if not (validity.within_limits(qs).all() and validity.restrictions.allowed(qs).all()
                and all(validity.cable_slack(q) >= 0.0 for q in qs)):
            expected.append((False, 0))
        else:
            expected.append(reference.segment_clear(q0, q1))
    assert len(answers) == len(expected) and all(a == e for a, e in zip(answers, expected))
    assert 0.1 < np.mean([ok for ok, _ in answers]) < 0.95 and sum(k > 2 for _, k in answers) > 300


def test_a_clearance_function_set_on_the_checker_is_what_the_advancement_queries():
    """The advancement runs compiled with the checker's own queries; a clearance function set in their place (a
    wrapper here) is stepped in Python, query for query the same answers and counts."""
    station = Station(load_station("default"))
    compiled = MotionValidity(station, 0, margin=PLANNER_MARGIN)
    stepped = MotionValidity(station, 0, margin=PLANNER_MARGIN)
    calls = []
    real = stepped.checker.min_distance
    stepped.checker.min_distance = lambda q: calls.append(q) or real(q)
    segments = random_segments(station, 0, 200, seed=9)
    assert [compiled.segment_clear(q0, q1) for q0, q1 in segments] == [stepped.segment_clear(q0, q1)
                                                                        for q0, q1 in segments]
    assert compiled.n_checks == stepped.n_checks and len(calls) > 200
