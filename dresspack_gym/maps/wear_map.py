"""The settled-shape wear map: the cable's free equilibrium (cable alone) at sampled robot configurations,
stored with its wear measures and interpolated as a cheap, path-independent state cost for global planners.

Without obstacles and contacts, a settled cable's shape depends only on where its nodes are relative to each
other and to gravity (thesis eq. 4.8 names v = (Ry, j4, j5, j6) for a link 3 - link 6 dresspack). The map
therefore keys every sample by *shape features*: each node's pose in the frame of the first node's body, and
gravity in that frame. A query interpolates (inverse distance, nearest samples in feature space) the settled
shape's deviation from the analytic reference curve through the query's own nodes, so the nodes are always
exact and only the sag and bulge are interpolated. The map holds no obstacles, so one map serves every
station variant with the same robot and dresspack; clearance is computed exactly at query time.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..cable.shape import reference_shape
from ..errors import ConfigError
from ..io.artefacts import reading
from ..io.outputs import replacing
from ..physics.profiles import DEFAULT_ENGINE, ENGINES, make_simulator
from ..shipped import shipped_root
from ..stations.config import StationConfig
from ..stations.station import DOWN, Station, node_frames
from .robustness.algorithm import cable_only

MAP_VERSION = 1
# Points of each reference span's curve (the simulator's initial shapes use 2001; the map needs speed, and its
# deviations are measured against this same curve, so the coarser curve costs no accuracy).
REFERENCE_RESOLUTION = 201
MAX_SAMPLES = 1_000_000


@dataclass(frozen=True)
class WearMapSettings:
    """How a wear map is sampled and queried.

    ``samples``: robot configurations drawn uniformly in the joint limits (work units; those whose nodes the
    cable cannot span are skipped, not settled). ``neighbours``: samples blended per query. ``lever`` [m]: a
    node's orientation counts in the feature distance like a displacement of its axes' tips at this lever."""

    samples: int = 16000
    seed: int = 0
    neighbours: int = 6
    lever: float = 0.3

    def __post_init__(self):
        checks = {
            "samples": (isinstance(self.samples, int) and 1 <= self.samples <= MAX_SAMPLES,
                        f"an integer in [1, {MAX_SAMPLES}]"),
            "seed": (isinstance(self.seed, int) and self.seed >= 0, "an integer >= 0"),
            "neighbours": (isinstance(self.neighbours, int) and 1 <= self.neighbours <= 64, "an integer in [1, 64]"),
            "lever": (isinstance(self.lever, (int, float)) and 0.0 < self.lever <= 10.0, "a length in (0, 10] m"),
        }
        for name, (ok, allowed) in checks.items():
            if not ok:
                raise ConfigError(f"wear_map.{name}", f"{getattr(self, name)!r} is not allowed: must be {allowed}")


@dataclass(frozen=True)
class MapPrediction:
    """The map's answer at one configuration: the cable's free settled shape (world, one point per vertex), its
    largest curvature [1/m], tension [N] and twist rate [rad/m], and the feature distance to the nearest sample
    (how far the map had to reach)."""

    points: np.ndarray
    max_curvature: float
    max_tension: float
    max_twist_rate: float
    reach: float


class ShapeModel:
    """Shape features and the reference curve of one robot's dresspack (no simulation)."""

    def __init__(self, config: StationConfig, robot: int = 0, lever: float = WearMapSettings.lever):
        self.station = Station(cable_only(config))  # the map is the free cable's: no obstacles, no contact
        self.robot = self.station.check_robot(robot)
        self.placement = self.station.config.robots[self.robot]
        self.kinematics = self.station.robots[self.robot].kinematics
        self.lever = float(lever)

    def frames(self, q: np.ndarray) -> list[np.ndarray]:
        return node_frames(self.placement, self.kinematics.link_frames(q))

    def features(self, frames: list[np.ndarray]) -> np.ndarray:
        """Each later node's position and two axis tips (x lever) in the first node's body frame, and gravity
        (x lever) in that frame."""
        ref = frames[0]
        inv = ref[:3, :3].T
        out = []
        for f in frames[1:]:
            rot = inv @ f[:3, :3]
            out += [inv @ (f[:3, 3] - ref[:3, 3]), rot[:, 0] * self.lever, rot[:, 1] * self.lever]
        out.append(inv @ DOWN * self.lever)
        return np.concatenate(out)

    def reference(self, frames: list[np.ndarray]) -> np.ndarray | None:
        """The analytic reference curve through the nodes, or None if the cable cannot span them."""
        try:
            return reference_shape(self.placement.dresspack, frames, DOWN, resolution=REFERENCE_RESOLUTION)
        except ConfigError:
            return None


