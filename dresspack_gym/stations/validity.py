"""Validity of robot configurations and straight joint-space motions: limits, joint restrictions, the dresspack's
reach, collisions."""

from __future__ import annotations

import math

import numpy as np

from ..cable.shape import node_vertices, node_world_points, span_slack
from ..robots.joint_limits import within_limits
from .collision import RobotCollisionChecker
from .station import LINK_INDEX, Station, node_frames

MIN_MARGIN = 0.002  # [m] conservative advancement needs a positive clearance to make progress
# [m] robot-station clearance the planners keep (and the policy's masks, so its paths pass the planners' check)
PLANNER_MARGIN = 0.005
# segments_clear makes the common first query of more segments than this once (fewer are checked one by one, as
# segment_clear checks them)
SHARED_START_MIN = 4
# segments whose collision answers a MotionValidity keeps (a planner checks many again: 1,400 of the ompl-wear
# plan's 6,300 on the default station); past this, the oldest are forgotten (about 250 bytes each)
SEGMENT_MEMORY = 20_000


class MotionValidity:
    """``valid(q)`` and ``segment_valid(q0, q1)`` for one robot; segments are checked every ``resolution``.

    Cheap checks first (limits, the thesis joint restrictions, the dresspack's reach: no span between its
    nodes may demand more cable than it has), then MuJoCo distance queries. A segment is collision-free in the
    continuous sense (not only at samples) with clearance >= margin / 2.
    """

    def __init__(self, station: Station, robot: int = 0, margin: float = 0.0, resolution_deg: float = 2.0):
        robot = station.check_robot(robot)
        placement = station.config.robots[robot]
        self.limits = placement.robot.joint_limits
        self.restrictions = placement.restrictions
        self.checker = RobotCollisionChecker(station, robot, max(margin, MIN_MARGIN))
        self._placement = placement
        self._kinematics = station.robots[robot].kinematics
        self._may_tear = _may_tear(placement, self._kinematics, self.checker)
        self.resolution = math.radians(resolution_deg)
        self.n_checks = 0  # collision queries the checks ask for (planning cost accounting; see segment_clear)
        self._segments: dict[bytes, tuple[bool, int]] = {}  # (q0, q1) -> (clear, queries), see segment_clear

    def within_limits(self, q: np.ndarray) -> np.ndarray:
        return within_limits(q, self.limits)

    def valid(self, q) -> bool:
        q = np.asarray(q, dtype=float)
        if not (self.within_limits(q)[0] and self.restrictions.allowed(q)[0]) or self.cable_slack(q) < 0.0:
            return False
        self.n_checks += 1
        return not self.checker.collides(q)  # early exit: cheaper than the full distance

    def why_invalid(self, q) -> str:
        q = np.asarray(q, dtype=float)
        if not self.within_limits(q)[0]:
            return "outside the joint limits"
        broken = self.restrictions.violated_by(q)
        if broken:
            return "joint restriction: " + "; ".join(broken)
        slack = self.cable_slack(q)
        if slack < 0.0:
            return f"the dresspack cannot reach: its nodes demand {-slack:.3f} m more cable than it has"
        return "collides with the station" if self.checker.collides(q) else ""

    def cable_slack(self, q) -> float:
        """The dresspack's smallest span slack [m] at q (negative: the robot would tear the cable)."""
        if not self._may_tear:
            return np.inf
        return span_slack(self._placement.dresspack, node_frames(self._placement, self._kinematics.link_frames(q)))

    def segment_valid(self, q0, q1) -> bool:
        """Joint limits and restrictions sampled every ``resolution`` (they are cheap, smooth functions of q);
        collisions checked continuously by conservative advancement: from a configuration with clearance d,
        no robot point moves farther than ``chain_reach @ |dq|``, so the next check can be that far along."""
        q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
        n = max(1, int(math.ceil(np.max(np.abs(q1 - q0)) / self.resolution)))
        qs = q0 + np.linspace(0.0, 1.0, n + 1)[1:, None] * (q1 - q0)
        if not (self.within_limits(qs).all() and self.restrictions.allowed(qs).all()):
            return False
        if self._may_tear and any(self.cable_slack(q) < 0.0 for q in qs):
            return False
        return self.segment_clear(q0, q1)

    def segment_clear(self, q0: np.ndarray, q1: np.ndarray) -> bool:
        """The collision part of :meth:`segment_valid` alone (for callers that checked limits/restrictions).

        A segment checked before is answered from memory (the answer is a function of its two ends); it counts
        the queries its check made in ``n_checks`` again, so the count does not depend on what was kept."""
        q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
        key = q0.tobytes() + q1.tobytes()
        known = self._segments.get(key)
        if known is None:
            before = self.n_checks
            dq = q1 - q0
            clear = self._advance(q0, dq, float(self.checker.chain_reach() @ np.abs(dq)), 0.0)
            if len(self._segments) >= SEGMENT_MEMORY:
                del self._segments[next(iter(self._segments))]  # the oldest (dicts keep insertion order)
            known = self._segments[key] = (clear, self.n_checks - before)
        else:
            self.n_checks += known[1]
        return known[0]

    def _advance(self, q0: np.ndarray, dq: np.ndarray, reach_per_t: float, t: float) -> bool:
        """Conservative advancement along q0 + t dq from ``t`` to 1: True when it stays clear. From ``t``, query the
        clearance d at q0 + t dq; fail if d < margin, succeed at t = 1, else step to t + (d - margin / 2) /
        reach_per_t (capped at 1): the clearance stays above margin / 2 in between. Each query counts in
        n_checks. With the checker's own queries the loop runs compiled (RobotCollisionChecker.advance); a
        clearance function put in their place (a subclass's, or one set on the instance) is stepped here."""
        checker = self.checker
        distance = checker.min_distance
        if getattr(distance, "__func__", None) is RobotCollisionChecker.min_distance:
            clear, queries = checker.advance(q0, dq, reach_per_t, t)
            self.n_checks += queries
            return clear
        margin = checker.margin
        while True:
            self.n_checks += 1
            d = distance(q0 + t * dq)
            if d < margin:
                return False
            if t >= 1.0 or reach_per_t == 0.0:
                return True
            t = min(1.0, t + (d - 0.5 * margin) / reach_per_t)

    def segments_clear(self, q0: np.ndarray, q1s: np.ndarray) -> np.ndarray:
        """:meth:`segment_clear` of each segment from ``q0`` to a row of ``q1s`` (the env's masks check dozens
        from one configuration): the same advancement and answers, with the segments' common first query (q0's)
        made once when there are more than SHARED_START_MIN of them (then q0 in collision answers all after one
        query); each segment then goes on alone from its first step."""
        q0 = np.asarray(q0, dtype=float)
        dq = np.asarray(q1s, dtype=float) - q0
        chain = self.checker.chain_reach()
        reach_per_t = np.array([float(chain @ np.abs(row)) for row in dq])
        margin = self.checker.margin
        t = np.zeros(len(dq))
        clear = np.zeros(len(dq), dtype=bool)
        if len(dq) > SHARED_START_MIN:  # every segment's first query is q0's: made once for all
            self.n_checks += 1
            d0 = self.checker.min_distance(q0)
            if d0 < margin:
                return clear
            clear[reach_per_t == 0.0] = True
            active = np.flatnonzero(reach_per_t > 0.0)
            t[active] = np.minimum(1.0, (d0 - 0.5 * margin) / reach_per_t[active])
        else:
            active = np.arange(len(dq))
        for k in active.tolist():
            clear[k] = self._advance(q0, dq[k], float(reach_per_t[k]), float(t[k]))
        return clear

    def path_valid(self, path) -> bool:
        path = np.asarray(path, dtype=float)
        return self.valid(path[0]) and all(self.segment_valid(a, b) for a, b in zip(path[:-1], path[1:]))


