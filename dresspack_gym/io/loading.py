"""YAML edge of the package: reads station/robot/dresspack files into frozen config dataclasses."""

from __future__ import annotations

import copy
from dataclasses import replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from ..cable.config import DresspackConfig
from ..errors import ConfigError
from ..fields import Section, check_unique
from ..robots.config import RobotConfig
from ..robots.joint_limits import check_within_limits
from ..robots.model import MAX_ROBOTS
from ..robots.restrictions import RestrictionSet
from ..shipped import find_shipped, shipped_names, shipped_root
from ..stations.config import (
    RobotPlacement,
    SimulationConfig,
    StationConfig,
    WearCostConfig,
    obstacle_from_section,
    weld_point_from_section,
)

CONFIG_DIR = shipped_root()  # the shipped configs (robots/, dresspacks/, stations/, grids/, training/)


class _UniqueKeyLoader(yaml.SafeLoader):
    """YAML's safe loader, refusing a key given twice in one mapping (plain YAML keeps the last silently)."""

    def construct_mapping(self, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r} (first at line {seen[key] + 1})", key_node.start_mark)
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep)


def read_yaml(path: str | Path, field: str = "file") -> dict[str, Any]:
    path = Path(path)
    if not path.is_file():
        raise ConfigError(field, f"file not found: {path}")
    try:
        with path.open() as f:
            data = yaml.load(f, Loader=_UniqueKeyLoader)
    except yaml.YAMLError as exc:
        raise ConfigError(field, f"{path} is not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError(field, f"{path} must contain a mapping at the top level")
    return data


def list_stations() -> list[str]:
    return shipped_names("stations")


def list_robots() -> list[str]:
    return shipped_names("robots")


def resolve_station_path(ref: str | Path) -> Path:
    """Accept a YAML path or the name of a shipped station (``default``, ``thesis_curvature``...)."""
    return find_shipped(ref, "stations", "station")


def load_robot(ref: str | Path, base_dir: Path = CONFIG_DIR, field: str = "robot") -> RobotConfig:
    path = find_shipped(ref, "robots", field, base_dir=base_dir)
    data = read_yaml(path, field)
    if "model_file" in data:
        data = _robot_from_model_file(data, path, f"{path.name}")
    return RobotConfig.from_dict(data, path=f"{path.name}")


DERIVED_FROM_MODEL = ("kinematics", "chain", "joint_limits_deg", "controller_axes")


def _robot_from_model_file(data: dict[str, Any], yaml_path: Path, field: str) -> dict[str, Any]:
    """The robot YAML with kinematics, limits, controller axes (and speeds, if the YAML has none) derived from its
    ``model_file``: a URDF/MJCF path relative to the YAML, or ``{package, path}`` inside an installed package."""
    from ..robots.importer import (
        NotSphericalWrist,
        chain_from_model,
        derive,
        load_model,
        model_collision,
        urdf_velocities,
    )

    data = dict(data)
    ref = data.pop("model_file")
    f = f"{field}.model_file"
    for key in DERIVED_FROM_MODEL:
        if key in data:
            raise ConfigError(f"{field}.{key}", "is derived from model_file: leave it out of the YAML")
    model_path = _model_file_path(ref, yaml_path.parent, f)
    model = load_model(model_path)
    try:
        kin, sign, offset, limits = derive(model, f)
        data["kinematics"] = {k: getattr(kin, k) for k in ("a1", "d1", "a2", "a3", "d4", "d6")}
        data["controller_axes"] = {"sign": sign.tolist(), "offset_deg": np.degrees(offset).tolist()}
    except NotSphericalWrist:  # a general chain, solved numerically, in the model's own joint convention
        chain, limits = chain_from_model(model, f)
        data["chain"] = chain.as_yaml()
    data["joint_limits_deg"] = np.degrees(limits).tolist()
    if "joint_speed_deg_s" not in data:
        speeds = urdf_velocities(model_path)
        if speeds is None:
            raise ConfigError(f"{field}.joint_speed_deg_s", f"{model_path.name} gives no velocity limit for every "
                                                             "joint: state the 6 rated joint speeds in the YAML")
        data["joint_speed_deg_s"] = np.degrees(speeds).tolist()
    if data.get("collision") == "from_model":  # the maker's collision meshes, carried into our link frames
        data["collision"] = model_collision(model_path, model, RobotConfig.from_dict({**data, "collision": []}, field),
                                            f"{field}.collision")
    return data


def _model_file_path(ref: Any, base_dir: Path, field: str) -> Path:
    import importlib.util

    if isinstance(ref, str):
        path = base_dir / ref
    elif isinstance(ref, Mapping) and set(ref) == {"package", "path"}:
        spec = importlib.util.find_spec(str(ref["package"]))  # finds the package's folder without importing it
        if spec is None or not spec.submodule_search_locations:
            raise ConfigError(field, f"needs the Python package {ref['package']!r}, which is not installed "
                                     "(pip install 'dresspack-gym[robots]')")
        path = Path(list(spec.submodule_search_locations)[0]) / str(ref["path"])
    else:
        raise ConfigError(field, "expected a file path or {package: NAME, path: FILE IN THE PACKAGE}")
    if not path.is_file():
        raise ConfigError(field, f"file not found: {path}")
    return path


def _merge(base: dict[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for k, v in overrides.items():
        out[k] = copy.deepcopy(v)
    return out


def load_station(ref: str | Path) -> StationConfig:
    path = resolve_station_path(ref)
    return station_from_dict(read_yaml(path, "station"), base_dir=path.parent, label=path.name)


def station_from_dict(data: Mapping[str, Any], base_dir: Path = CONFIG_DIR / "stations",
                      label: str = "station") -> StationConfig:
    s = Section(data, "")
    name = s.string("name")
    description = s.string("description", "")
    robots = []
    for r in s.sections("robots"):
        rname = r.string("name", f"robot{len(robots)}")
        robot = load_robot(r.string("robot"), base_dir, r.field("robot"))
        dp_ref = r.raw("dresspack")
        if isinstance(dp_ref, str):
            dp_path = find_shipped(dp_ref, "dresspacks", r.field("dresspack"), base_dir=base_dir)
            dp_data = read_yaml(dp_path, r.field("dresspack"))
        elif isinstance(dp_ref, dict):
            dp_data = dp_ref
        else:
            raise ConfigError(r.field("dresspack"), "expected a dresspack name/path or an inline mapping")
        overrides = r.raw("dresspack_overrides", {})
        if not isinstance(overrides, dict):
            raise ConfigError(r.field("dresspack_overrides"), "expected a mapping of dresspack keys to values")
        dresspack = DresspackConfig.from_dict(_merge(dp_data, overrides), path=f"{r.field('dresspack')}")
        base_pos = r.vector("base_pos", 3, (0, 0, 0), lo=-500, hi=500, unit="m")
        base_yaw = float(np.radians(r.number("base_yaw_deg", 0.0, lo=-360, hi=360, unit="deg")))
        home = np.radians(r.vector("home_deg", 6, lo=-720, hi=720, unit="deg"))
        check_within_limits(home, robot.joint_limits, r.field("home_deg"), digits=1)
        restrictions = RestrictionSet.from_list(r.raw("restrictions", []), r.field("restrictions"))
        if not restrictions.allowed(home)[0]:
            raise ConfigError(r.field("home_deg"), f"Home violates the robot's joint restrictions: "
                                                    f"{restrictions.violated_by(home)}")
        robustness_map = _robustness_map(r, base_dir)
        r.done()
        robots.append(RobotPlacement(rname, robot, dresspack, base_pos, base_yaw, tuple(home.tolist()), restrictions,
                                     robustness_map))
    if not robots:
        raise ConfigError("robots", "a station needs at least one robot")
    if len(robots) > MAX_ROBOTS:
        raise ConfigError("robots", f"{len(robots)} robots: a station holds at most {MAX_ROBOTS}")
    names = [r.name for r in robots]
    check_unique(names, "robots", "robot")
    obstacles = tuple(obstacle_from_section(o) for o in s.sections("obstacles", []))
    check_unique([o.name for o in obstacles], "obstacles", "obstacle")
    obstacles = tuple(_absolute_mesh(o, base_dir) for o in obstacles)
    welds = tuple(weld_point_from_section(w, names) for w in s.sections("weld_points", []))
    welds += _weld_points_csv(s, base_dir, names)
    check_unique([w.name for w in welds], "weld_points", "weld point")
    for i, r in enumerate(robots):
        _check_some_weld_within_reach(r, i, welds)
    wear = WearCostConfig.from_dict(s.raw("wear_cost", {}), "wear_cost")
    sim = SimulationConfig.from_dict(s.raw("simulation", {}), "simulation")
    floor = s.boolean("floor", True)
    s.done()
    return StationConfig(name, description, tuple(robots), obstacles, welds, wear, sim, floor)


def _weld_points_csv(s: Section, base_dir: Path, robot_names: list[str]) -> tuple:
    """``weld_points_csv: FILE`` or ``{path: FILE, units: m|mm}``: weld points exported from a CAD/OLP tool or a
    spreadsheet, one per row (columns weld_csv.REQUIRED, optionally weld_csv.OPTIONAL); each error names the row
    and column."""
    from .weld_csv import LENGTH_UNITS, read_weld_rows

    ref = s.raw("weld_points_csv", None)
    if ref is None:
        return ()
    field = "weld_points_csv"
    units = "m"
    if isinstance(ref, dict):
        c = Section(ref, field)
        path_ref = c.string("path")
        units = c.string("units", "m", choices=list(LENGTH_UNITS))
        c.done()
    elif isinstance(ref, str):
        path_ref = ref
    else:
        raise ConfigError(field, "expected a CSV file path or a mapping {path, units: m|mm}")
    path = _resolve(path_ref, base_dir)
    if not path.is_file():
        raise ConfigError(field, f"file not found: {path}")
    return tuple(weld_point_from_section(Section(data, where), robot_names)
                 for where, data in read_weld_rows(path, field, units))


def arm_reach(robot: RobotConfig) -> float:
    """An upper bound [m] of the distance from the robot's base to its tool point: every link, the flange and the
    tool laid end to end."""
    chain = robot.chain if robot.chain is not None else robot.kinematics.joint_chain()
    links = sum(float(np.linalg.norm(o)) for o in chain.origins) + float(np.linalg.norm(chain.flange_pos))
    return links + float(np.linalg.norm(robot.tcp_pos))


def _check_some_weld_within_reach(placement: RobotPlacement, index: int, welds) -> None:
    """A robot none of whose weld points it could ever reach is a typing error (a base or weld position in
    millimetres read as metres), not a station: refused, naming the nearest weld point. A station where only
    some welds are out of reach loads (tasks on the others run; one that uses such a weld fails naming it)."""
    own = [w for w in welds if w.robot == placement.name]
    if not own:
        return
    base = np.asarray(placement.base_pos, dtype=float)
    distance = [float(np.linalg.norm(np.asarray(w.pos) - base)) for w in own]
    reach = arm_reach(placement.robot)
    if min(distance) > reach:
        near = own[int(np.argmin(distance))]
        raise ConfigError(f"robots[{index}].base_pos", f"robot {placement.name!r} at {list(placement.base_pos)} m "
                                                       f"reaches none of its {len(own)} weld point(s): the nearest, "
                                                       f"{near.name!r} at {list(near.pos)} m, is {min(distance):.3g} m "
                                                       f"away and the arm reaches at most {reach:.3g} m (millimetres "
                                                       f"given as metres?)")


def _robustness_map(r: Section, base_dir: Path):
    """``robustness_map: FOLDER`` or ``{path: FOLDER, threshold: m}``: a map from `dresspack robustness-map`."""
    from ..maps.robustness.query import RobustnessMap

    ref = r.raw("robustness_map", None)
    if ref is None:
        return None
    field = r.field("robustness_map")
    threshold = None
    if isinstance(ref, dict):
        m = Section(ref, field)
        path = m.string("path")
        if m.has("threshold"):
            threshold = m.number("threshold", lo=0.0, lo_open=True, hi=10.0, unit="m")
        m.done()
    elif isinstance(ref, str):
        path = ref
    else:
        raise ConfigError(field, "expected a map folder (string) or a mapping {path, threshold}")
    return RobustnessMap(_resolve(path, base_dir), threshold=threshold, field=field)


def _resolve(ref: str, base_dir: Path) -> Path:
    """A path from a station YAML: absolute, or relative to the YAML's folder."""
    p = Path(ref).expanduser()
    return p if p.is_absolute() else base_dir / p


def _absolute_mesh(o, base_dir: Path):
    if o.mesh_file is None:
        return o
    p = Path(o.mesh_file)
    if not p.is_absolute():
        p = base_dir / p
    if not p.is_file():
        raise ConfigError(f"obstacles.{o.name}.file", f"mesh file not found: {p}")
    return replace(o, mesh_file=str(p))
