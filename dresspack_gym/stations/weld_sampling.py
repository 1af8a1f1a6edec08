"""Weld points drawn on the station's parts, for goal-conditioned tasks: a point on a face of a box obstacle tagged
``part: true``, the gun approaching against the face's outward normal tilted within a cone, kept only if one of its
IK branches passes the filters every planner's weld goals pass (joint limits, restrictions, robustness map, no
collision with the station)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError, KinematicsError
from ..fields import check_integer, check_number
from ..robots.kinematics import rpy_matrix, weld_configurations
from .config import Obstacle, WeldPoint
from .station import Station
from .tasks import allowed_weld_configurations


@dataclass(frozen=True)
class WeldSampling:
    """How weld points are drawn: approach tilt from the face normal, the spins tried about the approach (a stud
    gun is symmetric), draws before giving up, and the smallest face dimension worth welding on."""

    tilt_max: float = math.radians(20.0)
    spin: tuple[float, ...] = field(default_factory=lambda: tuple(np.radians(np.arange(0.0, 360.0, 30.0))))
    tries: int = 500
    min_face: float = 0.02  # [m] faces thinner than this (a sheet's edge) are not welded on

    def __post_init__(self):
        check_number(self.tilt_max, "weld_sampling.tilt_max", lo=0.0, hi=math.radians(80.0), unit="rad")
        check_integer(self.tries, "weld_sampling.tries", lo=1)
        if not self.spin:
            raise ConfigError("weld_sampling.spin", "give at least one spin angle")


@dataclass(frozen=True)
class Face:
    """One rectangular face of a box part: centre, outward normal, two in-plane half-extent vectors."""

    part: str
    centre: np.ndarray
    normal: np.ndarray
    u: np.ndarray
    v: np.ndarray

    @property
    def area(self) -> float:
        return 4.0 * float(np.linalg.norm(self.u) * np.linalg.norm(self.v))


def part_faces(obstacles: tuple[Obstacle, ...], min_face: float = 0.0) -> list[Face]:
    """The faces of every box tagged as a part (both in-plane extents at least ``min_face``)."""
    faces = []
    for o in obstacles:
        if not o.part:
            continue
        rot, c, h = rpy_matrix(o.rpy), np.asarray(o.pos, dtype=float), np.asarray(o.size, dtype=float)
        for axis in range(3):
            a, b = [k for k in range(3) if k != axis]
            if 2 * min(h[a], h[b]) < min_face:
                continue
            for sign in (1.0, -1.0):
                n = sign * rot[:, axis]
                faces.append(Face(o.name, c + h[axis] * n, n, h[a] * rot[:, a], h[b] * rot[:, b]))
    return faces


@dataclass(frozen=True)
class SampledWeld:
    """A drawn weld point and the IK branches of it that pass every filter (at least one)."""

    weld: WeldPoint
    face: Face
    configurations: np.ndarray


class WeldSampler:
    """Draws weld points for robot ``robot`` of ``station`` (``collides(q)``: its robot-station collision query)."""

    def __init__(self, station: Station, robot: int, collides, settings: WeldSampling = WeldSampling()):
        self.station = station
        self.robot = station.check_robot(robot)
        self.collides = collides
        self.settings = settings
        self.placement = station.config.robots[self.robot]
        self.kinematics = station.robots[self.robot].kinematics
        self.faces = part_faces(station.config.obstacles, settings.min_face)
        if not self.faces:
            raise ConfigError("obstacles", f"station {station.config.name!r} has no box obstacle tagged 'part: true' "
                                           "to draw weld points on")
        self._weights = np.array([f.area for f in self.faces])
        self._weights /= self._weights.sum()

    def sample(self, rng: np.random.Generator, name: str = "sampled") -> SampledWeld:
        """A weld point drawn area-uniformly over the parts' faces with a uniformly tilted approach, redrawn until
        one passes; a ConfigError after ``tries`` draws (the parts are out of this robot's reach)."""
        s = self.settings
        for _ in range(s.tries):
            face = self.faces[int(rng.choice(len(self.faces), p=self._weights))]
            a, b = rng.uniform(-1.0, 1.0, 2)
            pos = face.centre + a * face.u + b * face.v
            approach = tilted(-face.normal, s.tilt_max, rng)
            weld = WeldPoint(name, self.placement.name, tuple(pos.tolist()), tuple(approach.tolist()), s.spin)
            if self._inside_another_part(pos, face.part):
                continue
            try:
                q = weld_configurations(self.kinematics, weld)
            except KinematicsError:
                continue
            q = allowed_weld_configurations(self.station, self.robot, name, self.collides, q=q)
            if len(q):
                return SampledWeld(weld, face, q)
        raise ConfigError("weld_sampling.tries", f"no weld point on the parts of {self.station.config.name!r} passed "
                                                 f"for robot {self.placement.name!r} in {s.tries} draws")

    def _inside_another_part(self, pos: np.ndarray, own: str) -> bool:
        """A face point covered by another obstacle (a joint between parts) is not weldable."""
        for o in self.station.config.obstacles:
            if o.name == own or o.type != "box":
                continue
            local = rpy_matrix(o.rpy).T @ (pos - np.asarray(o.pos))
            if np.all(np.abs(local) < np.asarray(o.size) - 1e-9):
                return True
        return False


def tilted(direction: np.ndarray, max_angle: float, rng: np.random.Generator) -> np.ndarray:
    """A unit vector within ``max_angle`` of ``direction``, uniform over that spherical cap."""
    d = direction / np.linalg.norm(direction)
    cos_t = rng.uniform(math.cos(max_angle), 1.0)
    phi = rng.uniform(0.0, 2 * math.pi)
    ref = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(d, ref)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    sin_t = math.sqrt(max(0.0, 1.0 - cos_t ** 2))
    return cos_t * d + sin_t * (math.cos(phi) * e1 + math.sin(phi) * e2)
