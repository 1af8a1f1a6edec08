"""Compiled clearance queries of one robot: its kinematics as MuJoCo computes them, pair bounds, exact distances."""

from __future__ import annotations

import glob
import math
import os

import llvmlite.binding as llvm
import mujoco
import numpy as np
from numba import carray, njit, types
from numba.extending import intrinsic

# MuJoCo's exact pair distance and full kinematics are called from the compiled loops by their C names (no Python
# call per query); the symbols resolve when a kernel is compiled or loaded from numba's cache.
llvm.load_library_permanently(sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco*")))[0])
_geom_distance = types.ExternalFunction(
    "mj_geomDistance", types.float64(types.voidptr, types.voidptr, types.intc, types.intc, types.float64,
                                     types.voidptr))
_mj_kinematics = types.ExternalFunction("mj_kinematics", types.void(types.voidptr, types.voidptr))

# mjMINVAL (mjtype.h): mju_normalize4 leaves a quaternion whose norm is this close to 1 as it is
MINVAL = 1e-15
# [m] a pair is skipped only when its lower bound clears the nearest distance found by this much: MuJoCo's convex
# distances (GJK) are accurate to about its ccd_tolerance (1e-6 m by default), so the minimum is the one every
# pair's exact query gives, whatever bounds order and prune the queries
BOUND_SLACK = 1e-5
# mj_geomDistance's cap for an exact distance: the one every pair's reference query uses
DISTANCE_CAP = 10.0

# pair tables: integer columns
P_ROW, P_OTHER, P_OTHER_ROW, P_KIND, P_LINK_A, P_LINK_B = range(6)
# pair tables: float columns (frame: the other geom's 3x3 orientation, row-major as MuJoCo's geom_xmat)
P_SCALE, P_EXTRA, P_RADII = 0, 1, 2
P_FRAME, P_CENTRE, P_SIZE, P_REACH = 3, 12, 15, 18
P_FLOATS = 24
# what bounds a pair: the other geom's centre (a point), a box, a plane, or a geom of the robot itself
CENTRE, BOX, PLANE, OWN = range(4)

# binding: addresses of the model, the data and the data's arrays the kinematics writes
(B_MODEL, B_DATA, B_QPOS, B_XPOS, B_XQUAT, B_XMAT, B_XIPOS, B_XIMAT, B_XANCHOR, B_XAXIS, B_GEOM_XPOS, B_GEOM_XMAT,
 B_SITE_XPOS, B_SITE_XMAT) = range(14)
# and the arrays' lengths
B_NQ, B_NBODY, B_NJNT, B_NGEOM, B_NSITE = range(14, 19)
BINDING = 19
DATA_ARRAYS = ("qpos", "xpos", "xquat", "xmat", "xipos", "ximat", "xanchor", "xaxis", "geom_xpos", "geom_xmat",
               "site_xpos", "site_xmat")

# forward kinematics tables: moving bodies (integer and float columns), their hinges, their geoms and sites
K_BODY, K_PARENT, K_JOINT0, K_JOINTS, K_SAMEFRAME = range(5)
K_POS, K_QUAT, K_IPOS, K_IQUAT = 0, 3, 7, 10
J_ID, J_QPOS, J_TYPE = range(3)
SLIDE, BALL = 2, 1  # mjtJoint (hinges: 3)
J_AXIS, J_POS, J_QPOS0 = 0, 3, 6
I_SITE, I_ID, I_BODY, I_SAMEFRAME = range(4)
I_POS, I_QUAT = 0, 3

# reference state: whether one is kept, then its configuration
R_KEPT, R_Q = 0, 1


def binding(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The addresses the kernels read and write MuJoCo's structures through (valid while both live)."""
    out = np.zeros(BINDING, dtype=np.int64)
    out[B_MODEL], out[B_DATA] = model._address, data._address
    for k, name in enumerate(DATA_ARRAYS):
        array = getattr(data, name)
        assert array.flags.c_contiguous and array.dtype == np.float64
        out[B_QPOS + k] = array.ctypes.data
    out[B_NQ], out[B_NBODY], out[B_NJNT] = model.nq, model.nbody, model.njnt
    out[B_NGEOM], out[B_NSITE] = model.ngeom, model.nsite
    return out


@intrinsic
def _pointer(typingctx, address):
    """The float64 array at ``address`` (an integer) as a pointer numba's carray takes."""
    sig = types.CPointer(types.float64)(types.int64)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(types.CPointer(types.float64)))

    return sig, codegen


@njit(cache=True)
def _array(bind, k, rows, cols):
    return carray(_pointer(bind[k]), (rows, cols))


# MuJoCo's own arithmetic (engine_inline.h, engine_util_spatial.c, engine_util_blas.c), operation for operation:
# the poses must be MuJoCo's to the last bit (the exact distances read them)

@njit(cache=True)
def _rot_vec_quat(res, vec, quat):
    if quat[0] == 1 and quat[1] == 0 and quat[2] == 0 and quat[3] == 0:
        res[0], res[1], res[2] = vec[0], vec[1], vec[2]
        return
    t0 = quat[0] * vec[0] + quat[2] * vec[2] - quat[3] * vec[1]
    t1 = quat[0] * vec[1] + quat[3] * vec[0] - quat[1] * vec[2]
    t2 = quat[0] * vec[2] + quat[1] * vec[1] - quat[2] * vec[0]
    res[0] = vec[0] + 2 * (quat[2] * t2 - quat[3] * t1)
    res[1] = vec[1] + 2 * (quat[3] * t0 - quat[1] * t2)
    res[2] = vec[2] + 2 * (quat[1] * t1 - quat[2] * t0)


@njit(cache=True)
def _mul_quat(res, qa, qb):
    r0 = qa[0] * qb[0] - qa[1] * qb[1] - qa[2] * qb[2] - qa[3] * qb[3]
    r1 = qa[0] * qb[1] + qa[1] * qb[0] + qa[2] * qb[3] - qa[3] * qb[2]
    r2 = qa[0] * qb[2] - qa[1] * qb[3] + qa[2] * qb[0] + qa[3] * qb[1]
    r3 = qa[0] * qb[3] + qa[1] * qb[2] - qa[2] * qb[1] + qa[3] * qb[0]
    res[0], res[1], res[2], res[3] = r0, r1, r2, r3


@njit(cache=True)
def _normalize4(vec):
    norm = math.sqrt(vec[0] * vec[0] + vec[1] * vec[1] + vec[2] * vec[2] + vec[3] * vec[3])
    if norm < MINVAL:
        vec[0], vec[1], vec[2], vec[3] = 1.0, 0.0, 0.0, 0.0
    elif abs(norm - 1) > MINVAL:
        inv = 1 / norm
        vec[0] *= inv
        vec[1] *= inv
        vec[2] *= inv
        vec[3] *= inv


@njit(cache=True)
def _quat2mat(res, quat):
    if quat[0] == 1 and quat[1] == 0 and quat[2] == 0 and quat[3] == 0:
        for i in range(9):
            res[i] = 0.0
        res[0] = res[4] = res[8] = 1.0
        return
    q00, q01, q02, q03 = quat[0] * quat[0], quat[0] * quat[1], quat[0] * quat[2], quat[0] * quat[3]
    q11, q12, q13 = quat[1] * quat[1], quat[1] * quat[2], quat[1] * quat[3]
    q22, q23, q33 = quat[2] * quat[2], quat[2] * quat[3], quat[3] * quat[3]
    res[0] = (q00 - q22) + (q11 - q33)
    res[4] = (q00 + q22) - (q11 + q33)
    res[8] = (q00 - q22) - (q11 - q33)
    res[1] = 2 * (q12 - q03)
    res[2] = 2 * (q13 + q02)
    res[3] = 2 * (q12 + q03)
    res[5] = 2 * (q23 - q01)
    res[6] = 2 * (q13 - q02)
    res[7] = 2 * (q23 + q01)


@njit(cache=True)
def _local_to_global(out_pos, out_mat, pos, quat, sameframe, xpos, xquat, xmat, xipos, ximat):
    """mj_local2Global of a frame (pos, quat) on a body posed at (xpos, xquat, xmat; inertia xipos, ximat)."""
    if sameframe == 1:  # mjSAMEFRAME_BODY
        out_pos[:] = xpos
    elif sameframe == 2:  # mjSAMEFRAME_INERTIA
        out_pos[:] = xipos
    else:
        for i in range(3):
            out_pos[i] = xmat[3 * i] * pos[0] + xmat[3 * i + 1] * pos[1] + xmat[3 * i + 2] * pos[2]
            out_pos[i] += xpos[i]
    if sameframe == 0:
        tmp = np.empty(4)
        _mul_quat(tmp, xquat, quat)
        _quat2mat(out_mat, tmp)
    elif sameframe == 1 or sameframe == 3:
        out_mat[:] = xmat
    else:
        out_mat[:] = ximat


@njit(cache=True)
def forward(bind, body_i, body_f, joint_i, joint_f, item_i, item_f):
    """mj_kinematics for the bodies one robot's joints move (given in MuJoCo's order, parents first), their joints,
    geoms and sites; every other body keeps its pose (nothing else moves)."""
    qpos = carray(_pointer(bind[B_QPOS]), bind[B_NQ])
    xpos, xquat = _array(bind, B_XPOS, bind[B_NBODY], 3), _array(bind, B_XQUAT, bind[B_NBODY], 4)
    xmat = _array(bind, B_XMAT, bind[B_NBODY], 9)
    xipos, ximat = _array(bind, B_XIPOS, bind[B_NBODY], 3), _array(bind, B_XIMAT, bind[B_NBODY], 9)
    xanchor, xaxis = _array(bind, B_XANCHOR, bind[B_NJNT], 3), _array(bind, B_XAXIS, bind[B_NJNT], 3)
    pos, quat, anchor, axis, qloc, vec = np.empty(3), np.empty(4), np.empty(3), np.empty(3), np.empty(4), np.empty(3)
    for r in range(len(body_i)):
        b, parent = body_i[r, K_BODY], body_i[r, K_PARENT]
        bpos, bquat = body_f[r, K_POS:K_POS + 3], body_f[r, K_QUAT:K_QUAT + 4]
        if parent != 0:
            m = xmat[parent]
            for i in range(3):
                pos[i] = m[3 * i] * bpos[0] + m[3 * i + 1] * bpos[1] + m[3 * i + 2] * bpos[2]
                pos[i] += xpos[parent, i]
            _mul_quat(quat, xquat[parent], bquat)
        else:
            pos[:] = bpos
            quat[:] = bquat
        for j in range(body_i[r, K_JOINT0], body_i[r, K_JOINT0] + body_i[r, K_JOINTS]):
            jid = joint_i[j, J_ID]
            jaxis, jpos = joint_f[j, J_AXIS:J_AXIS + 3], joint_f[j, J_POS:J_POS + 3]
            _rot_vec_quat(axis, jaxis, quat)
            _rot_vec_quat(anchor, jpos, quat)
            for i in range(3):
                anchor[i] += pos[i]
            adr = joint_i[j, J_QPOS]
            if joint_i[j, J_TYPE] == SLIDE:
                shift = qpos[adr] - joint_f[j, J_QPOS0]
                for i in range(3):
                    pos[i] += axis[i] * shift
                xanchor[jid] = anchor
                xaxis[jid] = axis
                continue
            angle = qpos[adr] - joint_f[j, J_QPOS0]
            if joint_i[j, J_TYPE] == BALL:
                qloc[:] = qpos[adr:adr + 4]
                _normalize4(qloc)
            elif angle == 0:
                qloc[0], qloc[1], qloc[2], qloc[3] = 1.0, 0.0, 0.0, 0.0
            else:
                s = math.sin(angle * 0.5)
                qloc[0] = math.cos(angle * 0.5)
                qloc[1], qloc[2], qloc[3] = jaxis[0] * s, jaxis[1] * s, jaxis[2] * s
            _mul_quat(quat, quat, qloc)
            _rot_vec_quat(vec, jpos, quat)
            for i in range(3):
                pos[i] = anchor[i] - vec[i]
            xanchor[jid] = anchor
            xaxis[jid] = axis
        _normalize4(quat)
        xquat[b] = quat
        xpos[b] = pos
        _quat2mat(xmat[b], quat)
    for r in range(len(body_i)):  # inertial frames (mj_kinematics2): after every body, as MuJoCo orders them
        b = body_i[r, K_BODY]
        _local_to_global(xipos[b], ximat[b], body_f[r, K_IPOS:K_IPOS + 3], body_f[r, K_IQUAT:K_IQUAT + 4],
                         body_i[r, K_SAMEFRAME], xpos[b], xquat[b], xmat[b], xipos[b], ximat[b])
    geom_xpos, geom_xmat = _array(bind, B_GEOM_XPOS, bind[B_NGEOM], 3), _array(bind, B_GEOM_XMAT, bind[B_NGEOM], 9)
    site_xpos, site_xmat = _array(bind, B_SITE_XPOS, bind[B_NSITE], 3), _array(bind, B_SITE_XMAT, bind[B_NSITE], 9)
    for r in range(len(item_i)):
        k, b = item_i[r, I_ID], item_i[r, I_BODY]
        out_pos = site_xpos[k] if item_i[r, I_SITE] else geom_xpos[k]
        out_mat = site_xmat[k] if item_i[r, I_SITE] else geom_xmat[k]
        _local_to_global(out_pos, out_mat, item_f[r, I_POS:I_POS + 3], item_f[r, I_QUAT:I_QUAT + 4],
                         item_i[r, I_SAMEFRAME], xpos[b], xquat[b], xmat[b], xipos[b], ximat[b])


@njit(cache=True)
def pose(q, qpos_adr, bind, fk, body_i, body_f, joint_i, joint_f, item_i, item_f):
    """Write the robot's joints ``q`` and pose it: the compiled kinematics when ``fk`` (it was checked to give
    MuJoCo's poses), else MuJoCo's full mj_kinematics."""
    qpos = carray(_pointer(bind[B_QPOS]), bind[B_NQ])
    for j in range(len(qpos_adr)):
        qpos[qpos_adr[j]] = q[j]
    if fk:
        forward(bind, body_i, body_f, joint_i, joint_f, item_i, item_f)
    else:
        _mj_kinematics(bind[B_MODEL], bind[B_DATA])


@njit(cache=True)
def _exact(bind, geom, other, extra, scale, cap):
    return (_geom_distance(bind[B_MODEL], bind[B_DATA], geom, other, cap, 0) - extra) * scale


@njit(cache=True)
def _fresh_bounds(centres, pair_i, pair_f, out):
    """Every pair's lower bound from the posed geom centres (-inf where it is not positive: no bound)."""
    for k in range(len(pair_i)):
        c = centres[pair_i[k, P_ROW]]
        kind = pair_i[k, P_KIND]
        f = pair_f[k]
        if kind == OWN:
            h = centres[pair_i[k, P_OTHER_ROW]]
            length = f[P_SCALE] * math.sqrt((c[0] - h[0]) ** 2 + (c[1] - h[1]) ** 2 + (c[2] - h[2]) ** 2)
        elif kind == PLANE:  # the height above the plane (its normal: the frame's third column)
            height = c[0] * f[P_FRAME + 2] + c[1] * f[P_FRAME + 5] + c[2] * f[P_FRAME + 8]
            length = max(height - f[P_CENTRE], 0.0)
        elif kind == BOX:  # what of the centre, in the box's frame, lies outside the box
            s = 0.0
            for i in range(3):
                local = c[0] * f[P_FRAME + i] + c[1] * f[P_FRAME + 3 + i] + c[2] * f[P_FRAME + 6 + i]
                out_i = max(abs(local - f[P_CENTRE + i]) - f[P_SIZE + i], 0.0)
                s += out_i * out_i
            length = math.sqrt(s)
        else:
            length = math.sqrt((c[0] - f[P_CENTRE]) ** 2 + (c[1] - f[P_CENTRE + 1]) ** 2
                               + (c[2] - f[P_CENTRE + 2]) ** 2)
        bound = length - f[P_RADII]
        out[k] = bound if bound > 0.0 else -np.inf


@njit(cache=True)
def _centres(bind, own_i):
    geom_xpos = _array(bind, B_GEOM_XPOS, bind[B_NGEOM], 3)
    out = np.empty((len(own_i), 3))
    for g in range(len(own_i)):
        out[g] = geom_xpos[own_i[g, 0]]
    return out


@njit(cache=True)
def min_distance(q, qpos_adr, bind, fk, body_i, body_f, joint_i, joint_f, item_i, item_f,
                 own_i, own_f, pair_i, pair_f, ref, ref_pos, kept):
    """The smallest exact pair distance at ``q`` (MuJoCo's mj_geomDistance, (distance - extra) x scale).

    Each pair's lower bound is the larger of two: from the geom centres (bounding spheres, boxes, planes), and the
    bound the last query left (``kept``: its exact distance, when it queried the pair) less how far the pair's geoms
    can have moved since (each point of a geom moves at most its centre's displacement plus the geom's turn times
    its bounding radius; the turn of link L is at most the sum of |dq| over the joints before it; two geoms of the
    robot move relative to each other only by the joints between them). A bound that is not positive bounds
    nothing (a penetration depth is not bounded so). Pairs are queried exactly in the order of their bounds until
    the next bound clears the nearest distance found by BOUND_SLACK: the answer is the smallest exact distance of
    every pair, whatever the bounds. The query's bounds (exact where queried) are kept for the next."""
    pose(q, qpos_adr, bind, fk, body_i, body_f, joint_i, joint_f, item_i, item_f)
    centres = _centres(bind, own_i)
    n = len(pair_i)
    lb = np.empty(n)
    _fresh_bounds(centres, pair_i, pair_f, lb)
    if ref[R_KEPT] != 0.0:
        moved = np.empty(len(q))
        turn = np.zeros(len(q) + 1)
        for j in range(len(q)):
            moved[j] = abs(q[j] - ref[R_Q + j])
            turn[j + 1] = turn[j] + moved[j]
        delta = np.empty(len(own_i))
        for g in range(len(own_i)):
            d0, d1, d2 = centres[g, 0] - ref_pos[g, 0], centres[g, 1] - ref_pos[g, 1], centres[g, 2] - ref_pos[g, 2]
            delta[g] = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) + turn[own_i[g, 1]] * own_f[g]
        for k in range(n):
            if not kept[k] > 0.0:
                continue
            row = pair_i[k, P_ROW]
            if pair_i[k, P_KIND] == OWN:  # what each geom moves, or what one moves relative to the other
                other = pair_i[k, P_OTHER_ROW]
                relative = 0.0
                for j in range(pair_i[k, P_LINK_A], pair_i[k, P_LINK_B]):
                    relative += pair_f[k, P_REACH + j - pair_i[k, P_LINK_A]] * moved[j]
                low = kept[k] - pair_f[k, P_SCALE] * min(delta[row] + delta[other], relative)
            else:
                low = kept[k] - delta[row]
            if low > 0.0 and low > lb[k]:
                lb[k] = low
    best = np.inf
    queried = np.zeros(n, dtype=np.bool_)
    while True:
        first, bound = -1, np.inf
        for k in range(n):
            if not queried[k] and lb[k] < bound:
                first, bound = k, lb[k]
        if first < 0 or bound >= max(best, 0.0) + BOUND_SLACK:  # none of the rest can be nearer
            break
        queried[first] = True
        exact = _exact(bind, own_i[pair_i[first, P_ROW], 0], pair_i[first, P_OTHER], pair_f[first, P_EXTRA],
                       pair_f[first, P_SCALE], DISTANCE_CAP)
        lb[first] = exact if exact > 0.0 else -np.inf
        if exact < best:
            best = exact
    kept[:] = lb
    ref[R_KEPT] = 1.0
    ref[R_Q:R_Q + len(q)] = q
    ref_pos[:] = centres
    return best


