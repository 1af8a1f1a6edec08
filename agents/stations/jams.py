"""Jam handling: the leg behind each cable a station replay found jammed, and re-routing a leg that jammed its
cable (reseeded, then through the robot's Home, else blocked for the solver)."""

from __future__ import annotations

import numpy as np

from .legs import LegBook
from .legs_up_front import move_key, plan_leg
from .plan import StationPlan

# Re-routes a leg that jammed its cable gets before it counts as blocked: the leg planner with another seed (a via
# point or OMPL route it had not drawn), then through the robot's Home (where the dresspack is laid out to hang
# freely)
REROUTES = ("reseeded", "via_home")
RESEED = 7919  # seed offset of a re-routed leg's plan (any fixed number: another stream, deterministically)


def jammed_legs(plan: StationPlan, qs: np.ndarray) -> list[tuple[int, int, int]]:
    """(robot, from node, to node) of the leg behind each jammed cable in ``plan.replay``: the motion under way
    when its tension first passed the jam strain, or, if the robot stood still then (welding, waiting), the motion
    that brought it there (the cable was wedged on the way and stays wedged). A robot without welds is left out:
    it never moves, so its cable was pinned by another robot."""
    replay = plan.replay
    out = []
    for r in replay.jammed():
        if not plan.assignment.routes[r]:  # a robot that stays Home has no leg to re-route (another pinned it)
            continue
        first = int(np.argmax(replay.measures["tension"][:, r] > replay.jam_tension[r]))
        t = float(replay.time[first])
        s = plan.schedule.robot(r)
        k = int(np.clip(np.searchsorted(s.leg_start, t, side="right") - 1, 0, len(s.legs) - 1))
        route = plan.assignment.routes[r]
        path = [r, *route, r]
        out.append((r, path[k], path[k + 1]))
    return out


def reroute(legs: LegBook, homes: np.ndarray, names: list[str], robot: int, i: int, j: int, qs: np.ndarray,
            stops: list[str], why: str, weld_time: float) -> dict:
    """Replace the leg i -> j of ``robot`` after it jammed the cable: the next of :data:`REROUTES` that applies
    and does not jam the cable itself (run alone), else mark it blocked (the solver then avoids it). ``homes``:
    the robots' Homes; ``names``: the robots'; ``stops`` names every node (the summary's words); ``weld_time`` is
    the weld at j (0 at a Home). Returns what was done, also logged in ``legs.log``."""
    key = move_key(robot, qs[i], qs[j])
    old = legs.rerouted.get(key, legs.paths.get(key))
    done = "blocked"
    legs.rerouted[key] = None
    for used, how in enumerate(REROUTES[legs.reroutes.get(key, 0):], start=legs.reroutes.get(key, 0) + 1):
        legs.reroutes[key] = used
        leg = _alternative(legs.planners[robot], homes[robot], how, robot, qs[i], qs[j], old)
        if leg is not None and not legs.run(robot, leg, weld_time).jammed:
            legs.rerouted[key], done = leg, how
            break
    entry = {"robot": names[robot], "from": stops[i], "to": stops[j], "now": done, "why": why}
    legs.log.append(entry)
    return entry


def _alternative(planner, home: np.ndarray, how: str, robot: int, qa: np.ndarray, qb: np.ndarray,
                 old) -> np.ndarray | None:
    if how == "reseeded":
        if old is not None and len(old) == 2:  # a straight move: any seed returns the same line
            return None
        seed, planner.seed = planner.seed, planner.seed + RESEED
        try:
            return plan_leg(planner, robot, qa, qb)
        finally:
            planner.seed = seed
    if np.array_equal(qa, home) or np.array_equal(qb, home):  # via_home: the leg already ends at Home
        return None
    if planner.validity.segment_valid(qa, home) and planner.validity.segment_valid(home, qb):
        return np.array([qa, home, qb])
    return None
