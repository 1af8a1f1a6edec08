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
_LIBRARY = [path for pattern in ("libmujoco.so*", "libmujoco*.dylib", "mujoco*.dll")
            for path in sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), pattern)))]
if not _LIBRARY:
    raise ImportError(f"MuJoCo's shared library is not beside its Python package ({os.path.dirname(mujoco.__file__)})")
llvm.load_library_permanently(_LIBRARY[0])
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

# pair table, integer columns: the robot geom's row, the other geom, its row (-1: not the robot's), what bounds the
# pair, and for two geoms of the robot the links a < b whose joints a .. b - 1 move one relative to the other
P_ROW, P_OTHER, P_OTHER_ROW, P_KIND, P_LINK_A, P_LINK_B = range(6)
P_INTS = 6
# pair table, float columns (frame: the other geom's 3x3 orientation, row-major as MuJoCo's geom_xmat; centre: its
# centre, in the box's frame for a box, the plane's height for a plane; reach: per joint a .. b - 1)
P_SCALE, P_EXTRA, P_RADII = 0, 1, 2
P_FRAME, P_CENTRE, P_SIZE, P_REACH = 3, 12, 15, 18
P_FLOATS = 24
# what bounds a pair: the other geom's centre (a point), a box, a plane, or a geom of the robot itself
CENTRE, BOX, PLANE, OWN = range(4)

# binding: addresses of the model, the data and the data's arrays the kinematics writes, then the arrays' lengths
(B_MODEL, B_DATA, B_QPOS, B_XPOS, B_XQUAT, B_XMAT, B_XIPOS, B_XIMAT, B_XANCHOR, B_XAXIS, B_GEOM_XPOS, B_GEOM_XMAT,
 B_SITE_XPOS, B_SITE_XMAT) = range(14)
B_NQ, B_NBODY, B_NJNT, B_NGEOM, B_NSITE = range(14, 19)
BINDING = 19
DATA_ARRAYS = ("qpos", "xpos", "xquat", "xmat", "xipos", "ximat", "xanchor", "xaxis", "geom_xpos", "geom_xmat",
               "site_xpos", "site_xmat")

# forward kinematics tables: the bodies the robot's joints move (integer and float columns), their joints, and the
# geoms and sites on them
K_BODY, K_PARENT, K_JOINT0, K_JOINTS, K_SAMEFRAME = range(5)
K_INTS = 5
K_POS, K_QUAT, K_IPOS, K_IQUAT = 0, 3, 7, 10
K_FLOATS = 14
J_ID, J_QPOS, J_TYPE = range(3)
J_INTS = 3
J_AXIS, J_POS, J_QPOS0 = 0, 3, 6
J_FLOATS = 7
SLIDE, BALL = 2, 1  # mjtJoint (hinges: 3)
I_SITE, I_ID, I_BODY, I_SAMEFRAME = range(4)
I_INTS = 4
I_POS, I_QUAT = 0, 3
I_FLOATS = 7

# The tables travel in one integer and one float array of rows (a compiled call's cost grows with its arguments,
# and a row read in place costs nothing, where a view of a table costs a reference count): a table's row r is row
# offset + r of both. The first rows are the header: row t holds table t's (rows, offset), row H_FK whether the
# compiled kinematics pose the robot.
T_QPOS, T_BODY, T_JOINT, T_ITEM, T_OWN, T_PAIR = range(6)
H_FK = 6
HEADER = H_FK + 1
INT_COLUMNS, FLOAT_COLUMNS = 8, P_FLOATS
# the state a query hands the next (its q after a flag whether there is one, its geom centres, its pairs' bounds),
# then scratch (bounds, centres, displacements, |dq|, turns): each part's offset by n_q, n_own, n_pairs
S_KEPT, S_Q = 0, 1


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