def map_key(config: StationConfig, robot: int = 0, engine: str = "dynamic") -> str:
    """What the map depends on: the robot's kinematic chain and joint limits (where samples are drawn), its base
    pose, its dresspack, the physics and gravity, and the engine that settled it (physics.profiles.ENGINES); not the
    robot's name, tool, speeds, collision geometry (the map settles the cable alone) or controller conventions, nor
    the obstacles, weld points or other robots. MuJoCo's ("dynamic") key leaves the engine out: the maps settled
    on it before engines were chosen keep theirs."""
    p = config.robots[robot]
    arm = p.robot.kinematics if p.robot.chain is None else p.robot.chain
    what = repr((MAP_VERSION, arm, p.robot.joint_limits_rad, p.base_pos, p.base_yaw, p.dresspack, config.simulation)
                + (() if engine == "dynamic" else (engine,)))
    return hashlib.sha256(what.encode()).hexdigest()[:16]


class WearMap:
    """Settled samples of one robot's dresspack; :meth:`predict` interpolates them at any configuration."""

    def __init__(self, model: ShapeModel, settings: WearMapSettings, configurations: np.ndarray,
                 features: np.ndarray, deviation: np.ndarray, measures: np.ndarray, converged: np.ndarray, info: dict):
        self.model, self.settings = model, settings
        self.configurations = np.asarray(configurations, dtype=float)  # (N, 6) the settled robot configurations
        self.features = np.asarray(features, dtype=float)
        self.deviation = np.asarray(deviation, dtype=float)
        self.measures = np.asarray(measures, dtype=float)  # (N, 3): curvature, tension, twist rate
        self.converged = np.asarray(converged, dtype=bool)
        self.info = info
        if len(self.features) == 0:
            raise ConfigError("wear_map.samples", f"none of the {settings.samples} sampled configurations lets the "
                                                  "cable span its nodes: draw more samples")
        self._sq = np.einsum("ij,ij->i", self.features, self.features)

    def __len__(self) -> int:
        return len(self.features)

    def predict(self, q) -> MapPrediction | None:
        """The free cable at robot configuration ``q`` (6,), or None where the cable cannot span its nodes."""
        frames = self.model.frames(np.asarray(q, dtype=float))
        base = self.model.reference(frames)
        if base is None:
            return None
        f = self.model.features(frames)
        d2 = np.maximum(self._sq - 2.0 * self.features @ f + f @ f, 0.0)
        k = min(self.settings.neighbours, len(d2))
        idx = np.argpartition(d2, k - 1)[:k] if k < len(d2) else np.arange(len(d2))
        dist = np.sqrt(d2[idx])
        if dist.min() < 1e-12:  # on a sample: its own values
            w = (dist < 1e-12).astype(float)
        else:
            w = 1.0 / dist ** 2
        w /= w.sum()
        points = base + np.tensordot(w, self.deviation[idx], axes=1)
        kappa, tension, twist = w @ self.measures[idx]
        return MapPrediction(points, float(kappa), float(tension), float(twist), float(dist.min()))

    # ------------------------------------------------------------------------------ files
    def save(self, path: str | Path) -> Path:
        path = Path(path)
        with replacing(path) as tmp:  # never a half-written map under the real name
            np.savez_compressed(tmp, configurations=self.configurations, features=self.features.astype(np.float32),
                                deviation=self.deviation.astype(np.float32),
                                measures=self.measures.astype(np.float32), converged=self.converged,
                                info=np.array(json.dumps({**self.info, "settings": asdict(self.settings)})))
        return path

    @staticmethod
    def load(path: str | Path, config: StationConfig, robot: int = 0) -> "WearMap":
        what = "wear map (.npz of `dresspack wear-map`)"
        recover = "build it again with `dresspack wear-map`"
        with reading(path, "wear_map", what, recover), np.load(Path(path), allow_pickle=False) as z:
            info = json.loads(str(z["info"]))
            settings = WearMapSettings(**info.pop("settings"))
            if info.get("key") != map_key(config, robot, info.get("engine", "dynamic")):
                raise ConfigError("wear_map", f"{path} was built for another robot, dresspack or physics "
                                              f"(key {info.get('key')}, this station needs {map_key(config, robot)})")
            return WearMap(ShapeModel(config, robot, settings.lever), settings, z["configurations"], z["features"],
                           z["deviation"],
                           z["measures"], z["converged"], info)


