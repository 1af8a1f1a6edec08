"""Physics benchmark: raw ``mj_step`` throughput and the cost of a quasi-static joint move."""

from __future__ import annotations

import time

import mujoco
import numpy as np


def physics_benchmark(station_ref: str = "default", repeats: int = 3, raw_steps: int = 2000) -> dict:
    """Raw steps/s of the station model, and wall time of a 90 deg j1 move with settling (best of repeats)."""
    from .loading import load_station
    from .simulation import CableSimulator
    from .station import Station

    station = Station(load_station(station_ref))
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
    return {
        "station": station.config.name,
        "timestep_s": m.opt.timestep,
        "cable_segments": [c.vertex_bodies.size - 1 for c in station.cables],
        "nv": int(m.nv),
        "raw_mj_step_steps_per_s": round(raw_rate, 1),
        "move90_wall_s": round(best_move, 4),
        "move90_simulated_s": round(steps_done * m.opt.timestep, 3),
        "move90_steps": steps_done,
        "move90_steps_per_s": round(steps_done / best_move, 1),
        "move90_vs_raw_ratio": round(steps_done / best_move / raw_rate, 3),
    }


def restrictions_benchmark(station_ref: str = "default", repeats: int = 3, batch: int = 100_000) -> dict:
    """Cost of the joint restrictions per configuration, batched and one at a time (best of repeats)."""
    from .loading import load_station

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