def pack(fk: bool, qpos_adr, bodies, joints, items, own, pairs) -> tuple[np.ndarray, np.ndarray]:
    """The tables (each an (integer rows, float rows) pair, in T_*'s order; qpos_adr has integers only) packed for
    the kernels: (integer rows after the header, float rows)."""
    parts = [(np.asarray(qpos_adr).reshape(-1, 1), np.zeros((len(qpos_adr), 0))), bodies, joints, items, own, pairs]
    header_i = np.zeros((HEADER, INT_COLUMNS), dtype=np.int64)
    ints, floats = [header_i], [np.zeros((HEADER, FLOAT_COLUMNS))]
    at = HEADER
    widths = [(1, 0), (K_INTS, K_FLOATS), (J_INTS, J_FLOATS), (I_INTS, I_FLOATS), (2, 1), (P_INTS, P_FLOATS)]
    for table, ((rows_i, rows_f), (n_int, n_float)) in enumerate(zip(parts, widths)):
        rows_i = np.asarray(rows_i, dtype=np.int64).reshape(len(rows_i), n_int)
        rows_f = np.asarray(rows_f, dtype=np.float64).reshape(len(rows_i), n_float)
        block_i = np.zeros((len(rows_i), INT_COLUMNS), dtype=np.int64)
        block_f = np.zeros((len(rows_i), FLOAT_COLUMNS))
        block_i[:, :n_int] = rows_i
        block_f[:, :n_float] = rows_f
        header_i[table, :2] = len(rows_i), at
        ints.append(block_i)
        floats.append(block_f)
        at += len(rows_i)
    header_i[H_FK, 0] = int(fk)
    return np.concatenate(ints), np.concatenate(floats)


def state_size(n_q: int, n_own: int, n_pairs: int) -> int:
    """Floats of a query's state (see _offsets)."""
    return _offsets(n_q, n_own, n_pairs)[-1]


@njit(cache=True, inline="always")
def _offsets(n_q, n_own, n_pairs):
    """Offsets in the state of: the kept centres, the kept bounds, the bounds, the centres, the displacements,
    |dq|, the turns, and the end."""
    centres_kept = 1 + n_q
    bounds_kept = centres_kept + 3 * n_own
    bounds = bounds_kept + n_pairs
    centres = bounds + n_pairs
    delta = centres + 3 * n_own
    moved = delta + n_own
    turn = moved + n_q
    return centres_kept, bounds_kept, bounds, centres, delta, moved, turn, turn + n_q + 1


@intrinsic
def _pointer(typingctx, address):
    """The float64 array at ``address`` (an integer) as a pointer numba's carray takes."""
    sig = types.CPointer(types.float64)(types.int64)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(types.CPointer(types.float64)))

    return sig, codegen


@njit(cache=True, inline="always")
def _array(bind, k, rows, cols):
    """A (rows, cols) array of the data's (no reference count: MuJoCo owns it)."""
    return carray(_pointer(bind[k]), (rows, cols))


# MuJoCo's own arithmetic (engine_inline.h, engine_util_spatial.c, engine_util_blas.c), operation for operation,
# on tuples (no allocation): the poses must be MuJoCo's to the last bit (the exact distances read them)

@njit(cache=True, inline="always")
def _vec3(a):
    return a[0], a[1], a[2]


@njit(cache=True, inline="always")
def _vec4(a):
    return a[0], a[1], a[2], a[3]


@njit(cache=True, inline="always")
def _rot_vec_quat(vec, quat):
    if quat[0] == 1 and quat[1] == 0 and quat[2] == 0 and quat[3] == 0:
        return vec
    t0 = quat[0] * vec[0] + quat[2] * vec[2] - quat[3] * vec[1]
    t1 = quat[0] * vec[1] + quat[3] * vec[0] - quat[1] * vec[2]
    t2 = quat[0] * vec[2] + quat[1] * vec[1] - quat[2] * vec[0]
    return (vec[0] + 2 * (quat[2] * t2 - quat[3] * t1),
            vec[1] + 2 * (quat[3] * t0 - quat[1] * t2),
            vec[2] + 2 * (quat[1] * t1 - quat[2] * t0))


@njit(cache=True, inline="always")
def _mul_quat(qa, qb):
    return (qa[0] * qb[0] - qa[1] * qb[1] - qa[2] * qb[2] - qa[3] * qb[3],
            qa[0] * qb[1] + qa[1] * qb[0] + qa[2] * qb[3] - qa[3] * qb[2],
            qa[0] * qb[2] - qa[1] * qb[3] + qa[2] * qb[0] + qa[3] * qb[1],
            qa[0] * qb[3] + qa[1] * qb[2] - qa[2] * qb[1] + qa[3] * qb[0])


@njit(cache=True, inline="always")
def _normalize4(vec):
    norm = math.sqrt(vec[0] * vec[0] + vec[1] * vec[1] + vec[2] * vec[2] + vec[3] * vec[3])
    if norm < MINVAL:
        return 1.0, 0.0, 0.0, 0.0
    if abs(norm - 1) > MINVAL:
        inv = 1 / norm
        return vec[0] * inv, vec[1] * inv, vec[2] * inv, vec[3] * inv
    return vec


