"""The thesis curvature scenario (§4.4, Figure 4.8, Figure A.1): the direct motion passes the tool support under
the node fixed in mid-air and bends the cable sharply, Home and Weld do not, and the wear-aware planners lower the
peak curvature."""

import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import Trajectory, replay
from dresspack_gym.stations.collision import RobotCollisionChecker
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import make_task

# the direct motion's peak must clear kappa0 by this factor (measured 12.39 1/m = 1.55 kappa0)
SHARP = 1.4
# Home and Weld must stay below this fraction of kappa0 (measured 5.24 and 3.47 1/m: 0.66 and 0.43 kappa0)
GENTLE = 0.8
# the wear-aware planners' peak must be at least this fraction lower than the direct one (measured: thesis-local
# -30 %, ompl-wear -26 %; the thesis -62 %)
LOWER_BY = 0.2


@pytest.fixture(scope="module")
def station():
    return Station(load_station("thesis_curvature"))


@pytest.fixture(scope="module")
def task(station):
    return make_task(station, 0, RobotCollisionChecker(station, 0).collides)


@pytest.fixture(scope="module")
def direct(station, task):
    """The direct (joint-space straight) Home -> Weld -> Home motion, replayed."""
    traj = Trajectory(np.array([task.start, task.goals[0], task.end]), (1, 2))
    return replay(CableSimulator(station), traj, record_states=False)


def test_the_direct_motion_passes_the_tool_support_right_under_the_node(station, task):
    support = next(nd for nd in station.config.robots[0].dresspack.nodes if nd.body == "link6")
    node = next(nd for nd in station.config.robots[0].dresspack.nodes if nd.body == "world")
    assert node.direction == pytest.approx((0, 0, -1)) and support.arc_length > node.arc_length
    kin = station.robots[0].kinematics
    path = []
    for s in np.linspace(0, 1, 201):
        frame = kin.link_frames(task.start + s * (task.goals[0] - task.start))[-1]
        path.append(frame[:3, :3] @ np.asarray(support.pos) + frame[:3, 3])
    path = np.array(path)
    horizontal = np.linalg.norm((path - node.pos)[:, :2], axis=1)
    i = int(np.argmin(horizontal))
    assert horizontal[i] < 0.05  # the tool support passes right under the node...
    assert 0.1 <= node.pos[2] - path[i, 2] <= 0.3  # ...0.1-0.3 m below it, partway along the motion
    assert 0.3 < i / 200 < 0.7
    length = station.config.robots[0].dresspack.length
    at_home, at_weld = np.linalg.norm(path[[0, -1]] - node.pos, axis=1)
    assert at_home == pytest.approx(at_weld, abs=0.05) and 0.6 * length < at_home < 0.8 * length


def test_the_direct_motion_bends_the_cable_sharply_midway_not_at_home_or_weld(station, direct):
    kappa0 = station.config.wear_cost.curvature_threshold
    assert direct.unconverged_stops == 0  # the curvature at Home and Weld is read off settled, proven equilibria
    k, t = direct.measures["curvature"], direct.time
    assert k.max() > SHARP * kappa0
    weld = int(np.searchsorted(t, direct.stop_times[0]))
    assert k[0] < GENTLE * kappa0 and k[weld] < GENTLE * kappa0 and k[-1] < GENTLE * kappa0
    assert 0 < t[int(np.argmax(k))] < direct.stop_times[0]  # on the way to the weld, not at a stop


@pytest.mark.parametrize("planner", ["thesis-local", pytest.param("ompl-wear", marks=pytest.mark.slow)])
def test_wear_aware_planners_lower_the_peak_curvature(station, direct, planner):
    pytest.importorskip("ompl.base")
    from dresspack.agents.planners.registry import plan_station

    unaware = plan_station(station, "ompl", seed=0).replay.measures["curvature"].max()
    assert unaware == pytest.approx(direct.measures["curvature"].max(), rel=1e-9)  # ompl returns the direct motion
    aware_replay = plan_station(station, planner, seed=0).replay
    assert aware_replay.unconverged_stops == 0
    aware = aware_replay.measures["curvature"].max()
    assert aware < (1 - LOWER_BY) * unaware
