"""Benchmarks of this machine: the cable engines' replays, raw ``mj_step`` throughput, restrictions, env steps."""

from __future__ import annotations

import time

import mujoco
import numpy as np


def physics_benchmark(station_ref: str = "default", repeats: int = 3, raw_steps: int = 2000,
                      engine: str = "dynamic", segments: int | None = None) -> dict:
    """On ``engine`` (physics.profiles.ENGINES), its cables at ``segments`` (default: the station's own): the wall
    seconds per second of motion over fixed weld-cycle replays (``replay_wall_per_motion_s``, the field both engines
    compare by) and the engine's own figures (MuJoCo: raw steps/s, a settled 90 deg move, settling; the rod engine:
    equilibria/s, a sample's time by part, and MuJoCo's replay of the same cycles as the station stands, timed in
    the same run, with the ratio of the two)."""
    from dataclasses import replace

    from ..fields import check_choice
    from ..io.loading import load_station
    from ..physics.profiles import ENGINES
    from ..stations.station import Station

    check_choice("physics", engine, list(ENGINES))
    config = load_station(station_ref)
    reference = Station(config)
    if segments is not None:
        config = replace(config, robots=tuple(replace(r, dresspack=replace(r.dresspack, segments=segments))
                                              for r in config.robots))
    station = Station(config) if segments is not None else reference
    common = {"station": station.config.name, "engine": engine,
              "cable_segments": [c.n_vertices - 1 for c in station.cables]}
    if engine == "fast":
        return {**common, **_replay_benchmark(station, engine, repeats, against=reference),
                **_rod_benchmark(station, repeats)}
    return {**common, **_replay_benchmark(station, engine, repeats), **_mujoco_benchmark(station, repeats, raw_steps)}


# Fixed weld cycles of the replay benchmark: Home -> a random via -> a named weld -> Home, drawn from this seed.
REPLAY_PATHS, REPLAY_SEED = 5, 0


def _replay_benchmark(station, engine: str, repeats: int, against=None) -> dict:
    """Wall seconds per second of motion replaying REPLAY_PATHS fixed weld cycles (best of repeats), after one
    warm-up replay (the rod engine's compiled kernels load from disk on first use). With ``against`` (a station),
    MuJoCo replays the same cycles on it in turn with the engine's, so both see the same load, and the ratio of
    the two is reported."""
    from ..physics.profiles import make_simulator, random_paths
    from ..physics.trajectory import replay
    from ..stations.validity import MotionValidity

    paths = random_paths(station, 0, MotionValidity(station, 0, 0.005), REPLAY_PATHS, seed=REPLAY_SEED)
    sims = {"engine": make_simulator(station, engine)}
    if against is not None:
        sims["dynamic"] = make_simulator(against, "dynamic")
    for sim in sims.values():
        replay(sim, paths[0], record_states=False)
    walls = {k: [] for k in sims}
    motion = 0.0
    for _ in range(repeats):
        for k, sim in sims.items():
            t0 = time.perf_counter()
            motion = sum(replay(sim, p, record_states=False).cycle_time for p in paths)
            walls[k].append(time.perf_counter() - t0)
    out = {"replay_paths": REPLAY_PATHS, "replay_motion_s": round(motion, 3),
           "replay_wall_per_motion_s": round(min(walls["engine"]) / motion, 5)}
    if against is not None:
        out["dynamic_segments"] = [c.n_vertices - 1 for c in against.cables]
        out["dynamic_replay_wall_per_motion_s"] = round(min(walls["dynamic"]) / motion, 5)
        out["replay_speedup_vs_dynamic"] = round(min(walls["dynamic"]) / min(walls["engine"]), 2)
    return out


