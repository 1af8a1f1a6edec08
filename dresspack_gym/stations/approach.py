"""Approach configurations of a goal: free configurations around it from which a straight segment enters it."""

from __future__ import annotations

import math

import numpy as np

from .validity import MotionValidity

# Candidates drawn around a goal. Welds in a pocket of the body admit only a narrow cone of straight entries: on the
# default station's hardest drawn welds 1 in 7 to 1 in 200 draws within 45 deg has a free segment into the
# weld, so 256 draws find a few on all but the narrowest (drawn_21 gets none), at ~0.1 s a goal.
APPROACH_SAMPLES = 256
SEGMENT_BATCH = 32  # candidates whose segments are checked together
CHOICE_POOL = 4  # free candidates per approach wanted before the choice (clearest, then most spread)


def goal_seed(goal: np.ndarray) -> np.ndarray:
    """The draw's seed: the goal itself (rounded to 1e-6 rad), so a goal's approaches are the same whatever ran
    before, in any env and process."""
    rounded = np.round(np.asarray(goal, dtype=float), 6) + 0.0  # + 0.0 folds -0.0 into 0.0
    return np.frombuffer(rounded.tobytes(), dtype=np.uint32)


def approach_configurations(validity: MotionValidity, goal: np.ndarray, count: int, reach: float,
                            samples: int = APPROACH_SAMPLES) -> np.ndarray:
    """Up to ``count`` configurations within ``reach`` [rad] of ``goal`` (per joint) whose straight segment into
    ``goal`` is free (limits and restrictions every ``validity.resolution``, collisions continuously, as the env's
    masks check a move): the clearest first, then each the farthest (largest joint change) from those chosen, so
    they open different ways in. Fewer (possibly none) where fewer exist. Shape (k, 6), k <= count."""
    goal = np.asarray(goal, dtype=float)
    rng = np.random.default_rng(goal_seed(goal))
    cands = goal + rng.uniform(-reach, reach, size=(samples, 6))
    # limits and restrictions along each segment (cheap, all samples of all segments in one batch)
    n = max(1, math.ceil(reach / validity.resolution))
    s = np.linspace(0.0, 1.0, n + 1)[1:]
    along = (goal + s[None, :, None] * (cands - goal)[:, None, :]).reshape(-1, 6)
    ok = (validity.within_limits(along) & validity.restrictions.allowed(along)).reshape(samples, n).all(axis=1)
    cands = cands[ok]
    # the ends first (one batch of distance queries): most draws end inside the part or another panel
    clearance = validity.checker.min_distances(cands) if len(cands) else np.zeros(0)
    free = clearance >= validity.checker.margin
    cands, clearance = cands[free], clearance[free]
    # goal -> candidate in lockstep batches, in draw order, until there are enough to choose from: an open goal
    # is done after a batch, a weld in a pocket (few free entries) looks at every draw
    clear = np.zeros(len(cands), dtype=bool)
    for start in range(0, len(cands), SEGMENT_BATCH):
        clear[start:start + SEGMENT_BATCH] = validity.segments_clear(goal, cands[start:start + SEGMENT_BATCH])
        if clear.sum() >= CHOICE_POOL * count:
            break
    cands, clearance = cands[clear], clearance[clear]
    if not len(cands):
        return np.zeros((0, 6))
    chosen: list[np.ndarray] = []
    spread = np.full(len(cands), np.inf)  # each candidate's joint distance to the nearest one chosen
    left = np.ones(len(cands), dtype=bool)
    while len(chosen) < count and left.any():
        score = np.where(left, clearance if not chosen else spread, -np.inf)
        k = int(np.argmax(score))
        left[k] = False
        # the move the masks will check is candidate -> goal: advancement from that end takes other samples
        if validity.segment_clear(cands[k], goal):
            chosen.append(cands[k])
            spread = np.minimum(spread, np.max(np.abs(cands - cands[k]), axis=1))
    return np.array(chosen).reshape(-1, 6)
