"""``dresspack inspect``: build a station, settle its cable at Home and report robot, cable and wear measures."""

from __future__ import annotations

import json

import numpy as np

from .args import add_station_argument
from .common import load_simulated


def _measure_report(sim) -> dict:
    from ..physics.wear_cost import normalized_wear_cost, wear_cost

    m = sim.measures()
    cfg = sim.station.config.wear_cost
    cost = wear_cost(m, cfg)
    norm = normalized_wear_cost(m, cfg)
    return {
        "max_curvature": m.max_curvature,
        "max_tension": m.max_tension,
        "min_clearance": m.min_clearance,
        "max_twist_rate": m.max_twist_rate,
        "cost": cost.total,
        "cost_terms": cost.terms(),
        "normalized_cost": norm.total,
        "normalized_cost_terms": norm.terms(),
        "curvature_at": m.curvature_at,
        "tension_at": m.tension_at,
        "clearance_at": m.clearance_at,
        "nearest_obstacle": m.nearest_obstacle,
        "total_twist": m.total_twist,
        "max_compression": m.max_compression,
        "max_node_force": m.max_node_force,
        "max_node_torque": m.max_node_torque,
        "max_damage_rate": m.max_damage_rate,
        "damage_at": m.damage_at,
        "nodes": _node_report(sim),
        "equilibrium": _equilibrium_report(sim),
    }


def _node_report(sim) -> dict:
    """Per node: the force [N] and torque [N m] it carries, in its frame (x = cable direction of a clamp)."""
    out = {}
    for i, cable in enumerate(sim.station.cables):
        forces, torques = sim.node_loads(i)
        for att, f, t in zip(cable.attachments, forces, torques):
            out[f"{cable.robot}/{att.node.name}"] = {"force": [round(float(v), 6) for v in f],
                                                     "torque": [round(float(v), 6) for v in t]}
    return out


def _equilibrium_report(sim) -> dict:
    """The last settle's equilibrium residual (a settled shape carries its proof)."""
    r = sim.last_settle
    eq = r.equilibrium if r is not None else sim.equilibrium()
    return {"converged": eq.converged, "force_residual": eq.force_residual, "torque_residual": eq.torque_residual,
            "kinetic_energy": eq.kinetic_energy, "settle_time": r.time if r is not None else None}