def sample_configurations(limits: np.ndarray, settings: WearMapSettings) -> np.ndarray:
    """The configurations a map draws: uniform in the joint limits, from the map's own seed."""
    rng = np.random.default_rng([settings.seed, 17])
    return rng.uniform(limits[:, 0], limits[:, 1], size=(settings.samples, len(limits)))


def build_wear_map(config: StationConfig, robot: int = 0, settings: WearMapSettings = WearMapSettings(),
                   progress: bool = False, engine: str = DEFAULT_ENGINE) -> WearMap:
    """Settle the cable alone at every drawn configuration the cable can span on ``engine`` (one of
    physics.profiles.ENGINES) and record its shape and measures."""
    model = ShapeModel(config, robot, settings.lever)
    sim = make_simulator(model.station, engine)
    q_all = model.station.home.copy()
    qs = sample_configurations(model.placement.robot.joint_limits, settings)
    kept, feats, devs, meas, conv = [], [], [], [], []
    start = time.perf_counter()
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(qs), desc="wear map", unit="config")
    for q in qs:
        frames = model.frames(q)
        base = model.reference(frames)
        if base is not None:
            q_all[model.robot] = q
            sim.reset(q_all, settle=False)
            settled = sim.settle()
            m = sim.measures()
            kept.append(q)
            feats.append(model.features(frames))
            devs.append(sim.cable_points(model.robot) - base)
            meas.append((m.max_curvature, m.max_tension, m.max_twist_rate))
            conv.append(settled.converged)
        if bar is not None:
            bar.update()
    if bar is not None:
        bar.close()
    info = {"key": map_key(config, robot, engine), "engine": engine, "station": config.name,
            "robot": config.robots[robot].name,
            "drawn": len(qs), "settled": len(feats), "unconverged": int(len(conv) - sum(conv)),
            "build_seconds": round(time.perf_counter() - start, 1)}
    return WearMap(model, settings, np.array(kept).reshape(-1, 6), np.array(feats).reshape(len(feats), -1),
                   np.array(devs).reshape(len(devs), -1, 3), np.array(meas).reshape(-1, 3), np.array(conv, bool),
                   info)


def shipped_map_path(config: StationConfig, robot: int = 0, engine: str = "dynamic") -> Path:
    """Where a shipped map for this robot and dresspack settled on ``engine`` lives (``configs/wear_maps/<key>.npz``),
    present or not.
    Only shipped or explicitly named maps are used: a map found in some cache would make a plan depend on
    the machine's history."""
    return shipped_root() / "wear_maps" / f"{map_key(config, robot, engine)}.npz"


def load_wear_map(config: StationConfig, robot: int = 0, path: str | Path | None = None) -> WearMap | None:
    """The map at ``path``, else the shipped one for this robot and dresspack (settled on the default engine, else
    on any other, in ENGINES' order), else None."""
    if path is not None:
        if not Path(path).is_file():
            raise ConfigError("wear_map", f"{path} is not a file (build one with: dresspack wear-map STATION "
                                          "--out PATH)")
        return WearMap.load(path, config, robot)
    for engine in (DEFAULT_ENGINE, *(e for e in ENGINES if e != DEFAULT_ENGINE)):
        shipped = shipped_map_path(config, robot, engine)
        if shipped.is_file():
            return WearMap.load(shipped, config, robot)
    return None