def _rod_benchmark(station, repeats: int) -> dict:
    """The rod engine: equilibria/s from the Home reference shape, and one sample's wall time split into the
    solves (sub-steps included) and the measures, over a 90 deg j1 move."""
    from ..rod.simulator import RodSimulator

    sim = RodSimulator(station)
    settles = []
    for _ in range(repeats):
        sim.reset(settle=False)
        t0 = time.perf_counter()
        sim.settle()
        settles.append(time.perf_counter() - t0)
    target = station.home.copy()
    target[0, 0] += np.pi / 2
    solve, measure, samples = [], [], 0
    for _ in range(repeats):
        sim.reset()
        t_solve, t_measure, samples = sim.timed_move(target)
        solve.append(t_solve)
        measure.append(t_measure)
    return {"equilibria_per_s": round(1.0 / min(settles), 1),
            "settle_converged": sim.last_settle.converged,
            "sample_solve_us": round(min(solve) / samples * 1e6, 1),
            "sample_measures_us": round(min(measure) / samples * 1e6, 1)}


def _mujoco_benchmark(station, repeats: int, raw_steps: int) -> dict:
    """Raw steps/s of the station model, and wall time of a 90 deg j1 move with settling (best of repeats)."""
    from ..physics.simulation import CableSimulator

    sim = CableSimulator(station)
    home_state = sim.get_state()
    m, d = station.model, sim.data
    raw = []
    for _ in range(repeats):
        sim.set_state(home_state)
        t0 = time.perf_counter()
        for _ in range(raw_steps):
            mujoco.mj_step(m, d)
        raw.append(raw_steps / (time.perf_counter() - t0))
    target = station.home.copy()
    target[0, 0] += np.pi / 2
    moves, steps_done = [], 0
    for _ in range(repeats):
        sim.set_state(home_state)
        t0 = time.perf_counter()
        time0 = d.time
        sim.move_to(target)
        moves.append(time.perf_counter() - t0)
        steps_done = int(round((d.time - time0) / m.opt.timestep))
    best_move = min(moves)
    raw_rate = max(raw)
    settle = _settle_benchmark(sim, repeats)
    return {
        "timestep_s": m.opt.timestep,
        "nv": int(m.nv),
        "raw_mj_step_steps_per_s": round(raw_rate, 1),
        "move90_wall_s": round(best_move, 4),
        "move90_simulated_s": round(steps_done * m.opt.timestep, 3),
        "move90_steps": steps_done,
        "move90_steps_per_s": round(steps_done / best_move, 1),
        "move90_vs_raw_ratio": round(steps_done / best_move / raw_rate, 3),
        **settle,
    }


def _settle_benchmark(sim, repeats: int) -> dict:
    """Time to reach the equilibrium residual from a disturbed shape (the Home reference curve, not yet
    relaxed), against a fixed 1.5 s of stepping at the motion timestep (a time-based settle), best of repeats."""
    import mujoco as mj

    m, d = sim.model, sim.data
    to_eq, fixed, result = [], [], None
    for _ in range(repeats):
        sim.reset(settle=False)
        t0 = time.perf_counter()
        result = sim.settle()
        to_eq.append(time.perf_counter() - t0)
        sim.reset(settle=False)
        t0 = time.perf_counter()
        for _ in range(int(round(1.5 / m.opt.timestep))):
            mj.mj_step(m, d)
        fixed.append(time.perf_counter() - t0)
    return {
        "settle_to_equilibrium_wall_s": round(min(to_eq), 4),
        "settle_to_equilibrium_simulated_s": round(result.time, 3),
        "settle_converged": result.converged,
        "settle_force_residual": round(result.equilibrium.force_residual, 5),
        "fixed_1p5s_settle_wall_s": round(min(fixed), 4),
        "settle_vs_fixed_time_ratio": round(min(to_eq) / min(fixed), 3),
    }


def restrictions_benchmark(station_ref: str = "default", repeats: int = 3, batch: int = 100_000) -> dict:
    """Cost of the joint restrictions per configuration, batched and one at a time (best of repeats)."""
    from ..io.loading import load_station

    cfg = load_station(station_ref)
    rules = cfg.robots[0].restrictions
    lim = cfg.robots[0].robot.joint_limits
    q = np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], size=(batch, 6))
    batched, single = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        rules.allowed(q)
        batched.append((time.perf_counter() - t0) / batch)
        t0 = time.perf_counter()
        for qi in q[:2000]:
            rules.allowed(qi)
        single.append((time.perf_counter() - t0) / 2000)
    return {
        "station": cfg.name,
        "n_rules": len(rules),
        "batched_us_per_config": round(min(batched) * 1e6, 4),
        "single_call_us": round(min(single) * 1e6, 2),
        "allowed_fraction_random": round(float(rules.allowed(q).mean()), 4),
    }