@njit(cache=True)
def advance(q0, dq, reach_per_t, t, margin, qpos_adr, bind, fk, body_i, body_f, joint_i, joint_f, item_i, item_f,
            own_i, own_f, pair_i, pair_f, ref, ref_pos, kept):
    """Conservative advancement along q0 + t dq from ``t`` to 1, as MotionValidity states it: (clear, queries)."""
    q = np.empty(len(q0))
    queries = 0
    while True:
        queries += 1
        for i in range(len(q0)):
            q[i] = q0[i] + t * dq[i]
        d = min_distance(q, qpos_adr, bind, fk, body_i, body_f, joint_i, joint_f, item_i, item_f,
                         own_i, own_f, pair_i, pair_f, ref, ref_pos, kept)
        if d < margin:
            return False, queries
        if t >= 1.0 or reach_per_t == 0.0:
            return True, queries
        t = min(1.0, t + (d - 0.5 * margin) / reach_per_t)


@njit(cache=True)
def min_distances(qs, qpos_adr, bind, fk, body_i, body_f, joint_i, joint_f, item_i, item_f,
                  own_i, own_f, pair_i, pair_f, ref, ref_pos, kept):
    out = np.empty(len(qs))
    for b in range(len(qs)):
        out[b] = min_distance(qs[b], qpos_adr, bind, fk, body_i, body_f, joint_i, joint_f, item_i, item_f,
                              own_i, own_f, pair_i, pair_f, ref, ref_pos, kept)
    return out


@njit(cache=True)
def collides(q, margin, qpos_adr, bind, fk, body_i, body_f, joint_i, joint_f, item_i, item_f,
             own_i, pair_i, pair_f):
    """Whether any pair is closer than ``margin``: the pairs whose centre bound does not clear it, in order, each
    queried with MuJoCo's distance capped 1 mm (in the pair's own units) beyond the margin; stops at the first."""
    pose(q, qpos_adr, bind, fk, body_i, body_f, joint_i, joint_f, item_i, item_f)
    lb = np.empty(len(pair_i))
    _fresh_bounds(_centres(bind, own_i), pair_i, pair_f, lb)
    for k in range(len(pair_i)):
        if lb[k] < margin + BOUND_SLACK:
            scale, extra = pair_f[k, P_SCALE], pair_f[k, P_EXTRA]
            cap = min(max(margin + 1e-3 * scale, 0.0) / scale + extra, DISTANCE_CAP)
            if _exact(bind, own_i[pair_i[k, P_ROW], 0], pair_i[k, P_OTHER], extra, scale, cap) < margin:
                return True
    return False
