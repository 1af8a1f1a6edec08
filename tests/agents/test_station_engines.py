"""The station planner on either cable engine (``--physics``) and in worker processes (``--jobs``): the rod engine
follows a timed program as MuJoCo does, every simulation of a plan runs on the engine it names, and the plan does not
depend on the number of processes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace

import numpy as np
import pytest
from dresspack.agents.stations import StationPlanConfig, StationPlanner
from dresspack.agents.stations.replay import replay_plan
from helpers import NEAR_SIDE, as_a_shell_starts_it, near_side_yaml

from dresspack_gym.cli.main import main
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.multi.schedule import RobotSchedule, StationSchedule
from dresspack_gym.multi.tasks import make_station_task
from dresspack_gym.physics.profiles import DEFAULT_ENGINE, make_simulator
from dresspack_gym.robots.time_law import segment_durations
from dresspack_gym.stations.station import Station

# small budgets: what is compared is the plan's dependence on the engine and the processes, not its quality
SMALL = dict(kept_options=1, costed_options=2, cable_repairs=0, work=0.5, pair_solves=0, bound_work=0.5,
             exact_rounds=1)



@pytest.fixture(scope="module")
def two_robot_station() -> Station:
    """The near side of the shipped side-framing station: robots r1 and r2, four of their welds."""
    cfg = load_station("side_framing_4r")
    return Station(replace(cfg, robots=cfg.robots[:2], weld_points=tuple(w for w in cfg.weld_points
                                                                          if w.name in NEAR_SIDE)))


def _base_turn(station, duration: float):
    """Robot 0's Home with its base turned as far as the time law moves it in ``duration`` s, and its limits."""
    limits = station.config.robots[0].robot.joint_motion_limits.at_speed(station.config.simulation.speed_fraction)
    lo, hi = 0.0, 1.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if segment_durations(np.array([mid, 0, 0, 0, 0, 0]), limits) < duration else (lo, mid)
    target = station.home.copy()
    target[0, 0] += 0.5 * (lo + hi)
    return target, limits


def test_the_rod_engine_follows_a_timed_program_like_move_to(two_robot_station):
    """A timed program that is one straight segment of about 0.5 s, followed at most every 0.05 s, gives the
    cables move_to gives (its samples are the same robot poses); any duration is divided into equal samples."""
    st = two_robot_station
    target, limits = _base_turn(st, 0.5)
    a, b = make_simulator(st, "fast"), make_simulator(st, "fast")
    a.move_to(target, settle=False, record_every=0.05)
    program = StationSchedule((
        RobotSchedule.as_soon_as_possible(0, [], [np.array([st.home[0], target[0]])], limits, 0.0),
        RobotSchedule.as_soon_as_possible(1, [], [np.array([st.home[1], st.home[1]])], limits, 0.0)), st.home)
    times, samples = b.follow(program.at, program.makespan, record_every=0.05)
    assert b.motion_time == pytest.approx(a.motion_time, abs=1e-9)
    assert times[-1] == pytest.approx(program.makespan) and len(samples[-1]) == 2
    np.testing.assert_allclose(b.q, target, atol=1e-12)
    for r in range(2):
        np.testing.assert_allclose(b.cable_points(r), a.cable_points(r), atol=1e-6)
    c = make_simulator(st, "fast")
    times, _ = c.follow(program.at, 0.12, record_every=0.05)
    np.testing.assert_allclose(times, [0.04, 0.08, 0.12])
    with pytest.raises(ConfigError, match="record_every"):
        c.follow(program.at, 0.1, record_every=0.0)


