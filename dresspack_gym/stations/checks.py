"""Checks a compiled station at Home: robots clear of each other, obstacles clear of the robots and their Home
cables, weld points on (not inside) the parts, and cables that fit above the floor. Each failure names the YAML
entry to change."""

from __future__ import annotations

import mujoco
import numpy as np

from ..errors import ConfigError

# Penetration allowed before a check fails [m]: geometry that only touches (a cable resting on a part, a weld
# point placed on a surface from rounded CAD coordinates) is legitimate, overlap beyond this is a modelling error.
OVERLAP_TOL = 0.005
WELD_DEPTH_TOL = 0.01
# The Home shape (cable_shape.reference_shape) ignores the floor: a cable that ends up lying on the floor starts
# partly below it and settles onto it (a 6 m thesis cable: 23 % below, settles); much more (8 m: 47 %) never does.
FLOOR_FRACTION = 0.25  # a weld point is the TCP on the part's surface; 1 cm inside means a wrong coordinate


class _Probe:
    """Signed distances of capsules and points to one station's geoms, on a private MjData posed at Home."""

    def __init__(self, station):
        m = station.model
        self.model = m
        self.data = station.data_at_home()
        self.probe = m.geom("clearance_probe").id
        self._fromto = np.zeros(6)
        self._quat = np.zeros(4)
        self._rot = np.zeros(9)

    def geoms(self, a: int, b: int, distmax: float = 1.0) -> float:
        return mujoco.mj_geomDistance(self.model, self.data, a, b, distmax, self._fromto)

    def capsule(self, p0, p1, radius: float, geom: int, distmax: float = 1.0) -> float:
        """Signed distance from the capsule p0-p1 of ``radius`` to ``geom`` (negative: overlap depth)."""
        d = self.data
        axis = np.asarray(p1, float) - np.asarray(p0, float)
        d.geom_xpos[self.probe] = 0.5 * (np.asarray(p0, float) + np.asarray(p1, float))
        mujoco.mju_quatZ2Vec(self._quat, axis if np.linalg.norm(axis) > 1e-12 else np.array([0.0, 0.0, 1.0]))
        mujoco.mju_quat2Mat(self._rot, self._quat)
        d.geom_xmat[self.probe] = self._rot
        size = self.model.geom_size[self.probe]
        saved = size.copy()
        size[0], size[1] = radius, max(0.5 * np.linalg.norm(axis), 1e-6)
        try:
            return self.geoms(self.probe, geom, distmax)
        finally:
            size[:] = saved


def check_station(station) -> None:
    """Raise a ConfigError naming the entry if the station is physically inconsistent at Home."""
    cfg = station.config
    probe = _Probe(station)
    m = station.model
    obstacles = [(i, o, m.geom(f"obstacle/{o.name}").id) for i, o in enumerate(cfg.obstacles)]
    link_of = {}
    for robot in station.robots:
        for g, link in zip(robot.geom_ids, robot.geom_links):
            link_of[int(g)] = (robot.name, "base" if link == 0 else f"link{link}")
    for i, o, og in obstacles:
        for robot in station.robots:
            for g in robot.geom_ids:
                depth = probe.geoms(int(g), og)
                if depth < -OVERLAP_TOL:
                    name, link = link_of[int(g)]
                    raise ConfigError(f"obstacles[{i}]", f"obstacle {o.name!r} overlaps robot {name!r} ({link}) at "
                                                         f"Home by {-1000 * depth:.0f} mm: move the obstacle, the "
                                                         f"robot's base_pos or its home_deg")
    for j, b in enumerate(station.robots):
        for a in station.robots[:j]:
            for ga in a.geom_ids:
                for gb in b.geom_ids:
                    depth = probe.geoms(int(ga), int(gb))
                    if depth < -OVERLAP_TOL:
                        raise ConfigError(f"robots[{j}].base_pos",
                                          f"robot {b.name!r} overlaps robot {a.name!r} at Home ({link_of[int(gb)][1]} "
                                          f"in {link_of[int(ga)][1]}, {-1000 * depth:.0f} mm): move its base_pos "
                                          f"or change a home_deg")
    for k, (placement, shape) in enumerate(zip(cfg.robots, station.home_cable_shapes)):
        radius = placement.dresspack.radius
        seg = np.linalg.norm(np.diff(shape, axis=0), axis=1)
        below = float(seg[0.5 * (shape[1:, 2] + shape[:-1, 2]) < 0.0].sum())
        if cfg.floor and below > FLOOR_FRACTION * seg.sum():
            raise ConfigError(f"robots[{k}].dresspack.length",
                              f"{below:.2f} m of the {placement.dresspack.length:g} m cable of robot {placement.name!r} "
                              f"would start below the floor at Home (more than {FLOOR_FRACTION:.0%} of it): it is "
                              f"too long for where its nodes are (shorten it or move the nodes)")
        for i, o, og in obstacles:
            for e in range(len(shape) - 1):
                depth = probe.capsule(shape[e], shape[e + 1], radius, og)
                if depth < -max(OVERLAP_TOL, radius):
                    raise ConfigError(f"obstacles[{i}]",
                                      f"obstacle {o.name!r} cuts through the Home cable of robot {placement.name!r} "
                                      f"({(e + 0.5) * placement.dresspack.segment_length:.2f} m along it, "
                                      f"{-1000 * depth:.0f} mm deep): the cable would start inside it")
    for j, w in enumerate(cfg.weld_points):
        for i, o, og in obstacles:
            depth = probe.capsule(w.pos, w.pos, 1e-4, og)
            if depth < -WELD_DEPTH_TOL:
                raise ConfigError(f"weld_points[{j}].pos",
                                  f"weld point {w.name!r} lies {-1000 * depth:.0f} mm inside obstacle {o.name!r}: a "
                                  f"weld point is the tool tip on the part's surface (check the coordinates)")