def collision_benchmark(station_ref: str = "default", repeats: int = 3, n_configs: int = 2000) -> dict:
    """Cost of one robot's clearance queries (what every planner's motion check calls), as ratios to posing the
    robot (MuJoCo kinematics of the whole model) measured in the same run; configurations near Home, where
    planners spend their queries: one after another at random (each query on its own), and the steps of
    conservative advancement along segments (each query near the last)."""
    import mujoco

    from ..io.loading import load_station
    from ..stations.collision import RobotCollisionChecker
    from ..stations.station import Station

    station = Station(load_station(station_ref))
    checker = RobotCollisionChecker(station, 0, margin=0.01)
    qs = station.home[0] + np.random.default_rng(0).uniform(-0.5, 0.5, size=(n_configs, 6))
    calls = {"kinematics": lambda q: mujoco.mj_kinematics(checker.model, checker.data),
             "pose_and_bounds": checker._pose, "min_distance": checker.min_distance, "collides": checker.collides}
    best = {}
    for _ in range(repeats):
        for name, call in calls.items():
            t0 = time.perf_counter()
            for q in qs:
                call(q)
            best[name] = min(best.get(name, np.inf), (time.perf_counter() - t0) / n_configs)
    base = best["kinematics"]
    return {
        "station": station.config.name,
        "pairs": len(checker.pairs),
        "kinematics_us": round(best["kinematics"] * 1e6, 2),
        **{f"{k}_vs_kinematics": round(v / base, 2) for k, v in best.items() if k != "kinematics"},
        "collides_fraction": round(float(np.mean([checker.collides(q) for q in qs])), 4),
        **_stepping_benchmark(station, repeats, base),
        **_segments_benchmark(station, repeats),
    }


def _stepping_benchmark(station, repeats: int, kinematics_s: float, n_segments: int = 300) -> dict:
    """What the planners' motion checks do: conservative advancement along segments that mostly go on from the
    last one's end (a path, a tree's branch); one query's cost there as a ratio to posing the robot, and the
    queries a segment takes. Each repeat on a new MotionValidity (one answers a segment it checked from memory)."""
    from ..stations.validity import PLANNER_MARGIN, MotionValidity

    rng = np.random.default_rng(2)
    lim = station.config.robots[0].robot.joint_limits
    home = station.home[0]
    segments, q = [], home
    for i in range(n_segments):
        if i % 10 == 0:  # a jump to elsewhere near Home
            q = np.clip(home + rng.uniform(-1.0, 1.0, 6), lim[:, 0], lim[:, 1])
        q1 = np.clip(q + rng.normal(0.0, 0.3, 6), lim[:, 0], lim[:, 1])
        segments.append((q, q1))
        q = q1
    best, validity = np.inf, None
    for _ in range(repeats):
        validity = MotionValidity(station, 0, margin=PLANNER_MARGIN)
        t0 = time.perf_counter()
        for a, b in segments:
            validity.segment_clear(a, b)
        best = min(best, (time.perf_counter() - t0) / validity.n_checks)
    return {"stepping_query_vs_kinematics": round(best / kinematics_s, 2),
            "stepping_queries_per_segment": round(validity.n_checks / n_segments, 1)}