@pytest.mark.parametrize("engine", ["dynamic", "fast"])
def test_every_simulation_of_a_plan_runs_on_its_engine(two_robot_station, engine):
    """The option costs, the legs' cable runs and the station replay run on the engine the config names, and the
    replay's summary says which."""
    planner = StationPlanner(two_robot_station, StationPlanConfig(physics=engine))
    assert StationPlanConfig().physics == DEFAULT_ENGINE
    assert planner.costs.alone(0).engine == engine
    task = make_station_task(two_robot_station, lambda r: None, ["r1_sill_1"])
    q = task.options["r1_sill_1"][0].q
    assert planner.costs.rate(0, q) > 0
    run = planner.legs.run(0, np.array([two_robot_station.home[0], q]), 0.2)
    assert run.wear > 0 and not run.jammed
    target, limits = _base_turn(two_robot_station, 0.3)
    plan = type("Plan", (), {})()  # replay_plan reads the schedule and keeps the replay
    plan.schedule = StationSchedule((
        RobotSchedule.as_soon_as_possible(0, [], [np.array([two_robot_station.home[0], target[0]])], limits, 0.0),
        RobotSchedule.as_soon_as_possible(1, [], [np.array([two_robot_station.home[1]] * 2)], limits, 0.0)),
        two_robot_station.home)
    replay = replay_plan(two_robot_station, plan, "thesis", lambda label, total: _Silent(), engine=engine)
    assert replay.engine == engine and replay.summary(["r1", "r2"])["engine"] == engine
    assert replay.time[-1] == pytest.approx(plan.schedule.makespan, abs=0.01)
    with pytest.raises(ConfigError, match=r"^physics: 'mujoco' is not one of the allowed values \['dynamic', 'fast'\]"):
        StationPlanConfig(physics="mujoco")
    with pytest.raises(ConfigError, match="^jobs"):
        StationPlanConfig(jobs=0)


class _Silent:
    def update(self, n=1):
        pass

    def close(self):
        pass


def test_option_costs_are_read_back_only_for_their_engine(two_robot_station, tmp_path):
    """A cost file names its engine and cost variant: another engine's rates are not read as this one's."""
    task = make_station_task(two_robot_station, lambda r: None, ["r1_sill_1"])
    q = task.options["r1_sill_1"][0].q
    fast = StationPlanner(two_robot_station, StationPlanConfig(physics="fast"))
    fast.costs.rate(0, q)
    fast.costs.save(tmp_path / "costs.json")
    assert json.loads((tmp_path / "costs.json").read_text())["engine"] == "fast"
    again = StationPlanner(two_robot_station, StationPlanConfig(physics="fast"))
    again.costs.load(tmp_path / "costs.json")
    assert again.costs.rates == fast.costs.rates
    other = StationPlanner(two_robot_station, StationPlanConfig(physics="dynamic"))
    other.costs.load(tmp_path / "costs.json")
    assert other.costs.rates == {}


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_workers_compute_what_the_planner_computes_itself(two_robot_station):
    """Option costs, straight moves, legs and leg runs from two worker processes equal this process's own."""
    config = StationPlanConfig(**SMALL, objective="time")
    task = make_station_task(two_robot_station, lambda r: None, ["r1_sill_1"])
    with StationPlanner(two_robot_station, replace(config, jobs=2)) as two:
        one = StationPlanner(two_robot_station, config)
        opts = [one.costs.choose(task, 2, 1), two.costs.choose(task, 2, 1)]
        assert [o.q.tobytes() for o in opts[0]] == [o.q.tobytes() for o in opts[1]]
        assert list(one.costs.rates.items()) == list(two.costs.rates.items())
        assert one.costs.unconverged == two.costs.unconverged
        one.legs.check_straight_moves(task, opts[0])
        two.legs.check_straight_moves(task, opts[1])
        assert one.legs.paths.keys() == two.legs.paths.keys() and one.legs.known == two.legs.known
        qs = np.vstack([task.homes, [o.q for o in opts[0]]])
        moves = [m for k, o in enumerate(opts[0], start=2) for m in ((o.robot, o.robot, k, 1.0),
                                                                      (o.robot, k, o.robot, 0.0))]
        two.legs.prefetch(moves, qs)
        assert not two.legs.known - one.legs.known  # prefetching does not make a leg known to the plan
        for r, i, j, weld in moves:
            a, b = one.legs.leg(r, i, j, qs), two.legs.leg(r, i, j, qs)
            np.testing.assert_array_equal(a, b)
            assert one.legs.run(r, a, weld) == two.legs.run(r, b, weld)
            assert one.legs.motion(r, a).duration == two.legs.motion(r, b).duration
        assert len(one.legs.runs) == len(two.legs.runs)