@njit(cache=True, inline="always")
def _mat_vec(mat, vec, add):
    """mat @ vec + add (mji_mulMatVec3, then mji_addTo3)."""
    return (mat[0] * vec[0] + mat[1] * vec[1] + mat[2] * vec[2] + add[0],
            mat[3] * vec[0] + mat[4] * vec[1] + mat[5] * vec[2] + add[1],
            mat[6] * vec[0] + mat[7] * vec[1] + mat[8] * vec[2] + add[2])


@njit(cache=True, inline="always")
def _quat2mat(res, row, quat):
    """mju_quat2Mat into ``res[row]``; the diagonal summed in the grouping MuJoCo's library computes it in."""
    if quat[0] == 1 and quat[1] == 0 and quat[2] == 0 and quat[3] == 0:
        for i in range(9):
            res[row, i] = 1.0 if i % 4 == 0 else 0.0
        return
    q00, q01, q02, q03 = quat[0] * quat[0], quat[0] * quat[1], quat[0] * quat[2], quat[0] * quat[3]
    q11, q12, q13 = quat[1] * quat[1], quat[1] * quat[2], quat[1] * quat[3]
    q22, q23, q33 = quat[2] * quat[2], quat[2] * quat[3], quat[3] * quat[3]
    res[row, 0] = (q00 - q22) + (q11 - q33)
    res[row, 4] = (q00 + q22) - (q11 + q33)
    res[row, 8] = (q00 - q22) - (q11 - q33)
    res[row, 1] = 2 * (q12 - q03)
    res[row, 2] = 2 * (q13 + q02)
    res[row, 3] = 2 * (q12 + q03)
    res[row, 5] = 2 * (q23 - q01)
    res[row, 6] = 2 * (q13 - q02)
    res[row, 7] = 2 * (q23 + q01)


@njit(cache=True, inline="always")
def _local_to_global(out_pos, out_mat, k, pos, quat, sameframe, b, xpos, xquat, xmat, xipos, ximat):
    """mj_local2Global: row k of (out_pos, out_mat) from the frame (pos, quat) on body b."""
    if sameframe == 1:  # mjSAMEFRAME_BODY
        out_pos[k, 0], out_pos[k, 1], out_pos[k, 2] = xpos[b, 0], xpos[b, 1], xpos[b, 2]
    elif sameframe == 2:  # mjSAMEFRAME_INERTIA
        out_pos[k, 0], out_pos[k, 1], out_pos[k, 2] = xipos[b, 0], xipos[b, 1], xipos[b, 2]
    else:
        out_pos[k, 0], out_pos[k, 1], out_pos[k, 2] = _mat_vec(xmat[b], pos, xpos[b])
    if sameframe == 0:
        _quat2mat(out_mat, k, _mul_quat(_vec4(xquat[b]), quat))
    elif sameframe == 1 or sameframe == 3:
        for i in range(9):
            out_mat[k, i] = xmat[b, i]
    else:
        for i in range(9):
            out_mat[k, i] = ximat[b, i]