def _segments_benchmark(station, repeats: int, n_starts: int = 8, n_segments: int = 48) -> dict:
    """What the env's masks do: dozens of segments from one configuration checked one by one
    (``segment_clear``) or in lockstep (``segments_clear``), the same answers; best of repeats, each on a new
    MotionValidity (one answers a segment it checked from memory)."""
    from ..stations.validity import PLANNER_MARGIN, MotionValidity

    rng = np.random.default_rng(1)
    home = station.config.robots[0].home
    starts = [home + rng.uniform(-0.2, 0.2, 6) for _ in range(n_starts)]
    ends = [q + rng.uniform(-1.0, 1.0, size=(n_segments, 6)) for q in starts]
    one, lockstep = np.inf, np.inf
    for _ in range(repeats):
        validity = MotionValidity(station, 0, margin=PLANNER_MARGIN)
        t0 = time.perf_counter()
        alone = [[validity.segment_clear(q, e) for e in es] for q, es in zip(starts, ends)]
        t1 = time.perf_counter()
        together = [validity.segments_clear(q, es).tolist() for q, es in zip(starts, ends)]
        t2 = time.perf_counter()
        if alone != together:
            raise RuntimeError("segments_clear disagrees with segment_clear: a bug, please report it")
        one, lockstep = min(one, t1 - t0), min(lockstep, t2 - t1)
    return {"segments_one_by_one_ms_per_start": round(1e3 * one / n_starts, 2),
            "segments_lockstep_vs_one_by_one": round(one / lockstep, 2),
            "segments_clear_fraction": round(float(np.mean(together)), 3)}


