"""The wear map as a state cost: eq. (4.10) on the map's predicted free cable at a configuration, with the
clearance of that shape computed exactly against the station's obstacles, plus an obstruction term where the
free shape would pass through a solid obstacle (there the real cable is caught and the map cannot predict it; a
plane such as the floor only supports it)."""

from __future__ import annotations

import mujoco
import numpy as np

from ..physics.fatigue import peak_excursion_damage
from ..physics.measures import ClearanceProbe, WearMeasures
from ..physics.wear_cost import cost_function
from ..stations.station import Station
from .wear_map import WearMap

# Cost rate [1/s] of a configuration whose free cable passes this deep into an obstacle, and of one whose
# nodes the cable cannot span at all: such states are to be avoided, not traded against seconds of motion.
OBSTRUCTION_DEPTH = 0.05  # m: the obstruction term is OBSTRUCTION_RATE * (depth / OBSTRUCTION_DEPTH)^2
OBSTRUCTION_RATE = 10.0
UNSPANNABLE_RATE = 1e3


class MapStateCost:
    """``cost(q)`` [1/s]: the cheap, path-independent wear cost rate of robot configuration ``q`` (6,), cached.

    ``terms(q)`` names its parts: the (4.10) terms of the chosen cost variant on the predicted measures and
    exact clearance, ``obstruction``, and ``unspannable`` (1e3 where the cable cannot reach)."""

    def __init__(self, station: Station, wear_map: WearMap, robot: int = 0, cost_variant: str = "thesis"):
        self.station, self.map, self.robot = station, wear_map, robot
        self.cost_fn = cost_function(cost_variant)
        self.cfg = station.config.wear_cost
        self.cable = station.cables[robot]
        self.dresspack = station.config.robots[robot].dresspack
        self.probe = ClearanceProbe(station)
        self.data = mujoco.MjData(station.model)  # obstacles are static: one kinematics pass places them
        mujoco.mj_kinematics(station.model, self.data)
        self.queries = 0
        self._cache: dict[bytes, dict[str, float]] = {}

    def terms(self, q) -> dict[str, float]:
        q = np.asarray(q, dtype=float)
        key = q.tobytes()
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        self.queries += 1
        pred = self.map.predict(q)
        if pred is None:
            out = {"unspannable": UNSPANNABLE_RATE}
        else:
            clearance, _, nearest = self.probe.min_distance(self.data, self.cable, pred.points, signed=True)
            m = WearMeasures(pred.max_curvature, pred.max_tension, max(clearance, 0.0), pred.max_twist_rate,
                             excursion_damage=peak_excursion_damage(pred.max_curvature, pred.max_twist_rate,
                                                                    pred.max_tension, self.dresspack))
            out = self.cost_fn(m, self.cfg).terms()
            # A plane (the floor) only supports a sagging cable, it cannot catch it: only solids obstruct. The
            # solids are queried again only when the deepest penetration is a plane's.
            solid = clearance
            if clearance < 0 and nearest in self.probe.plane_names:
                solid = self.probe.min_distance(self.data, self.cable, pred.points, signed=True, planes=False)[0]
            out["obstruction"] = OBSTRUCTION_RATE * (min(solid, 0.0) / OBSTRUCTION_DEPTH) ** 2
        self._cache[key] = out
        return out

    def cost(self, q) -> float:
        return float(sum(self.terms(q).values()))
