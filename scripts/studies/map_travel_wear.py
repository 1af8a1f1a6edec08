"""Could the settled-shape wear map stand in for the cable simulation while a policy trains? Ranks the goal-conditioned
policy's own weld cycles by ∫C dt three ways: the accurate replay (what the evaluation reports), the training env's
coarse_step simulation (what the policy is trained on today) and the wear map's state cost integrated over the same
samples (a candidate training reward with no cable physics between the welds), and times the map against the
simulation per motion second.

    .venv/bin/dresspack wear-map --station default --samples 2000 --out runs/maps/default_2k.npz     # 3 min
    .venv/bin/dresspack wear-map --station default --samples 16000 --out runs/maps/default_16k.npz   # ~30 min
    PYTHONPATH=. .venv/bin/python scripts/studies/map_travel_wear.py --map runs/maps/default_2k.npz \
        --map runs/maps/default_16k.npz --episodes 40 --out docs/data/map_travel_wear.json

Each map is reported under its file's stem. The weld cycles are the shipped
goal-conditioned policy's on episodes of its own task distribution (seeds 31000 + k, apart from the training,
callback, select-model, self-imitate and evaluation seeds): the most probable actions on even k, sampled on odd k (a
wider spread of wear). The issue's bar for a cheaper training profile is Spearman >= 0.9 against the accurate one.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from dresspack.agents.learned.policy import PolicyAgent, resolve_policy

from dresspack_gym.env.dresspack_env import DresspackEnv
from dresspack_gym.io.loading import load_station
from dresspack_gym.maps.map_cost import MapStateCost
from dresspack_gym.maps.wear_map import load_wear_map
from dresspack_gym.physics.profiles import spearman
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import Trajectory, replay
from dresspack_gym.stations.station import Station

FIRST_SEED = 31000


def policy_cycles(policy: str, episodes: int) -> list[dict]:
    """The policy's finished weld cycles: waypoints, weld stops and the training env's own ∫C dt."""
    model_path, config = resolve_policy(policy)
    env = DresspackEnv(station="default", **dict(config["env_kwargs"]))
    agent = PolicyAgent(model_path)
    cycles = []
    for k in range(episodes):
        seed = FIRST_SEED + k
        agent.reset(seed)
        obs, info = env.reset(seed=seed)
        waypoints, stops, wear, done = [env.q.copy()], [], 0.0, False
        while not done:
            action = agent.predict(obs, env.action_masks(), deterministic=k % 2 == 0)
            reached = info.get("goals_reached", 0)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
            wear += info["integral_cost"]
            waypoints += [q for q in info["moved_through"] if not np.allclose(q, waypoints[-1], atol=1e-12)]
            if info["goals_reached"] > reached:
                stops.append(len(waypoints) - 1)
        if info["is_success"]:
            cycles.append({"seed": seed, "trajectory": Trajectory(np.array(waypoints), tuple(stops)),
                           "training_env": wear})
    return cycles


def worst_cycles(station, cycles: list[dict], named_map, count: int, every: int) -> list[dict]:
    """Where the map goes wrong: on the ``count`` cycles whose map ∫C falls furthest below the accurate one, each
    cost term integrated both ways, and the mean cost rate at every ``every``-th sample three ways: the accurate
    replay, the cable settled afresh at that configuration (the shape a map sample holds; how many of those settles
    reached the equilibrium residual, and the largest residual, are in the row) and the map."""
    from dresspack_gym.physics.wear_cost import cost_function

    name, cost = named_map
    cost_fn, cfg = cost_function("thesis"), station.config.wear_cost
    sim, settle_sim = CableSimulator(station), CableSimulator(station)
    rows = []
    for c in sorted(cycles, key=lambda c: c[name] / c["accurate"])[:count]:
        r = replay(sim, c["trajectory"], record_states=False)
        terms: dict[str, list[float]] = {}
        for q in r.q:
            for k, v in cost.terms(q).items():
                terms.setdefault(k, []).append(v)
        picked = np.arange(0, len(r.q), every)
        settled, residuals = [], []
        for j in picked:
            settle_sim.reset(r.q[j][None])
            eq = settle_sim.settle().equilibrium  # each settle's residual is reported with the row, converged or not
            residuals.append((eq.converged, eq.force_residual, eq.torque_residual))
            settled.append(cost_fn(settle_sim.measures(), cfg).total)
        rows.append({"seed": c["seed"], "map": name, "accurate": round(c["accurate"], 2), "map_cost": round(c[name], 2),
                     "accurate_terms": {k: round(float(np.trapezoid(v, r.time)), 2) for k, v in r.cost_terms.items()},
                     "map_terms": {k: round(float(np.trapezoid(np.array(v), r.time)), 2) for k, v in terms.items()},
                     "mean_rate_at_samples": {"accurate": round(float(r.cost[picked].mean()), 2),
                                              "settled_afresh": round(float(np.mean(settled)), 2),
                                              "map": round(float(np.mean([cost.cost(r.q[j]) for j in picked])), 2)},
                     "settled_afresh_converged": f"{sum(c for c, _, _ in residuals)} of {len(residuals)}",
                     "settled_afresh_max_residual": {"force": round(max(f for _, f, _ in residuals), 4),
                                                     "torque": round(max(t for _, _, t in residuals), 4)}})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--map", action="append", required=True, help="a wear map of the default station (.npz)")
    parser.add_argument("--policy", default="goal_conditioned")
    parser.add_argument("--episodes", type=int, default=24)
    parser.add_argument("--worst", type=int, default=3, help="cycles the last map misses most, looked at closely")
    parser.add_argument("--every", type=int, default=6, help="of those, every N-th sample settled afresh")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    config = load_station("default")
    station = Station(config)
    maps = {Path(m).stem: MapStateCost(station, load_wear_map(config, 0, m), 0) for m in args.map}
    cycles = policy_cycles(args.policy, args.episodes)
    sim = CableSimulator(station)
    sim_s, motion_s, map_s = 0.0, 0.0, dict.fromkeys(maps, 0.0)
    for c in cycles:
        t0 = time.perf_counter()
        r = replay(sim, c["trajectory"], record_states=False)
        sim_s += time.perf_counter() - t0
        motion_s += r.cycle_time
        c.update(accurate=r.integrated_cost(), settled=r.unconverged_stops == 0,
                 accurate_terms={k: float(np.trapezoid(v, r.time)) for k, v in r.cost_terms.items()})
        for name, cost in maps.items():
            t0 = time.perf_counter()
            rate = np.array([cost.cost(q) for q in r.q])
            map_s[name] += time.perf_counter() - t0
            c[name] = float(np.trapezoid(rate, r.time))
    acc = np.array([c["accurate"] for c in cycles])
    settled = np.array([c["settled"] for c in cycles])
    env_wear = np.array([c["training_env"] for c in cycles])
    out = {"policy": args.policy, "episodes": args.episodes, "finished": len(cycles),
           "settled_in_accurate_replay": int(settled.sum()), "motion_seconds": round(motion_s, 1),
           "accurate_sim_wall_s_per_motion_s": round(sim_s / motion_s, 4),
           "training_env_spearman": round(spearman(acc, env_wear), 3), "maps": {}}
    for name, cost in maps.items():
        v = np.array([c[name] for c in cycles])
        out["maps"][name] = {
            "samples": len(cost.map), "build_seconds": cost.map.info.get("build_seconds"),
            "spearman": round(spearman(acc, v), 3), "spearman_settled": round(spearman(acc[settled], v[settled]), 3),
            "median_ratio_to_accurate": round(float(np.median(v / acc)), 3),
            "wall_s_per_motion_s": round(map_s[name] / motion_s, 4),
            "speed_vs_accurate_sim": round(sim_s / map_s[name], 2)}
    out["worst_cycles"] = worst_cycles(station, cycles, list(maps.items())[-1], args.worst, args.every)
    out["cycles"] = [{k: (round(v, 2) if isinstance(v, float) else v) for k, v in c.items() if k != "trajectory"}
                     for c in cycles]
    print(json.dumps({k: v for k, v in out.items() if k != "cycles"}, indent=1))
    if args.out:
        args.out.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