def env_benchmark(station_ref: str = "default", repeats: int = 3, env_steps: int = 60) -> dict:
    """Env steps/s vs raw mj_step of the same model and the same physics steps, in one run.

    Every ``mj_step`` the env makes is timed (MuJoCo's step timer, which spans the simulator's resets), so ``raw_equivalent_steps_per_s`` (the env step rate if
    masks, measures, observations and Python cost nothing) uses the physics actually stepped: a moving
    cable in contact costs more per step than one at rest, which ``raw_resting_steps_per_s`` shows.
    ``ratio`` = env_steps_per_s / raw_equivalent_steps_per_s = the share of env time spent in mj_step.
    """
    from ..env.dresspack_env import DresspackEnv
    from ..physics.profiles import PROFILES

    envs = {name: DresspackEnv(station=station_ref, physics_profile=name) for name in PROFILES}
    rates = {name: _env_rate(e, repeats, env_steps) for name, e in envs.items()}  # in one run: fair ratios
    # the goal-conditioned training setup, as its shipped training config builds it (planner-like segments, welds
    # drawn on the parts, training profile, fallback vias); a step is a whole segment, so simulated motion
    # seconds per wall second compares the setups' work
    primitives = DresspackEnv(station=station_ref, **_training_env_kwargs("goal_conditioned"))
    prim_rate = _env_rate(primitives, repeats, max(1, env_steps // 3))
    env = envs["accurate"]
    m, d = env.station.model, env.sim.data
    best = rates["accurate"]
    env.reset(seed=0)
    state = env.sim.get_state()
    t0 = time.perf_counter()
    for _ in range(2000):
        mujoco.mj_step(m, d)
    resting = 2000 / (time.perf_counter() - t0)
    env.sim.set_state(state)
    env_rate, raw_rate, per_step, _ = best
    raw_equivalent = raw_rate / per_step
    return {
        "station": env.station.config.name,
        "env_steps_per_s": round(env_rate, 2),
        "physics_steps_per_env_step": round(per_step, 1),
        "raw_mj_step_steps_per_s": round(raw_rate, 1),
        "raw_equivalent_steps_per_s": round(raw_equivalent, 2),
        "ratio": round(env_rate / raw_equivalent, 3),
        "raw_resting_steps_per_s": round(resting, 1),
        "profiles_env_steps_per_s": {k: round(v[0], 2) for k, v in rates.items()},
        "training_vs_accurate": round(rates["training"][0] / rates["accurate"][0], 2),
        "coarse_step_vs_accurate": round(rates["coarse_step"][0] / rates["accurate"][0], 2),
        # the same cable on the rod engine (training) and on MuJoCo at an 8 ms step (coarse_step)
        "training_vs_coarse_step": round(rates["training"][0] / rates["coarse_step"][0], 2),
        "motion_s_per_s": {**{k: round(v[3], 2) for k, v in rates.items()},
                           "training_primitives": round(prim_rate[3], 2)},
        "primitives_env_steps_per_s": round(prim_rate[0], 2),
        "primitives_vs_accurate_motion": round(prim_rate[3] / rates["accurate"][3], 2),
    }


def _training_env_kwargs(name: str) -> dict:
    """The env kwargs of a shipped training config (configs/training/<name>.yaml), read here rather than
    restated, so the bench measures the setup that is trained."""
    from ..io.loading import read_yaml
    from ..shipped import find_shipped

    return dict(read_yaml(find_shipped(name, "training", "training config"), "training config")["env_kwargs"])


def _env_rate(env, repeats: int, env_steps: int):
    """The best of ``repeats`` runs of random masked steps: (env steps/s, mj_step steps/s, physics steps per env
    step, simulated motion seconds per wall second). Every run repeats the same episodes (same seeds, same
    actions), so the runs differ only in how long the machine took: a primitive step's motion ranges from a
    fraction of a second to several, and different draws per run made the motion rate swing by a third."""
    # MuJoCo's own mj_step timer (nothing global is patched); the rod engine makes no mj_step: NaN physics rates
    timer = env.sim.data.timer[mujoco.mjtTimer.mjTIMER_STEP] if env.sim.engine == "dynamic" else None
    best = None
    for _ in range(repeats):
        rng = np.random.default_rng(0)
        env.reset(seed=0)
        step_time, step_count = (timer.duration, timer.number) if timer is not None else (0.0, 0)
        t0 = time.perf_counter()
        motion = 0.0
        for _ in range(env_steps):
            masks = env.action_masks()
            _, _, term, trunc, info = env.step(int(rng.choice(np.flatnonzero(masks))))
            motion += info["step_time"]
            if term or trunc:
                env.reset()
        total = time.perf_counter() - t0
        n = timer.number - step_count if timer is not None else 0
        physics = n / (timer.duration - step_time) if n else float("nan")
        run = (env_steps / total, physics, n / env_steps, motion / total)
        best = run if best is None or run[0] > best[0] else best
    return best


def robustness_benchmark(station_ref: str = "default", repeats: int = 1, n_rows: int = 8,
                         grid_name: str = "thesis_67500") -> dict:
    """Configurations per second with 1 and 2 process workers on ``n_rows`` grid rows spread over the grid.

    Whole rows (the work units of the default "row" start), so both workers get equal work; the 1-worker
    run is in-process, and its MuJoCo step timer gives the share of the time spent in ``mj_step``.
    """
    import tempfile

    from ..io.loading import load_station, read_yaml
    from ..maps.robustness import runner
    from ..maps.robustness.algorithm import RobustnessSettings
    from ..maps.robustness.grid import RobustnessGrid
    from ..shipped import find_shipped

    grid = RobustnessGrid.from_dict(read_yaml(find_shipped(grid_name, "grids", "grid")))
    config = load_station(station_ref)
    settings = RobustnessSettings(engine="dynamic", cable_robot_contact=False)  # MuJoCo's step timer: its engine
    n_per_row = len(grid.j6)
    rows = np.linspace(0, len(grid) // n_per_row - 1, n_rows).round().astype(int)
    indices = (rows[:, None] * n_per_row + np.arange(n_per_row)).ravel()
    rates, step_share = {}, 0.0
    for workers in (1, 2):
        best = 0.0
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as out:
                t0 = time.perf_counter()
                runner.run_map(grid, config, out, settings, backend="process", workers=workers, progress=False,
                               indices=indices)
                wall = time.perf_counter() - t0
            best = max(best, len(indices) / wall)
            if workers == 1:
                timer = runner._WORKER.sim.data.timer[mujoco.mjtTimer.mjTIMER_STEP]
                step_share = timer.duration / wall
        rates[workers] = best
    return {
        "grid": grid.name,
        "configs_measured": len(indices),
        "configs_per_s_1_worker": round(rates[1], 3),
        "configs_per_s_2_workers": round(rates[2], 3),
        "speedup_1_to_2": round(rates[2] / rates[1], 3),
        "share_of_time_in_mj_step_1_worker": round(step_share, 3),
        "projected_full_grid_hours_2_workers": round(len(grid) / rates[2] / 3600, 2),
    }
