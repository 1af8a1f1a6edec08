"""Robot collision queries (the robot is kinematic, so these are checks, not contacts): against static geometry
(the station's obstacles and its other robots parked at Home) and of the dresspack hardware it carries (clamps,
rings) against its own links."""

from __future__ import annotations

import math
from bisect import insort
from itertools import accumulate, chain, islice
from operator import add, mul, sub

import mujoco
import numpy as np

from .station import Station, as_slice

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
# [m] a pair is skipped only when its lower bound clears the nearest distance found by this much: MuJoCo's convex
# distances (GJK) are accurate to about its ccd_tolerance (1e-6 m by default), so the minimum is the one every
# pair's exact query gives, whatever bounds order and prune the queries (one at a time or batched alike)
BOUND_SLACK = 1e-5
# A query hands its nearest pairs to the next one, which checks them one by one (the head); the other pairs wait
# in a list sorted by bound, excluded together while the robot's displacements since allow (see _near_reference).
HEAD_PAIRS = 4
# more waiting pairs than this joining the head at once (a jump, not a step): every pair's bound is computed again
JOIN_MAX = 8
# pairs in the waiting list (the nearest after the head's): the others wait under the smallest bound among them
WAITING_PAIRS = 32


_ONES3 = np.ones(3)


class RobotCollisionChecker:
    """``collides(q)`` and ``min_distance(q)`` for one robot of a station, with a safety ``margin`` [m].

    Uses a private MjData (so it never disturbs a running simulation), ``mj_kinematics`` for the link poses,
    lower bounds of every (robot geom, other geom) pair's distance, and MuJoCo's exact ``mj_geomDistance`` for
    the pairs the bounds cannot exclude: the answer is the smallest exact pair distance, whatever the bounds.
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
        self.plane = (m.geom_type[self.pairs[:, 1]] == mujoco.mjtGeom.mjGEOM_PLANE if len(self.pairs)
                      else np.zeros(0, bool))
        self.rbound = m.geom_rbound
        # Box obstacles (the station's panels and fixtures are mostly boxes, many much larger than the robot's
        # geoms): their lower bound is the distance from the robot geom's bounding sphere to the box itself, far
        # tighter than sphere to sphere, so fewer exact distance queries are needed.
        self.box = ((m.geom_type[self.pairs[:, 1]] == mujoco.mjtGeom.mjGEOM_BOX) & (self.scale == 1.0)
                    if len(self.pairs) else np.zeros(0, bool))  # obstacles and parked robots only
        # each pair's (geom, geom, extra, scale) as Python numbers, for the exact queries' loop
        self._pair_rows = [(int(g), int(o), float(e), float(c))
                           for (g, o), e, c in zip(self.pairs, self.extra, self.scale)]
        # Robot geoms each joint moves: joint j moves the bodies of link j+1 .. link6.
        links = self.robot.geom_links
        self.joint_ids = [m.joint(f"{self.robot.name}/j{j + 1}").id for j in range(6)]
        self.moved_geoms = [self.robot.geom_ids[links >= j + 1] for j in range(6)]
        self._freeze_static_geometry()
        # the last query's: (configuration, geom centres, every pair's bound) when it computed them all, else
        # (configuration, geom centres, head, waiting, their decay); see _near_reference
        self._reference = None

    def _freeze_static_geometry(self) -> None:
        """Precompute what every query shares. Only this robot's geoms move (the obstacles and the other robots,
        parked at Home, never do), so each pair's lower bound is the length of a fixed affine map of the robot's
        geom centres, clipped: the part of the moving centre outside a box (in the box's frame), its offset from
        a point (the centre of a geom that only its bounding sphere bounds), its height above a plane, or the
        offset between two of the robot's own geoms. One product of the centres (1, geoms x 3) with a fixed
        (geoms x 3, pairs x 3) matrix gives every pair's three coordinates, and a query's bounds are half a dozen
        array operations whatever the number of pairs (array operations per pair kind were most of a query's
        time)."""
        m, d = self.model, self.data
        own = np.asarray(self.robot.geom_ids, dtype=int)
        row = {int(g): i for i, g in enumerate(own)}
        self._own_geoms = own
        self._own_index = as_slice(own)  # a slice when the geoms are consecutive (a view, not a gather)
        self._qpos_index = as_slice(np.asarray(self.robot.qpos, dtype=int))
        n = len(self.pairs)
        to_pair = np.zeros((3 * len(own), 3 * n))  # centres (flattened) -> each pair's three coordinates
        low, high = np.zeros(3 * n), np.zeros(3 * n)  # the coordinates' clip range: what is inside, or no gap
        for k, (g, o, _, scale) in enumerate(self._pair_rows):
            rows, cols = slice(3 * row[g], 3 * row[g] + 3), slice(3 * k, 3 * k + 3)
            if o in row:  # dresspack hardware against its own links: the two centres' offset, at the pair's scale
                to_pair[rows, cols] = scale * np.eye(3)
                to_pair[3 * row[o]:3 * row[o] + 3, cols] = -scale * np.eye(3)
            elif self.plane[k]:  # the height above the plane: no gap below it
                normal = d.geom_xmat[o].reshape(3, 3)[:, 2]
                to_pair[rows, 3 * k] = normal
                low[3 * k], high[3 * k] = -np.inf, normal @ d.geom_xpos[o]
            elif self.box[k]:  # the centre in the box's frame (its columns: the box's axes in the world)
                frame = d.geom_xmat[o].reshape(3, 3)
                to_pair[rows, cols] = frame
                centre = d.geom_xpos[o] @ frame
                low[cols], high[cols] = centre - m.geom_size[o], centre + m.geom_size[o]
            else:  # the offset from the other geom's centre (a box of no size)
                to_pair[rows, cols] = np.eye(3)
                low[cols] = high[cols] = d.geom_xpos[o]
        self._to_pair, self._low, self._high = to_pair, low, high
        # what each pair's length is less than the pair's distance: both bounding radii for two centres, the moving
        # geom's alone for a box or a plane (static pairs count their full distance: scale 1)
        surface = self.box | self.plane
        g_of, o_of = self.pairs[:, 0], self.pairs[:, 1]
        self._bound_radii = self.scale * (self.rbound[g_of] + np.where(surface, 0.0, self.rbound[o_of]) + self.extra)
        # Only a positive gap to a box or a plane bounds the distance: where the sphere reaches into it, the exact
        # query decides (a penetration depth can be deeper than any such bound). A centre bound would hold either
        # way (separating the two bounding spheres separates the geoms), but the queries treat every bound that is
        # not positive as none: one rule, and the penetrating configurations they meet are few.

        # for the displacement bounds (_near_reference): each own geom's link and bounding radius
        self._own_links = [int(link) for link in self.robot.geom_links]
        self._own_radii = [float(self.rbound[g]) for g in own]
        # each pair's (own row of each geom, -1 for static geometry; scale; relative reach; then _pair_rows)
        links = dict(zip((int(g) for g in own), self._own_links))
        anchors = d.xanchor[self.joint_ids]  # at Home: the distances read from them do not depend on the pose
        link_len = np.linalg.norm(np.diff(anchors, axis=0), axis=1)  # anchor j -> anchor j + 1

        def relative_reach(g: int, h: int) -> tuple[int, int, list[float]] | None:
            """For geoms g and h of this robot on links a < b: (a, b, reach of joints a .. b - 1), so that
            ``reach @ |dq[a:b]|`` bounds how far any point of the geom on link b moves relative to link a: the
            chain_reach bound of the joints between the links alone (the joints before them move both alike)."""
            (_, a), (far, b) = sorted([(g, links[g]), (h, links[h])], key=lambda x: x[1])
            tail = float(np.linalg.norm(d.geom_xpos[far] - anchors[b - 1])) + float(self.rbound[far])
            return a, b, [float(link_len[j:b - 1].sum()) + tail for j in range(a, b)]

        self._pair_walk = [(row[g], row.get(o, -1), scale, relative_reach(g, o) if o in row else None, g, o, extra)
                           for g, o, extra, scale in self._pair_rows]
        # a pair of two moving geoms closes by at most scale x (both displacements): how many times one
        # displacement bound the most any pair's bound can shrink
        self._shrink = max([1.0] + [2.0 * scale for g, o, _, scale in self._pair_rows if o in row])

    def _kinematics(self, q) -> None:
        """Pose the robot at ``q`` (MuJoCo kinematics of the private MjData)."""
        self.data.qpos[self._qpos_index] = q
        mujoco.mj_kinematics(self.model, self.data)

    def _bounds(self, pos: np.ndarray) -> np.ndarray:
        """Every pair's lower bound (B, pairs) with this robot's geom centres at ``pos`` (B, geoms, 3); a bound
        that is not positive bounds nothing (see _freeze_static_geometry): a query compares its bounds with
        ``max(best, 0)``."""
        coords = pos.reshape(len(pos), -1) @ self._to_pair
        coords -= np.clip(coords, self._low, self._high)
        coords *= coords
        lengths = coords.reshape(len(pos), -1, 3) @ _ONES3
        np.sqrt(lengths, out=lengths)
        lengths -= self._bound_radii
        return lengths

    def _pose(self, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pose the robot at ``q``; (robot geoms, obstacles, lower bound of the distance) per pair (-inf where
        the bound is none)."""
        self._kinematics(q)
        lb = self._bounds(self.data.geom_xpos[self._own_index][None])[0]
        return self.pairs[:, 0], self.pairs[:, 1], np.where(lb > 0.0, lb, -np.inf)

    def _pose_batch(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each configuration of ``qs`` (B, 6) posed as :meth:`_pose` poses one: this robot's geom positions
        (B, G, 3) and orientations (B, G, 9), and the pairs' lower bounds (B, P, -inf where none), computed for
        all at once."""
        own = self._own_index
        pos = np.empty((len(qs), len(self._own_geoms), 3))
        mat = np.empty((len(qs), len(self._own_geoms), 9))
        for b, q in enumerate(qs):
            self._kinematics(q)
            pos[b] = self.data.geom_xpos[own]
            mat[b] = self.data.geom_xmat[own]
        lb = self._bounds(pos)
        return pos, mat, np.where(lb > 0.0, lb, -np.inf)

    def min_distances(self, qs) -> np.ndarray:
        """:meth:`min_distance` of each configuration of ``qs`` (B, 6), the bounds computed in one batch; the
        configuration posed last is the last one (as for :meth:`joint_reach`)."""
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        if len(self.pairs) == 0:
            return np.full(len(qs), np.inf)
        pos, mat, lbs = self._pose_batch(qs)
        own = self._own_index
        # every configuration's pairs by lower bound, sorted at once and read as Python numbers: the loop below
        # is per exact query (what _nearest does per configuration, without its per-call array operations)
        order = np.argsort(lbs, axis=1, kind="stable")
        bounds = np.take_along_axis(lbs, order, axis=1).tolist()
        order = order.tolist()
        out = np.empty(len(qs))
        for b in range(len(qs)):  # the exact queries read the geoms' poses: this configuration's
            self.data.geom_xpos[own] = pos[b]
            self.data.geom_xmat[own] = mat[b]
            pairs, lb = order[b], bounds[b]
            best = self._pair_distance(pairs[0], np.inf)
            for k, bound in zip(pairs[1:], lb[1:]):
                if bound >= best + BOUND_SLACK:  # sorted by lower bound: none of the rest can be nearer
                    break
                best = min(best, self._pair_distance(k, best + BOUND_SLACK))
            out[b] = best
        return out

    def min_distance(self, q) -> float:
        """Smallest robot-obstacle surface distance at configuration ``q`` (negative when penetrating); a
        hardware-to-own-link pair counts half its distance.

        Consecutive queries are usually close (conservative advancement steps along a segment): a query first
        tries the pairs the last query found nearest, each bound shrunk by how far the pair's geoms can have moved
        since (:meth:`_near_reference`); only when that cannot exclude the other pairs (a jump rather than a step)
        are every pair's bounds computed again. Either way the answer is the smallest exact pair distance."""
        if len(self.pairs) == 0:
            return np.inf
        q = np.asarray(q, dtype=float)
        self._kinematics(q)
        if self._reference is not None:
            best = self._near_reference(q)
            if best is not None:
                return best
        lb = self._bounds(self.data.geom_xpos[self._own_index][None])[0]
        best = self._nearest(lb)
        self._remember(q, lb)
        return best

    def _nearest(self, lb: np.ndarray) -> float:
        """The smallest exact pair distance, given every pair's lower bound at the posed configuration; the
        bounds of the pairs queried are raised to their exact distances (in place)."""
        first = int(lb.argmin())
        best = lb[first] = self._pair_distance(first, np.inf)
        # only pairs whose bound is below the nearest pair's distance can be nearer: usually a few of the
        # hundreds, so they alone are sorted (and read as Python numbers: the loop is per exact query)
        rest = (lb < max(best, 0.0) + BOUND_SLACK).nonzero()[0]
        if len(rest) > 1:
            rest = rest[np.argsort(lb[rest])]
            for k, bound in zip(rest.tolist(), lb[rest].tolist()):
                if bound >= max(best, 0.0) + BOUND_SLACK:  # sorted by lower bound: none of the rest can be nearer
                    break
                if k != first:
                    exact = self._pair_distance(k, best + BOUND_SLACK)
                    lb[k] = max(bound, exact)
                    best = min(best, exact)
        return float(best)

    def _remember(self, q: np.ndarray, lb: np.ndarray) -> None:
        """Make the posed configuration ``q`` the reference of the next query, given every pair's lower bound
        (exact distances where queried); its lists are made when a query steps from it (see _lists)."""
        self._reference = (q.tolist(), self.data.geom_xpos[self._own_index].tolist(), lb)

    @staticmethod
    def _lists(lb: np.ndarray) -> tuple[list, list, float]:
        """A reference's pairs from their bounds: the HEAD_PAIRS nearest (the head), the next WAITING_PAIRS
        waiting, sorted by bound, and the rest waiting together behind them, under the smallest bound among them;
        the waiting bounds' decay so far (none)."""
        kept = HEAD_PAIRS + WAITING_PAIRS
        order = np.argsort(lb)
        bounds = [b if b > 0.0 else -math.inf for b in lb[order[:kept + 1]].tolist()]  # not positive: no bound
        pairs = list(zip(bounds, order[:kept].tolist()))
        rest = (bounds[kept] if len(lb) > kept else math.inf, -1)  # pair -1: the rest; reaching it ends the walk
        return pairs[:HEAD_PAIRS], pairs[HEAD_PAIRS:] + [rest], 0.0

    def _near_reference(self, q: np.ndarray) -> float | None:
        """The smallest exact pair distance at the posed configuration ``q``, from the last query's (the
        reference's) pairs; None when too many pairs would need a look (every pair's bound is cheaper then).
        The posed configuration becomes the reference.

        A pair's distance is at least its bound at the reference less how far its geoms have moved since (each
        point of a geom moves at most its centre's displacement plus the geom's turn times its bounding radius;
        the turn of link L is at most the sum of |dq| over the joints before it; two geoms of the robot move
        relative to each other only by the joints between them), when that is positive (a penetration depth is
        not bounded so: such pairs are queried). The head's pairs are checked one by one: bound shrunk by their
        geoms' displacements, or an exact query; the waiting ones share one decay, the largest displacement of
        every step since the list was made, and join the head when that no longer excludes them. Python numbers
        throughout: the work is a few dozen operations, which one numpy call each would multiply."""
        ref_q, ref_pos, *lists = self._reference
        head, waiting, decay = self._lists(*lists) if len(lists) == 1 else lists
        q_list = q.tolist()
        moved = list(map(abs, map(sub, q_list, ref_q)))
        turn = list(accumulate(moved, initial=0.0))
        pos = self.data.geom_xpos[self._own_index].tolist()
        delta = list(map(add, map(math.dist, pos, ref_pos), map(mul, map(turn.__getitem__, self._own_links),
                                                                self._own_radii)))
        reach = self._shrink * max(delta)  # the most any pair's bound can have shrunk since the reference
        prior, decay = decay, decay + reach
        bound, first = head[0]
        if len(waiting) > JOIN_MAX and waiting[JOIN_MAX][0] - decay < bound + reach:
            return None  # most likely a jump: with the nearest pair as far as it may now be, too many would join
        model, data, walk = self.model, self.data, self._pair_walk
        _, _, scale, _, g, o, extra = walk[first]
        best = (mujoco.mj_geomDistance(model, data, g, o, 10.0, None) - extra) * scale
        limit = max(best, 0.0) + BOUND_SLACK
        joining = 0
        while waiting[joining][0] - decay < limit:  # the shared decay no longer excludes the pair
            if joining == JOIN_MAX or waiting[joining][1] < 0:  # a jump, or the rest: every bound again
                return None
            joining += 1
        joined = [(b - prior, k) for b, k in islice(waiting, joining)]  # their bounds at the last configuration
        del waiting[:joining]
        kept = [(best, first)]
        for bound, k in chain(islice(head, 1, None), joined):
            row_g, row_h, scale, relative, g, o, extra = walk[k]
            if bound > 0.0:
                if row_h < 0:
                    low = bound - delta[row_g]
                else:  # two geoms of the robot: what each moves, or what one moves relative to the other
                    a, b, reaches = relative
                    low = bound - scale * min(delta[row_g] + delta[row_h], sum(map(mul, reaches, moved[a:b])))
                if low > 0.0 and low >= best + BOUND_SLACK:
                    kept.append((low, k))
                    continue
            exact = (mujoco.mj_geomDistance(model, data, g, o, 10.0, None) - extra) * scale
            kept.append((exact, k))
            if exact < best:
                best = exact
        kept.sort()
        for low, k in islice(kept, HEAD_PAIRS, None):  # the head's farthest wait again, with the bound they have
            insort(waiting, (low + decay if low > 0.0 else -math.inf, k))
        del kept[HEAD_PAIRS:]
        self._reference = (q_list, pos, kept, waiting, decay)
        return float(best)

    def _pair_distance(self, k: int, cap: float) -> float:
        """Pair k's exact distance (as :meth:`min_distance` counts it), or at least ``cap`` when farther. The cap
        passed to MuJoCo is never negative: below zero it no longer bounds a penetration depth but cuts it short
        (a query capped by an earlier pair's penetration returned a shallower depth than the pair's own)."""
        g, o, extra, scale = self._pair_rows[k]
        return (mujoco.mj_geomDistance(self.model, self.data, g, o, min(max(cap, 0.0) / scale + extra, 10.0),
                                       None) - extra) * scale

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
        for k in np.flatnonzero(lb < self.margin + BOUND_SLACK).tolist():  # pairs bounded farther can't touch
            # capped 1 mm (in the pair's own units) beyond the margin: enough to decide, no farther
            if self._pair_distance(k, self.margin + 1e-3 * self._pair_rows[k][3]) < self.margin:
                return True
        return False

    def collides_batch(self, qs: np.ndarray) -> np.ndarray:
        return np.array([self.collides(q) for q in np.atleast_2d(qs)], dtype=bool)

