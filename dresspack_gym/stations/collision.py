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
        self.data = station.data_at_home()
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
        self._fromto = np.zeros(6)
        # each pair's (geom, geom, extra, scale) as Python numbers, for the exact queries' loop
        self._pair_rows = [(int(g), int(o), float(e), float(c))
                           for (g, o), e, c in zip(self.pairs, self.extra, self.scale)]
        self._freeze_static_geometry()
        # Robot geoms each joint moves: joint j moves the bodies of link j+1 .. link6.
        links = self.robot.geom_links
        self.joint_ids = [m.joint(f"{self.robot.name}/j{j + 1}").id for j in range(6)]
        self.moved_geoms = [self.robot.geom_ids[links >= j + 1] for j in range(6)]

    def _freeze_static_geometry(self) -> None:
        """Precompute what every query shares: only this robot's few geoms move (the obstacles and the other
        robots, parked at Home, never do), so the static positions, box frames and per-pair radius sums are
        fixed, and a query computes every (robot geom, geom) distance in one dense array and picks the pairs
        from it (gathering per pair from the whole model's arrays was most of a query's time)."""
        m, d = self.model, self.data
        own = np.asarray(self.robot.geom_ids, dtype=int)
        local = {int(g): i for i, g in enumerate(own)}
        static = np.array(sorted({int(o) for o in self.pairs[:, 1] if int(o) not in local}), dtype=int)
        row = {**local, **{int(o): len(own) + i for i, o in enumerate(static)}}  # rows of [own geoms; static]
        self._own_geoms = own
        self._static_pos = d.geom_xpos[static].copy()
        width = len(own) + len(static)
        self._pair_cell = np.array([local[int(g)] * width + row[int(o)] for g, o in self.pairs], dtype=int)
        g, o = self.pairs[:, 0], self.pairs[:, 1]
        self._radii = self.rbound[g] + self.rbound[o] + self.extra
        # the pairs only bounding spheres bound (not a box's or a plane's own bound): their rows of [own; static]
        self._sphere = np.flatnonzero(~self.box & ~self.plane)
        self._sphere_own = np.array([local[int(x)] for x in g[self._sphere]], dtype=int)
        self._sphere_other = np.array([row[int(x)] for x in o[self._sphere]], dtype=int)
        boxes, box_of_pair = np.unique(self.pairs[self.box, 1], return_inverse=True)
        self._box_centre = d.geom_xpos[boxes].copy()
        self._box_frame = d.geom_xmat[boxes].reshape(-1, 3, 3).copy()
        self._box_half = m.geom_size[boxes]
        self._box_cell = box_of_pair.reshape(-1) * len(own) + np.array([local[int(x)] for x in g[self.box]], dtype=int)
        self._box_radii = self.rbound[g[self.box]] + self.extra[self.box]
        # for batches: all boxes' frames side by side, one (3, 3 * boxes) product for every geom of every pose,
        # and each box pair's cell of the (geom, box) layout that gives
        self._box_frames_side = self._box_frame.transpose(1, 0, 2).reshape(3, -1)
        self._box_centre_local = np.einsum("bk,bkj->bj", self._box_centre, self._box_frame)
        self._box_cell_by_geom = np.array([local[int(x)] for x in g[self.box]], dtype=int) * len(boxes) + \
            box_of_pair.reshape(-1)
        # Planes (the floor): a robot geom's bounding sphere is at least its centre's height above the plane
        # less its radius away (without this bound every plane pair needed an exact query at every pose)
        planes = self.pairs[self.plane, 1]
        self._plane_normal = d.geom_xmat[planes].reshape(-1, 3, 3)[:, :, 2].copy()
        self._plane_offset = np.einsum("pk,pk->p", self._plane_normal, d.geom_xpos[planes])
        self._plane_own = np.array([local[int(x)] for x in g[self.plane]], dtype=int)
        self._plane_radii = self.rbound[g[self.plane]] + self.extra[self.plane]

    def _pose(self, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pose the robot at ``q``; (robot geoms, obstacles, bounding-sphere lower bound) per pair."""
        d = self.data
        d.qpos[self.robot.qpos] = q
        mujoco.mj_kinematics(self.model, d)
        own = d.geom_xpos[self._own_geoms]
        gap = own[:, None, :] - np.concatenate([own, self._static_pos])[None, :, :]
        lb = np.sqrt(np.einsum("abk,abk->ab", gap, gap)).ravel().take(self._pair_cell) - self._radii
        if len(self._plane_own):
            height = np.einsum("pk,pk->p", own[self._plane_own], self._plane_normal) - self._plane_offset
            lb[self.plane] = np.where(height - self._plane_radii > 0.0, height - self._plane_radii, -np.inf)
        lb *= self.scale
        if len(self._box_cell):
            local = np.matmul(own[None] - self._box_centre[:, None], self._box_frame)  # each geom in each box frame
            outside = np.maximum(np.abs(local) - self._box_half[:, None], 0.0)
            box_lb = np.sqrt(np.einsum("bgk,bgk->bg", outside, outside)).ravel().take(self._box_cell) - self._box_radii
            # only a positive gap bounds the distance; where the sphere reaches into the box, the exact query
            # decides (a penetration depth can be deeper than any such bound)
            lb[self.box] = np.where(box_lb > 0.0, box_lb, -np.inf)
        return self.pairs[:, 0], self.pairs[:, 1], lb

    def _pose_batch(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each configuration of ``qs`` (B, 6) posed as :meth:`_pose` poses one: this robot's geom positions
        (B, G, 3) and orientations (B, G, 9), and the pairs' lower bounds (B, P), computed for all at once (one
        configuration's bounds are a dozen small array operations whose overhead dwarfs their arithmetic)."""
        d, own = self.data, self._own_geoms
        pos = np.empty((len(qs), len(own), 3))
        mat = np.empty((len(qs), len(own), 9))
        for b, q in enumerate(qs):
            d.qpos[self.robot.qpos] = q
            mujoco.mj_kinematics(self.model, d)
            pos[b] = d.geom_xpos[own]
            mat[b] = d.geom_xmat[own]
        # every pair's bound as _pose computes it, but only where it is used: the boxes' and planes' own bounds
        # replace the bounding spheres' for most pairs (all pairs in one dense array was most of a batch's time)
        lb = np.zeros((len(qs), len(self.pairs)))  # not empty: the box columns, set last, are scaled with the rest
        every = np.concatenate([pos, np.broadcast_to(self._static_pos, (len(qs), *self._static_pos.shape))], axis=1)
        gap = pos[:, self._sphere_own] - every[:, self._sphere_other]
        lb[:, self._sphere] = np.sqrt(np.einsum("zpk,zpk->zp", gap, gap)) - self._radii[self._sphere]
        if len(self._plane_own):
            height = np.einsum("zpk,pk->zp", pos[:, self._plane_own], self._plane_normal) - self._plane_offset
            lb[:, self.plane] = np.where(height - self._plane_radii > 0.0, height - self._plane_radii, -np.inf)
        lb *= self.scale
        if len(self._box_cell):
            n_box = len(self._box_centre)
            local = (pos.reshape(-1, 3) @ self._box_frames_side).reshape(len(qs), len(own), n_box, 3) \
                - self._box_centre_local  # each geom in each box's frame, (B, G, boxes, 3)
            outside = np.maximum(np.abs(local) - self._box_half, 0.0)
            box_lb = (np.sqrt(np.einsum("zgbk,zgbk->zgb", outside, outside)).reshape(len(qs), -1)
                      [:, self._box_cell_by_geom] - self._box_radii)
            lb[:, self.box] = np.where(box_lb > 0.0, box_lb, -np.inf)
        return pos, mat, lb

    def min_distances(self, qs) -> np.ndarray:
        """:meth:`min_distance` of each configuration of ``qs`` (B, 6), the bounds computed in one batch; the
        configuration posed last is the last one (as for :meth:`joint_reach`)."""
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        if len(self.pairs) == 0:
            return np.full(len(qs), np.inf)
        pos, mat, lbs = self._pose_batch(qs)
        d, own = self.data, self._own_geoms
        # every configuration's pairs by lower bound, sorted at once and read as Python numbers: the loop below
        # is per exact query (what _nearest does per configuration, without its per-call array operations)
        order = np.argsort(lbs, axis=1, kind="stable")
        bounds = np.take_along_axis(lbs, order, axis=1).tolist()
        order = order.tolist()
        out = np.empty(len(qs))
        for b in range(len(qs)):  # the exact queries read the geoms' poses: this configuration's
            d.geom_xpos[own] = pos[b]
            d.geom_xmat[own] = mat[b]
            pairs, lb = order[b], bounds[b]
            best = self._pair_distance(pairs[0], np.inf)
            for k, bound in zip(pairs[1:], lb[1:]):
                if bound >= best:  # sorted by lower bound: none of the rest can be nearer
                    break
                best = min(best, self._pair_distance(k, best))
            out[b] = best
        return out

    def min_distance(self, q) -> float:
        """Smallest robot-obstacle surface distance at configuration ``q`` (negative when penetrating); a
        hardware-to-own-link pair counts half its distance."""
        if len(self.pairs) == 0:
            return np.inf
        return self._nearest(self._pose(q)[2])

    def _nearest(self, lb: np.ndarray) -> float:
        """The smallest exact pair distance, given every pair's lower bound at the posed configuration."""
        first = int(lb.argmin())
        best = self._pair_distance(first, np.inf)
        # only pairs whose bound is below the nearest pair's distance can be nearer: usually a few of the
        # hundreds, so they alone are sorted (and read as Python numbers: the loop is per exact query)
        rest = np.flatnonzero(lb < best)
        rest = rest[np.argsort(lb[rest])]
        for k, bound in zip(rest.tolist(), lb[rest].tolist()):
            if bound >= best:  # pairs are sorted by lower bound: none of the rest can be nearer
                break
            if k != first:
                best = min(best, self._pair_distance(k, best))
        return float(best)

    def _pair_distance(self, k: int, cap: float) -> float:
        """Pair k's exact distance (as :meth:`min_distance` counts it), or at least ``cap`` when farther. The cap
        passed to MuJoCo is never negative: below zero it no longer bounds a penetration depth but cuts it short
        (a query capped by an earlier pair's penetration returned a shallower depth than the pair's own)."""
        g, o, extra, scale = self._pair_rows[k]
        return (mujoco.mj_geomDistance(self.model, self.data, g, o, min(max(cap, 0.0) / scale + extra, 10.0),
                                       self._fromto) - extra) * scale

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
        lb = self._pose(q)[2]
        for k in np.flatnonzero(lb < self.margin).tolist():  # pairs whose bounding spheres are farther can't touch
            # capped 1 mm (in the pair's own units) beyond the margin: enough to decide, no farther
            if self._pair_distance(k, self.margin + 1e-3 * self._pair_rows[k][3]) < self.margin:
                return True
        return False

    def collides_batch(self, qs: np.ndarray) -> np.ndarray:
        return np.array([self.collides(q) for q in np.atleast_2d(qs)], dtype=bool)
