"""Robot collision queries (the robot is kinematic, so these are checks, not contacts): against static geometry
(the station's obstacles and its other robots parked at Home) and of the dresspack hardware it carries (clamps,
rings) against its own links."""

from __future__ import annotations

import mujoco
import numpy as np

from .station import Station

# Links that stand on the floor: their contact with it is not a collision.
FLOOR_EXEMPT_LINKS = ("base", "link1", "link2")
# [m] what a robot keeps from the other robots of the station, parked at Home: paths that keep clear of parked
# robots can always be coordinated by waits (at worst one robot waits until the other is back Home).
ROBOT_CLEARANCE = 0.02
# A clamp or ring is checked against the robot's links at least this many links away from the one carrying it
# (as MuJoCo skips parent-child contacts): the tool support on link 6 against link 4, the arm clamp on link 3
# against links 1, 5 and 6. Without it a wrist bent to 90 deg drove the tool support, with the cable's end
# edge it holds rigidly, into the forearm: the flex contact then reported crushing forces of tens of MN as
# cable tension.
HARDWARE_LINK_GAP = 2


class RobotCollisionChecker:
    """``collides(q)`` for one robot of a station, with a safety ``margin`` [m].

    Uses a private MjData (so it never disturbs a running simulation), ``mj_kinematics`` for the
    link poses, a bounding-sphere filter over (robot geom, obstacle) pairs and MuJoCo's exact
    ``mj_geomDistance`` for the pairs that can touch.
    """

    def __init__(self, station: Station, robot: int = 0, margin: float = 0.0):
        robot = station.check_robot(robot)
        self.station = station
        self.model = station.model
        self.data = mujoco.MjData(self.model)
        self.data.qpos[:] = self.model.qpos0
        self.data.qpos[station.robot_qpos] = station.home.ravel()
        self.data.qpos[station.load_qpos] = station.load_values  # dresspack nodes at their place on the links
        mujoco.mj_kinematics(self.model, self.data)
        self.robot = station.robots[robot]
        self.margin = float(margin)
        m = self.model
        floor = m.geom("floor").id if station.config.floor else -1
        exempt = {m.body(f"{self.robot.name}/{link}").id for link in FLOOR_EXEMPT_LINKS}
        pairs, extra, scale = [], [], []
        others = [g for r in station.robots if r is not self.robot for g in r.geom_ids]  # parked at Home
        for g in self.robot.geom_ids:
            for o in station.obstacle_geoms:
                if o == floor and m.geom_bodyid[g] in exempt:
                    continue
                pairs.append((g, o))
                extra.append(0.0)
            for o in others:
                pairs.append((g, o))
                extra.append(max(0.0, ROBOT_CLEARANCE - self.margin))
        scale = [1.0] * len(pairs)
        node_body = f"{self.robot.name}/node_"
        hardware = {int(g) for g in self.robot.geom_ids if m.body(int(m.geom_bodyid[g])).name.startswith(node_body)}
        for g, link_g in zip(self.robot.geom_ids, self.robot.geom_links):
            if int(g) not in hardware:
                continue
            for h, link_h in zip(self.robot.geom_ids, self.robot.geom_links):
                if int(h) not in hardware and abs(int(link_h) - int(link_g)) >= HARDWARE_LINK_GAP:
                    pairs.append((g, h))
                    extra.append(0.0)
                    # both geoms move: their gap closes at most twice as fast as a robot point moves (the bound
                    # MotionValidity steps by), so the pair counts half its distance (keeps twice the margin)
                    scale.append(0.5)
        self.pairs = np.array(pairs, dtype=int).reshape(-1, 2)
        # distances to other robots count ROBOT_CLEARANCE - margin less, so `margin` keeps ROBOT_CLEARANCE from them
        self.extra = np.array(extra, dtype=float)
        self.scale = np.array(scale, dtype=float)
        self.plane = m.geom_type[self.pairs[:, 1]] == mujoco.mjtGeom.mjGEOM_PLANE if len(self.pairs) else np.zeros(0, bool)
        self.rbound = m.geom_rbound
        # Box obstacles (the station's panels and fixtures are mostly boxes, many much larger than the robot's
        # geoms): their lower bound is the distance from the robot geom's bounding sphere to the box itself, far
        # tighter than sphere to sphere, so fewer exact distance queries are needed.
        self.box = ((m.geom_type[self.pairs[:, 1]] == mujoco.mjtGeom.mjGEOM_BOX) & (self.scale == 1.0)
                    if len(self.pairs) else np.zeros(0, bool))  # obstacles and parked robots only
        self._box_g, self._box_o = self.pairs[self.box, 0], self.pairs[self.box, 1]
        self._box_size = m.geom_size[self._box_o]
        self._fromto = np.zeros(6)
        # Robot geoms each joint moves: joint j moves the bodies of link j+1 .. link6.
        links = self.robot.geom_links
        self.joint_ids = [m.joint(f"{self.robot.name}/j{j + 1}").id for j in range(6)]
        self.moved_geoms = [self.robot.geom_ids[links >= j + 1] for j in range(6)]

    def _pose(self, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pose the robot at ``q``; (robot geoms, obstacles, bounding-sphere lower bound) per pair."""
        d = self.data
        d.qpos[self.robot.qpos] = q
        mujoco.mj_kinematics(self.model, d)
        g, o = self.pairs[:, 0], self.pairs[:, 1]
        lb = np.linalg.norm(d.geom_xpos[g] - d.geom_xpos[o], axis=1) - self.rbound[g] - self.rbound[o] - self.extra
        lb[self.plane] = -np.inf
        lb *= self.scale
        if len(self._box_o):
            rel = d.geom_xpos[self._box_g] - d.geom_xpos[self._box_o]
            local = np.einsum("nij,ni->nj", d.geom_xmat[self._box_o].reshape(-1, 3, 3), rel)  # in the box frame
            outside = np.maximum(np.abs(local) - self._box_size, 0.0)
            box_lb = np.linalg.norm(outside, axis=1) - self.rbound[self._box_g] - self.extra[self.box]
            # only a positive gap bounds the distance; where the sphere reaches into the box, the exact query
            # decides (a penetration depth can be deeper than any such bound)
            lb[self.box] = np.where(box_lb > 0.0, box_lb, -np.inf)
        return g, o, lb

    def min_distance(self, q) -> float:
        """Smallest robot-obstacle surface distance at configuration ``q`` (negative when penetrating); a
        hardware-to-own-link pair counts half its distance."""
        if len(self.pairs) == 0:
            return np.inf
        d = self.data
        g, o, lb = self._pose(q)
        best = np.inf
        for k in np.argsort(lb):
            if lb[k] >= best:  # pairs are sorted by lower bound: none of the rest can be nearer
                break
            dist = (mujoco.mj_geomDistance(self.model, d, int(g[k]), int(o[k]),
                                           min(best / self.scale[k] + self.extra[k], 10.0), self._fromto)
                    - self.extra[k]) * self.scale[k]
            best = min(best, dist)
        return float(best)

    def joint_reach(self) -> np.ndarray:
        """For each joint, the largest distance of a robot geom surface it moves from its axis [m].

        Valid for the configuration last posed (``min_distance``/``collides``). Turning joint j by delta moves
        no robot point farther than reach[j] * |delta| (the distance to a joint's own axis is invariant under
        its rotation), so a move is collision-free if the clearance before it exceeds that.
        """
        d = self.data
        reach = np.zeros(6)
        for j, (jid, geoms) in enumerate(zip(self.joint_ids, self.moved_geoms)):
            rel = d.geom_xpos[geoms] - d.xanchor[jid]
            along = rel @ d.xaxis[jid]
            radial = np.linalg.norm(rel - along[:, None] * d.xaxis[jid], axis=1)
            reach[j] = float(np.max(radial + self.rbound[geoms])) if len(geoms) else 0.0
        return reach

    def chain_reach(self) -> np.ndarray:
        """For each joint j, a bound on the distance of any robot surface it moves from its axis, valid in
        every configuration [m]: the path along the joint anchors to the geom (distances within one link do
        not change), so a move of several joints displaces no point more than ``chain_reach() @ |dq|``."""
        if getattr(self, "_chain_reach", None) is None:
            d = self.data  # anchors and geoms of the last posed configuration; the bound does not depend on it
            anchors = d.xanchor[self.joint_ids]
            link_len = np.linalg.norm(np.diff(anchors, axis=0), axis=1)  # anchor j -> anchor j+1
            reach = np.zeros(6)
            for g, link in zip(self.robot.geom_ids, self.robot.geom_links):
                b = int(link) - 1  # joint b moves link b + 1
                if b < 0:
                    continue
                tail = np.linalg.norm(d.geom_xpos[g] - anchors[b]) + self.rbound[g]
                for j in range(b + 1):  # joints 0..b move this geom
                    reach[j] = max(reach[j], float(link_len[j:b].sum()) + tail)
            self._chain_reach = reach
        return self._chain_reach

    def collides(self, q) -> bool:
        """True if any robot geom is closer than ``margin`` to static geometry (stops at the first hit)."""
        if len(self.pairs) == 0:
            return False
        d = self.data
        g, o, lb = self._pose(q)
        for k in np.flatnonzero(lb < self.margin):  # pairs whose bounding spheres are farther can't touch
            if (mujoco.mj_geomDistance(self.model, d, int(g[k]), int(o[k]),
                                       self.margin / self.scale[k] + self.extra[k] + 1e-3, self._fromto)
                    - self.extra[k]) * self.scale[k] < self.margin:
                return True
        return False

    def collides_batch(self, qs: np.ndarray) -> np.ndarray:
        return np.array([self.collides(q) for q in np.atleast_2d(qs)], dtype=bool)