@njit(cache=True)
def _forward(bind, qpos, ints, floats):
    """mj_kinematics for the bodies one robot's joints move (in MuJoCo's order, parents first), their joints, geoms
    and sites; every other body keeps its pose (nothing else moves)."""
    n_body, n_jnt = bind[B_NBODY], bind[B_NJNT]
    xpos, xquat = _array(bind, B_XPOS, n_body, 3), _array(bind, B_XQUAT, n_body, 4)
    xmat, xipos, ximat = _array(bind, B_XMAT, n_body, 9), _array(bind, B_XIPOS, n_body, 3), _array(bind, B_XIMAT,
                                                                                                     n_body, 9)
    xanchor, xaxis = _array(bind, B_XANCHOR, n_jnt, 3), _array(bind, B_XAXIS, n_jnt, 3)
    bodies, joints = ints[T_BODY, 1], ints[T_JOINT, 1]
    for r in range(bodies, bodies + ints[T_BODY, 0]):
        b, parent = ints[r, K_BODY], ints[r, K_PARENT]
        bpos = (floats[r, K_POS], floats[r, K_POS + 1], floats[r, K_POS + 2])
        bquat = (floats[r, K_QUAT], floats[r, K_QUAT + 1], floats[r, K_QUAT + 2], floats[r, K_QUAT + 3])
        if parent != 0:
            pos = _mat_vec(xmat[parent], bpos, xpos[parent])
            quat = _mul_quat(_vec4(xquat[parent]), bquat)
        else:
            pos, quat = bpos, bquat
        for j in range(joints + ints[r, K_JOINT0], joints + ints[r, K_JOINT0] + ints[r, K_JOINTS]):
            jid, adr = ints[j, J_ID], ints[j, J_QPOS]
            jaxis = (floats[j, J_AXIS], floats[j, J_AXIS + 1], floats[j, J_AXIS + 2])
            jpos = (floats[j, J_POS], floats[j, J_POS + 1], floats[j, J_POS + 2])
            axis = _rot_vec_quat(jaxis, quat)
            a0, a1, a2 = _rot_vec_quat(jpos, quat)
            anchor = (a0 + pos[0], a1 + pos[1], a2 + pos[2])
            if ints[j, J_TYPE] == SLIDE:
                shift = qpos[adr] - floats[j, J_QPOS0]
                pos = (pos[0] + axis[0] * shift, pos[1] + axis[1] * shift, pos[2] + axis[2] * shift)
            else:
                if ints[j, J_TYPE] == BALL:
                    qloc = _normalize4((qpos[adr], qpos[adr + 1], qpos[adr + 2], qpos[adr + 3]))
                else:
                    angle = qpos[adr] - floats[j, J_QPOS0]
                    if angle == 0:
                        qloc = (1.0, 0.0, 0.0, 0.0)
                    else:
                        s = math.sin(angle * 0.5)
                        qloc = (math.cos(angle * 0.5), jaxis[0] * s, jaxis[1] * s, jaxis[2] * s)
                quat = _mul_quat(quat, qloc)
                v0, v1, v2 = _rot_vec_quat(jpos, quat)
                pos = (anchor[0] - v0, anchor[1] - v1, anchor[2] - v2)
            xanchor[jid, 0], xanchor[jid, 1], xanchor[jid, 2] = anchor
            xaxis[jid, 0], xaxis[jid, 1], xaxis[jid, 2] = axis
        quat = _normalize4(quat)
        xquat[b, 0], xquat[b, 1], xquat[b, 2], xquat[b, 3] = quat
        xpos[b, 0], xpos[b, 1], xpos[b, 2] = pos
        _quat2mat(xmat, b, quat)
    for r in range(bodies, bodies + ints[T_BODY, 0]):  # inertial frames (mj_kinematics2), after every body's pose
        b = ints[r, K_BODY]
        _local_to_global(xipos, ximat, b, (floats[r, K_IPOS], floats[r, K_IPOS + 1], floats[r, K_IPOS + 2]),
                         (floats[r, K_IQUAT], floats[r, K_IQUAT + 1], floats[r, K_IQUAT + 2], floats[r, K_IQUAT + 3]),
                         ints[r, K_SAMEFRAME], b, xpos, xquat, xmat, xipos, ximat)
    n_geom, n_site = bind[B_NGEOM], bind[B_NSITE]
    geom_xpos, geom_xmat = _array(bind, B_GEOM_XPOS, n_geom, 3), _array(bind, B_GEOM_XMAT, n_geom, 9)
    site_xpos, site_xmat = _array(bind, B_SITE_XPOS, n_site, 3), _array(bind, B_SITE_XMAT, n_site, 9)
    items = ints[T_ITEM, 1]
    for r in range(items, items + ints[T_ITEM, 0]):
        pos = (floats[r, I_POS], floats[r, I_POS + 1], floats[r, I_POS + 2])
        quat = (floats[r, I_QUAT], floats[r, I_QUAT + 1], floats[r, I_QUAT + 2], floats[r, I_QUAT + 3])
        if ints[r, I_SITE]:
            _local_to_global(site_xpos, site_xmat, ints[r, I_ID], pos, quat, ints[r, I_SAMEFRAME], ints[r, I_BODY],
                             xpos, xquat, xmat, xipos, ximat)
        else:
            _local_to_global(geom_xpos, geom_xmat, ints[r, I_ID], pos, quat, ints[r, I_SAMEFRAME], ints[r, I_BODY],
                             xpos, xquat, xmat, xipos, ximat)


@njit(cache=True)
def pose(q, bind, ints, floats):
    """Write the robot's joints ``q`` and pose it: the compiled kinematics when the header says so (they were
    checked to give MuJoCo's poses), else MuJoCo's full mj_kinematics."""
    qpos = carray(_pointer(bind[B_QPOS]), bind[B_NQ])
    adr = ints[T_QPOS, 1]
    for j in range(ints[T_QPOS, 0]):
        qpos[ints[adr + j, 0]] = q[j]
    if ints[H_FK, 0]:
        _forward(bind, qpos, ints, floats)
    else:
        _mj_kinematics(bind[B_MODEL], bind[B_DATA])