def _may_tear(placement, kinematics, checker: RobotCollisionChecker) -> bool:
    """Whether any configuration could demand more cable than a span has. A point fixed on link a and one on
    link b > a are never farther apart than the path through the joint anchors between them (each distance
    on it is fixed: joint k's anchor sits in links k - 1 and k alike), so a span whose path is no longer than
    its cable can never tear and the per-configuration check is skipped (for a link 3 - link 6 dresspack)."""
    dresspack = placement.dresspack
    home = placement.home
    frames = node_frames(placement, kinematics.link_frames(home))
    checker._pose(home)
    origin = checker.data.xanchor[checker.joint_ids].copy()  # joint k (1-based) -> row k - 1
    axis = checker.data.xaxis[checker.joint_ids].copy()
    held = []  # (vertex, world point at Home, link index; 0 = world or base)
    for node, frame in zip(dresspack.nodes, frames):
        link = 0 if node.body in ("world", "base") else LINK_INDEX[node.body]
        for v, p in zip(node_vertices(dresspack, node), node_world_points(dresspack, node, frame)):
            held.append((v, p, link))
    held.sort(key=lambda a: a[0])
    for (v0, p0, a), (v1, p1, b) in zip(held, held[1:]):
        if v1 - v0 <= 1 or a == b:  # a rigid clamp edge, or both ends on one link: the distance never changes
            continue
        (pa, a), (pb, b) = sorted([(p0, a), (p1, b)], key=lambda x: x[1])
        # Any point of joint k's axis will do; the point nearest the next axis (the wrist centre for a
        # spherical wrist), and on the last axis the point nearest pb, keep the bound tight.
        rows = list(range(a, b))
        stops = [_nearest_on_axis(origin[k], axis[k], origin[k + 1], axis[k + 1]) if k + 1 in rows
                 else origin[k] + axis[k] * float(axis[k] @ (pb - origin[k])) for k in rows]
        chain = np.array([pa, *stops, pb])
        path = float(np.linalg.norm(np.diff(chain, axis=0), axis=1).sum())
        if path > (v1 - v0) * dresspack.segment_length:
            return True
    return False


def _nearest_on_axis(o1: np.ndarray, d1: np.ndarray, o2: np.ndarray, d2: np.ndarray) -> np.ndarray:
    """The point of line (o1, d1) nearest to line (o2, d2) (unit directions); o1 for parallel lines."""
    w = o1 - o2
    b = float(d1 @ d2)
    denom = 1.0 - b * b
    if denom < 1e-12:
        return o1
    t = (b * float(d2 @ w) - float(d1 @ w)) / denom
    return o1 + t * d1
