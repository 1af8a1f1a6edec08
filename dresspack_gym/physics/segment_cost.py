"""The wear cost along the cable: the terms of thesis eq. (4.10) evaluated segment by segment (where C comes from)."""

from __future__ import annotations

import mujoco
import numpy as np

from ..stations.config import WearCostConfig
from ..stations.station import CableIndex
from .measures import ClearanceProbe
from .segment_state import SegmentState


def segment_clearances(probe: ClearanceProbe, data: mujoco.MjData, cable: CableIndex,
                       points: np.ndarray) -> np.ndarray:
    """(n + 1,) each segment's distance to the nearest obstacle [m], 0 in contact: the smaller of the exact
    distances of the edge capsules that meet at its vertex (the probe's query, one edge at a time)."""
    edges = np.array([probe.min_distance(data, cable, points[e:e + 2])[0] for e in range(len(points) - 1)])
    out = np.empty(len(points))
    out[0], out[-1] = edges[0], edges[-1]
    out[1:-1] = np.minimum(edges[:-1], edges[1:])
    return out


def segment_wear_cost(state: SegmentState, clearance: np.ndarray, cfg: WearCostConfig,
                      tensile_stiffness: float) -> np.ndarray:
    """(n + 1,) eq. (4.10) on each segment's own measures: w_k max(0, k_i - k0)^2 + w_F F_i^2 +
    w_d min(0, d_i - c)^2 + w_t max(0, |tau_i| - tau0)^2, with F_i the pull in the segment (EA x its strain, 0
    when compressed). The configuration's C takes each term at its worst segment, so the largest curvature and
    distance terms here are C's, and no segment's cost exceeds C."""
    tension = np.maximum(tensile_stiffness * state.strain, 0.0)
    return (cfg.w_curvature * np.maximum(state.curvature - cfg.curvature_threshold, 0.0) ** 2
            + cfg.w_tension * tension ** 2
            + cfg.w_distance * np.minimum(np.asarray(clearance) - cfg.clearance, 0.0) ** 2
            + cfg.w_twist * np.maximum(np.abs(state.twist_rate) - cfg.twist_threshold, 0.0) ** 2)
