"""Robot collision queries (the robot is kinematic, so these are checks, not contacts): against static geometry
(the station's obstacles and its other robots parked at Home) and of the dresspack hardware it carries (clamps,
rings) against its own links."""

from __future__ import annotations

import mujoco
import numpy as np

from . import clearance_kernels as kernels
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
# Configurations on which the compiled kinematics must reproduce mj_kinematics to the last bit before a checker
# uses it (random ones within the joint limits, and Home); otherwise its queries call mj_kinematics.
KINEMATICS_CHECKS = 8


_ONES3 = np.ones(3)


class RobotCollisionChecker:
    """``collides(q)`` and ``min_distance(q)`` for one robot of a station, with a safety ``margin`` [m].

    Uses a private MjData (so it never disturbs a running simulation), posed by compiled kinematics that give
    MuJoCo's poses to the last bit (checked on construction, else ``mj_kinematics``), lower bounds of every
    (robot geom, other geom) pair's distance, and MuJoCo's exact ``mj_geomDistance`` for the pairs the bounds
    cannot exclude: the answer is the smallest exact pair distance, whatever the bounds. The queries run in
    compiled code (clearance_kernels), which calls MuJoCo's C functions directly.
    """

    def __init__(self, station: Station, robot: int = 0, margin: float = 0.0):
        robot = station.check_robot(robot)
        self.station = station
        self.model = station.model
        self.data = station.data_at_home()
        self.robot = station.robots[robot]
        self.margin = float(margin)
        self._limits = station.config.robots[robot].robot.joint_limits
        self._joints = (len(self.robot.qpos),)
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
        # each pair's (geom, geom, extra, scale) as Python numbers, for the tables below
        self._pair_rows = [(int(g), int(o), float(e), float(c))
                           for (g, o), e, c in zip(self.pairs, self.extra, self.scale)]
        # Robot geoms each joint moves: joint j moves the bodies of link j+1 .. link6.
        links = self.robot.geom_links
        self.joint_ids = [m.joint(f"{self.robot.name}/j{j + 1}").id for j in range(6)]
        self.moved_geoms = [self.robot.geom_ids[links >= j + 1] for j in range(6)]
        self._freeze_static_geometry()
        self._kernel_tables()
        self._bind()
        self._ints[kernels.H_FK, 0] = self._compiled_kinematics_match()

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

        # for the displacement bounds (see clearance_kernels.min_distance): each pair's (own row of each geom, -1
        # for static geometry; scale; relative reach of two geoms of the robot; then _pair_rows)
        links = {int(g): int(link) for g, link in zip(own, self.robot.geom_links)}
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

    def _kernel_tables(self) -> None:
        """The compiled queries' tables (clearance_kernels): the robot's geoms, every pair's bound as numbers, the
        bodies the robot's joints move with their joints, geoms and sites, and the state a query hands the next."""
        m, d = self.model, self.data
        own = self._own_geoms
        own_i = np.stack([own, self.robot.geom_links]).T.reshape(-1, 2)  # (geom, link)
        own_f = self.rbound[own].reshape(-1, 1)
        pair_i = np.zeros((len(self.pairs), 6), dtype=np.int64)
        pair_f = np.zeros((len(self.pairs), kernels.P_FLOATS))
        for k, (row_g, row_h, scale, relative, g, o, extra) in enumerate(self._pair_walk):
            frame = d.geom_xmat[o]
            if row_h >= 0:
                kind = kernels.OWN
                pair_i[k, kernels.P_LINK_A], pair_i[k, kernels.P_LINK_B] = relative[:2]
                pair_f[k, kernels.P_REACH:kernels.P_REACH + len(relative[2])] = relative[2]
            elif self.plane[k]:
                kind = kernels.PLANE
                pair_f[k, kernels.P_CENTRE] = frame.reshape(3, 3)[:, 2] @ d.geom_xpos[o]  # the plane's height
            elif self.box[k]:
                kind = kernels.BOX
                pair_f[k, kernels.P_CENTRE:kernels.P_CENTRE + 3] = d.geom_xpos[o] @ frame.reshape(3, 3)
                pair_f[k, kernels.P_SIZE:kernels.P_SIZE + 3] = m.geom_size[o]
            else:
                kind = kernels.CENTRE
                pair_f[k, kernels.P_CENTRE:kernels.P_CENTRE + 3] = d.geom_xpos[o]
            pair_i[k, :4] = row_g, o, row_h, kind
            pair_f[k, :3] = scale, extra, self._bound_radii[k]
            pair_f[k, kernels.P_FRAME:kernels.P_FRAME + 9] = frame
        # the bodies to pose: those carrying the robot's geoms and their ancestors, where a joint moves them
        chain = set()
        for body in {int(m.geom_bodyid[g]) for g in own}:
            while body:
                chain.add(body)
                body = int(m.body_parentid[body])

        def moved_by_a_joint(body: int) -> bool:
            return body != 0 and (m.body_jntnum[body] > 0 or moved_by_a_joint(int(m.body_parentid[body])))

        bodies = sorted(b for b in chain if moved_by_a_joint(b))  # MuJoCo numbers parents before children
        body_i, body_f, joint_i, joint_f = [], [], [], []
        for b in bodies:
            first = int(m.body_jntadr[b])
            body_i.append([b, m.body_parentid[b], len(joint_i), m.body_jntnum[b], m.body_sameframe[b]])
            body_f.append([*m.body_pos[b], *m.body_quat[b], *m.body_ipos[b], *m.body_iquat[b]])
            for j in range(first, first + int(m.body_jntnum[b])):
                joint_i.append([j, m.jnt_qposadr[j], m.jnt_type[j]])
                joint_f.append([*m.jnt_axis[j], *m.jnt_pos[j], m.qpos0[m.jnt_qposadr[j]]])
        item_i, item_f = [], []
        for kind, count, body_of, pos, quat, sameframe in (
                (0, m.ngeom, m.geom_bodyid, m.geom_pos, m.geom_quat, m.geom_sameframe),
                (1, m.nsite, m.site_bodyid, m.site_pos, m.site_quat, m.site_sameframe)):
            for k in range(count):
                if int(body_of[k]) in bodies:
                    item_i.append([kind, k, body_of[k], sameframe[k]])
                    item_f.append([*pos[k], *quat[k]])
        # the compiled kinematics covers hinges, slides and balls of bodies that are not mocap, without sleep
        self._fk_supported = (all(int(m.jnt_type[j]) != mujoco.mjtJoint.mjJNT_FREE for j, *_ in joint_i)
                              and all(m.body_mocapid[b] < 0 for b in bodies)
                              and not m.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP)
        self._fk_rows = (body_i, joint_i, item_i)
        self._ints, self._floats = kernels.pack(False, self.robot.qpos, (body_i, body_f), (joint_i, joint_f),
                                                (item_i, item_f), (own_i, own_f), (pair_i, pair_f))
        # what a query hands the next (the kernels' state): its q, its geom centres, its pairs' bounds
        self._state = np.zeros(kernels.state_size(len(self.robot.qpos), len(own), len(self.pairs)))

    def _bind(self) -> None:
        """The addresses the kernels reach this checker's MjModel and MjData by (made again for a copy: see
        __setstate__)."""
        self._binding = kernels.binding(self.model, self.data)

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        del state["_binding"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._bind()

    def _compiled_kinematics_match(self) -> bool:
        """Whether the compiled kinematics pose this robot exactly as mj_kinematics does (every pose they write,
        bit for bit) at Home and at KINEMATICS_CHECKS random configurations within the joint limits; the data is
        left posed as it was."""
        if not self._fk_supported:
            return False
        m, d = self.model, self.data
        body_i, joint_i, item_i = (np.array(rows, dtype=int).reshape(-1, n) for rows, n in
                                   zip(self._fk_rows, (kernels.K_INTS, kernels.J_INTS, kernels.I_INTS)))
        bodies, joints = body_i[:, kernels.K_BODY], joint_i[:, kernels.J_ID]
        geoms = item_i[item_i[:, kernels.I_SITE] == 0, kernels.I_ID]
        sites = item_i[item_i[:, kernels.I_SITE] == 1, kernels.I_ID]

        def poses() -> list[np.ndarray]:
            return [d.xpos[bodies], d.xquat[bodies], d.xmat[bodies], d.xipos[bodies], d.ximat[bodies],
                    d.xanchor[joints], d.xaxis[joints], d.geom_xpos[geoms], d.geom_xmat[geoms], d.site_xpos[sites],
                    d.site_xmat[sites]]

        saved = d.qpos.copy()
        rng = np.random.default_rng(0)
        qs = [saved[self.robot.qpos], *rng.uniform(self._limits[:, 0], self._limits[:, 1], size=(KINEMATICS_CHECKS, 6))]
        ints = self._ints.copy()
        ints[kernels.H_FK, 0] = 1
        match = True
        for q in qs:
            kernels.pose(np.asarray(q, dtype=float), self._binding, ints, self._floats)
            compiled = poses()
            mujoco.mj_kinematics(m, d)
            match &= all(np.array_equal(a, b) for a, b in zip(compiled, poses()))
        d.qpos[:] = saved
        mujoco.mj_kinematics(m, d)
        return bool(match)

    def _kinematics(self, q) -> None:
        """Pose the robot at ``q`` (the compiled kinematics, or MuJoCo's, of the private MjData)."""
        kernels.pose(self._configuration(q), self._binding, self._ints, self._floats)

    def _configuration(self, q, rows: bool = False) -> np.ndarray:
        """``q`` as the kernels read it: floats, one per robot joint (a row each when ``rows``); the kernels do not
        check lengths, so this does."""
        q = np.asarray(q, dtype=float)
        if rows:
            q = np.ascontiguousarray(np.atleast_2d(q))
        if q.shape[-1:] != self._joints or q.ndim != 1 + rows:
            raise ValueError(f"expected {'rows of ' if rows else ''}{self._joints[0]} joint values, got shape "
                             f"{q.shape}")
        return q

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
        """:meth:`min_distance` of each configuration of ``qs`` (B, 6), in one compiled loop; the configuration
        posed last is the last one (as for :meth:`joint_reach`)."""
        qs = self._configuration(qs, rows=True)
        return kernels.min_distances(qs, self._binding, self._ints, self._floats, self._state)

    def min_distance(self, q) -> float:
        """Smallest robot-obstacle surface distance at configuration ``q`` (negative when penetrating); a
        hardware-to-own-link pair counts half its distance.

        Consecutive queries are usually close (conservative advancement steps along a segment): each pair's
        bound is also the last query's bound (its exact distance, where it queried the pair) less how far the
        pair's geoms can have moved since (clearance_kernels.min_distance), so few pairs need an exact query.
        Either way the answer is the smallest exact pair distance."""
        return float(kernels.min_distance(self._configuration(q), self._binding, self._ints, self._floats,
                                          self._state))

    def advance(self, q0, dq, reach_per_t: float, t: float = 0.0) -> tuple[bool, int]:
        """Conservative advancement along ``q0 + t dq`` from ``t`` to 1 (MotionValidity's, see _advance there),
        in one compiled loop: (whether it stays at least ``margin`` clear, the distance queries it made). Each
        query is :meth:`min_distance`'s, so the steps and the answer are those of calling it step by step."""
        clear, queries = kernels.advance(self._configuration(q0), self._configuration(dq),
                                         float(reach_per_t), float(t), self.margin, self._binding, self._ints,
                                         self._floats, self._state)
        return bool(clear), int(queries)

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
        return bool(kernels.collides(self._configuration(q), self.margin, self._binding, self._ints,
                                     self._floats, self._state))

    def collides_batch(self, qs: np.ndarray) -> np.ndarray:
        return np.array([self.collides(q) for q in np.atleast_2d(qs)], dtype=bool)