def _plan_files(out) -> dict:
    summary = json.loads((out / "summary.json").read_text())
    return {"summary": summary, "costs": (out / "option_costs.json").read_text()}


@pytest.mark.slow  # two station plans, each with both objectives and their replays (~60 s)
def test_station_plan_is_the_same_at_one_and_two_jobs(tmp_path, capsys):
    station = near_side_yaml(tmp_path)
    args = ["station-plan", "--station", str(station), "--physics", "fast", "--work", "0.5", "--pair-solves", "2",
            "--bound-work", "0.5", "--cable-repairs", "1", "--json"]
    assert main([*args, "--jobs", "1", "--out", str(tmp_path / "one")]) == 0
    assert main([*args, "--jobs", "2", "--out", str(tmp_path / "two")]) == 0
    capsys.readouterr()
    one, two = _plan_files(tmp_path / "one"), _plan_files(tmp_path / "two")
    assert one == two
    assert one["summary"]["time"]["replay"]["engine"] == "fast"
    assert "no contact between two robots' cables" in (tmp_path / "one" / "summary.md").read_text()


def test_station_plan_command_takes_an_engine_and_a_number_of_jobs(capsys):
    for flag, value in (("--physics", "mujoco"), ("--jobs", "0"), ("--jobs", "65")):
        with pytest.raises(SystemExit) as exit_:
            main(["station-plan", "--station", "side_framing_4r", flag, value])
        assert exit_.value.code == 2
        assert flag in capsys.readouterr().err


def test_ctrl_c_with_two_jobs_prints_one_line_and_exits_130(tmp_path):
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) while the two workers cost the options: one
    line, exit status 130; the workers, which ignore it, print nothing."""
    station = near_side_yaml(tmp_path)
    out = tmp_path / "plans"
    args = ["station-plan", "--station", str(station), "--jobs", "2", "--out", str(out)]
    proc = subprocess.Popen([sys.executable, "-m", "dresspack_gym.cli.main", *args], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True, preexec_fn=as_a_shell_starts_it)
    deadline = time.time() + 180
    while time.time() < deadline and proc.poll() is None and len(_children(proc.pid)) < 3:  # 2 workers, a tracker
        time.sleep(0.1)
    time.sleep(1.0)
    os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        raise
    lines = [s for s in err.replace("\r", "\n").splitlines() if s.strip() and ":" in s and "%|" not in s]
    assert proc.returncode == 130 and len(lines) == 1, err[-3000:]
    assert lines[0].startswith("interrupted: ") and lines[0].endswith("resume with: dresspack " + " ".join(args))


def _children(pid: int) -> list[str]:
    try:
        return open(f"/proc/{pid}/task/{pid}/children").read().split()
    except OSError:
        return []


def test_a_solve_leaves_ctrl_c_to_the_command():
    """CP-SAT does not take SIGINT over: after a solve it is still Python's (which raises KeyboardInterrupt, so
    the command prints its line and exits 130), not the default that ends the process without a word."""
    from dresspack.agents.stations.solver import RoutingProblem, solve

    travel = np.array([[[0.0, 1.0, 2.0], [1.0, 0.0, 1.0], [2.0, 1.0, 0.0]]])
    problem = RoutingProblem(travel, np.ones(3), np.array([0, 0, 0]), np.array([-1, 0, 1]), 1.0, 2)
    def disposition():  # SIGINT caught, ignored (as the kernel sees it: a C library's handler included)
        status = {line.split(":")[0]: line.split()[1] for line in open("/proc/self/status")
                  if line.startswith(("SigCgt", "SigIgn"))}
        return tuple(int(status[k], 16) >> (signal.SIGINT - 1) & 1 for k in ("SigCgt", "SigIgn"))

    before = disposition()
    solve(problem, "time", work=0.1)
    assert disposition() == before