@njit(cache=True, inline="always")
def _exact(bind, ints, floats, k):
    """Pair k's exact distance at the posed configuration, (MuJoCo's distance - extra) x scale."""
    geom = ints[ints[T_OWN, 1] + ints[k, P_ROW], 0]
    distance = _geom_distance(bind[B_MODEL], bind[B_DATA], geom, ints[k, P_OTHER], DISTANCE_CAP, 0)
    return (distance - floats[k, P_EXTRA]) * floats[k, P_SCALE]


@njit(cache=True)
def _fresh_bounds(bind, ints, floats, state, centres, bounds):
    """Read the posed geom centres into the state (at ``centres``), and every pair's lower bound from them (at
    ``bounds``; -inf where it is not positive: no bound)."""
    geom_xpos = _array(bind, B_GEOM_XPOS, bind[B_NGEOM], 3)
    own, pairs = ints[T_OWN, 1], ints[T_PAIR, 1]
    for g in range(ints[T_OWN, 0]):
        for i in range(3):
            state[centres + 3 * g + i] = geom_xpos[ints[own + g, 0], i]
    for k in range(ints[T_PAIR, 0]):
        r = pairs + k
        at = centres + 3 * ints[r, P_ROW]
        c0, c1, c2 = state[at], state[at + 1], state[at + 2]
        kind = ints[r, P_KIND]
        if kind == OWN:
            at = centres + 3 * ints[r, P_OTHER_ROW]
            length = floats[r, P_SCALE] * math.sqrt((c0 - state[at]) ** 2 + (c1 - state[at + 1]) ** 2
                                                    + (c2 - state[at + 2]) ** 2)
        elif kind == PLANE:  # the height above the plane (its normal: the frame's third column)
            height = c0 * floats[r, P_FRAME + 2] + c1 * floats[r, P_FRAME + 5] + c2 * floats[r, P_FRAME + 8]
            length = max(height - floats[r, P_CENTRE], 0.0)
        elif kind == BOX:  # what of the centre, in the box's frame, lies outside the box
            s = 0.0
            for i in range(3):
                local = c0 * floats[r, P_FRAME + i] + c1 * floats[r, P_FRAME + 3 + i] + c2 * floats[r, P_FRAME + 6 + i]
                outside = max(abs(local - floats[r, P_CENTRE + i]) - floats[r, P_SIZE + i], 0.0)
                s += outside * outside
            length = math.sqrt(s)
        else:
            length = math.sqrt((c0 - floats[r, P_CENTRE]) ** 2 + (c1 - floats[r, P_CENTRE + 1]) ** 2
                               + (c2 - floats[r, P_CENTRE + 2]) ** 2)
        bound = length - floats[r, P_RADII]
        state[bounds + k] = bound if bound > 0.0 else -np.inf