def cmd_inspect(args) -> int:
    station, sim = load_simulated(args.station)
    report = _measure_report(sim)
    cfg = station.config
    unusable = _unusable(report["equilibrium"], cfg)
    if args.json:
        report["station"] = cfg.name
        report["weld_points"] = {k: int(len(v)) for k, v in station.weld_configurations.items()}
        report["usable"] = unusable is None
        if unusable:
            report["unusable"] = unusable
        print(json.dumps(report, indent=2))
        return 0 if unusable is None else 1
    print(f"Station {cfg.name!r}: {cfg.description}")
    for r, idx in zip(cfg.robots, station.robots):
        k = r.robot.kinematics
        if k is not None:
            reach = f"wrist reach {k.a1 + k.a2 + float(np.hypot(k.d4, k.a3)):.3f} m"
        else:  # a general joint chain: the sum of its link offsets bounds the reach
            c = r.robot.chain
            links = sum(np.linalg.norm(o) for o in c.origins[1:]) + np.linalg.norm(c.flange_pos)
            reach = f"joint chain, numeric IK, links {links:.3f} m"
        dp = r.dresspack
        print(f"\nRobot {r.name!r}: {r.robot.name} ({reach}) at {r.base_pos}, yaw "
              f"{np.degrees(r.base_yaw):.0f} deg\n  source: {r.robot.source}")
        print(f"  Home [deg]: {np.round(np.degrees(r.home), 1).tolist()}")
        print(f"  Dresspack {dp.name!r}: L={dp.length} m, r={dp.radius} m, rho={dp.linear_density} kg/m, "
              f"EI={dp.bending_stiffness} N m^2, GJ={dp.torsional_stiffness} N m^2, EA={dp.tensile_stiffness} N")
        print(f"    MuJoCo DER: {dp.segments} segments of {dp.segment_length * 1000:.1f} mm, "
              f"young={dp.young_modulus:.4g} Pa, shear={dp.shear_modulus:.4g} Pa, edges stretch with EA")
        for n in dp.nodes:
            kind = "clamp" if n.direction is not None else "ring"
            print(f"    node {n.name!r}: {kind} on {n.body} at {n.pos} (arc {n.arc_length:.3f} m)")
        if dp.free_end:
            print("    free hanging end")
    print(f"\nObstacles: {len(cfg.obstacles)}" + (" + floor" if cfg.floor else ""))
    print(f"Weld points: {len(cfg.weld_points)}")
    for w in cfg.weld_points:
        reach = station.unreachable_welds.get(w.name) or \
            f"{len(station.weld_configurations[w.name])} IK solutions within limits"
        print(f"  {w.name}: pos {w.pos}, approach {[round(float(a), 3) for a in w.approach]}, {reach}")
    print("\nSettled at Home:")
    print(f"  max curvature  {report['max_curvature']:8.3f} 1/m   (at {report['curvature_at']:.2f} m along the cable)")
    print(f"  max tension    {report['max_tension']:8.3f} N     (at {report['tension_at']:.2f} m)")
    print(f"  min clearance  {report['min_clearance']:8.3f} m     (to {report['nearest_obstacle'] or '-'})")
    print(f"  max twist rate {report['max_twist_rate']:8.3f} rad/m (total twist between clamps "
          f"{report['total_twist']:.3f} rad)")
    for name, load in report["nodes"].items():
        f, t = np.array(load["force"]), np.array(load["torque"])
        print(f"  node {name}: force {np.linalg.norm(f):7.2f} N (axial {f[0]:7.2f}), "
              f"torque {np.linalg.norm(t):6.3f} N m (twist {t[0]:6.3f})")
    print(f"  damage rate    {report['max_damage_rate']:8.3f} /s    (at {report['damage_at']:.2f} m; dresspack "
          f"damage weights)")
    eq = report["equilibrium"]
    print(f"  equilibrium: {'converged' if eq['converged'] else 'NOT CONVERGED'} (force residual "
          f"{eq['force_residual']:.4f} of a vertex weight, kinetic energy {eq['kinetic_energy']:.2e} J)")
    terms = report["cost_terms"]
    print(f"  wear cost (4.10) {report['cost']:.4f} = curvature {terms['curvature']:.4f} + tension "
          f"{terms['tension']:.4f} + distance {terms['distance']:.4f} + twist {terms['twist']:.4f}; "
          f"normalized {report['normalized_cost']:.4f}")
    if unusable:
        print(f"\nTHE STATION CANNOT BE USED: {unusable}")
        return 1
    return 0



# [vertex weights] an unbalanced force this large at Home is no near-equilibrium: the cable is not at rest in any
# meaningful sense (numerically stiff or over-constrained), and every measure and plan of the station is noise
UNUSABLE_RESIDUAL = 1.0


def _unusable(eq: dict, cfg) -> str | None:
    """Why the station cannot be used (its cable does not settle at Home at all), or None."""
    if eq["converged"] or eq["force_residual"] <= UNUSABLE_RESIDUAL:
        return None
    cables = "; ".join(f"{r.name}: EI={r.dresspack.bending_stiffness:g} N m^2, GJ={r.dresspack.torsional_stiffness:g} "
                       f"N m^2, EA={r.dresspack.tensile_stiffness:g} N, L={r.dresspack.length:g} m" for r in cfg.robots)
    return (f"the cable does not settle at Home (force residual {eq['force_residual']:.3g} vertex weights, "
            f"settled means <= {cfg.simulation.equilibrium_tolerance:g}): its dresspack is too stiff for the "
            f"simulation step or stretched between its nodes ({cables}); lower the stiffness or the timestep")


def add_inspect(sub) -> None:
    """``dresspack inspect``."""
    q = sub.add_parser("inspect", help="build a station, settle at Home and print robot, cable and wear measures")
    add_station_argument(q, deprecated_positional=True)
    q.add_argument("--json", action="store_true", help="print one JSON object")
    q.set_defaults(func=cmd_inspect)