@njit(cache=True, inline="always")
def _min_distance(q, bind, ints, floats, state):
    """The smallest exact pair distance at ``q`` (MuJoCo's mj_geomDistance, (distance - extra) x scale).

    Each pair's lower bound is the larger of two: from the geom centres (bounding spheres, boxes, planes), and the
    bound the last query left (its exact distance, where it queried the pair) less how far the pair's geoms can
    have moved since (each point of a geom moves at most its centre's displacement plus the geom's turn times its
    bounding radius; the turn of link L is at most the sum of |dq| over the joints before it; two geoms of the
    robot move relative to each other only by the joints between them). A bound that is not positive bounds
    nothing (a penetration depth is not bounded so). Pairs are queried exactly in the order of their bounds until
    the next bound clears the nearest distance found by BOUND_SLACK: the answer is the smallest exact distance of
    every pair, whatever the bounds. The query's bounds (exact where queried) are kept for the next."""
    pose(q, bind, ints, floats)
    n_q, n_own, n = len(q), ints[T_OWN, 0], ints[T_PAIR, 0]
    own, pairs = ints[T_OWN, 1], ints[T_PAIR, 1]
    centres_kept, kept, lb, centres, delta, moved, turn, _ = _offsets(n_q, n_own, n)
    _fresh_bounds(bind, ints, floats, state, centres, lb)
    if state[S_KEPT] != 0.0:
        state[turn] = 0.0
        for j in range(n_q):
            state[moved + j] = abs(q[j] - state[S_Q + j])
            state[turn + j + 1] = state[turn + j] + state[moved + j]
        for g in range(n_own):
            d0 = state[centres + 3 * g] - state[centres_kept + 3 * g]
            d1 = state[centres + 3 * g + 1] - state[centres_kept + 3 * g + 1]
            d2 = state[centres + 3 * g + 2] - state[centres_kept + 3 * g + 2]
            turned = state[turn + ints[own + g, 1]] * floats[own + g, 0]
            state[delta + g] = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) + turned
        for k in range(n):
            before = state[kept + k]
            if not before > 0.0:
                continue
            r = pairs + k
            row = ints[r, P_ROW]
            if ints[r, P_KIND] == OWN:  # what each geom moves, or what one moves relative to the other
                a = ints[r, P_LINK_A]
                relative = 0.0
                for j in range(a, ints[r, P_LINK_B]):
                    relative += floats[r, P_REACH + j - a] * state[moved + j]
                low = before - floats[r, P_SCALE] * min(state[delta + row] + state[delta + ints[r, P_OTHER_ROW]],
                                                        relative)
            else:
                low = before - state[delta + row]
            if low > 0.0 and low > state[lb + k]:
                state[lb + k] = low
    best = np.inf
    while True:
        first, bound = -1, np.inf  # a queried pair's bound is set to inf: it is not picked again
        for k in range(n):
            if state[lb + k] < bound:
                first, bound = k, state[lb + k]
        if first < 0 or bound >= max(best, 0.0) + BOUND_SLACK:  # none of the rest can be nearer
            break
        exact = _exact(bind, ints, floats, pairs + first)
        state[kept + first] = exact if exact > 0.0 else -np.inf
        state[lb + first] = np.inf
        if exact < best:
            best = exact
    for k in range(n):
        if state[lb + k] != np.inf:
            state[kept + k] = state[lb + k]
    state[S_KEPT] = 1.0
    for j in range(n_q):
        state[S_Q + j] = q[j]
    for i in range(3 * n_own):
        state[centres_kept + i] = state[centres + i]
    return best


@njit(cache=True)
def min_distance(q, bind, ints, floats, state):
    """_min_distance, called on its own (the advancement compiles its own copy inline: its step loop is the hot
    path; the kinematics and bounds stay calls, which cost little and compile once)."""
    return _min_distance(q, bind, ints, floats, state)


@njit(cache=True)
def advance(q0, dq, reach_per_t, t, margin, bind, ints, floats, state):
    """Conservative advancement along q0 + t dq from ``t`` to 1, as MotionValidity states it: (clear, queries)."""
    q = np.empty(len(q0))
    queries = 0
    while True:
        queries += 1
        for i in range(len(q0)):
            q[i] = q0[i] + t * dq[i]
        d = _min_distance(q, bind, ints, floats, state)
        if d < margin:
            return False, queries
        if t >= 1.0 or reach_per_t == 0.0:
            return True, queries
        t = min(1.0, t + (d - 0.5 * margin) / reach_per_t)


@njit(cache=True)
def min_distances(qs, bind, ints, floats, state):
    out = np.empty(len(qs))
    for b in range(len(qs)):
        out[b] = min_distance(qs[b], bind, ints, floats, state)
    return out


@njit(cache=True)
def collides(q, margin, bind, ints, floats, state):
    """Whether any pair is closer than ``margin``: the pairs whose centre bound does not clear it, in order, each
    queried with MuJoCo's distance capped 1 mm (in the pair's own units) beyond the margin; stops at the first.
    Uses only the state's scratch (what a query hands the next stays)."""
    pose(q, bind, ints, floats)
    n_own, n = ints[T_OWN, 0], ints[T_PAIR, 0]
    _, _, lb, centres, _, _, _, _ = _offsets(len(q), n_own, n)
    _fresh_bounds(bind, ints, floats, state, centres, lb)
    own, pairs = ints[T_OWN, 1], ints[T_PAIR, 1]
    for k in range(n):
        if state[lb + k] < margin + BOUND_SLACK:
            r = pairs + k
            scale, extra = floats[r, P_SCALE], floats[r, P_EXTRA]
            cap = min(max(margin + 1e-3 * scale, 0.0) / scale + extra, DISTANCE_CAP)
            geom = ints[own + ints[r, P_ROW], 0]
            if (_geom_distance(bind[B_MODEL], bind[B_DATA], geom, ints[r, P_OTHER], cap, 0) - extra) * scale < margin:
                return True
    return False
