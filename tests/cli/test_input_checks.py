"""Every bad input a clear error naming the field: a generated fuzz table over station configs, `dresspack`
flags and env arguments, plus the station's physical consistency at Home, the env's API order and map resume."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from helpers import default_station_dict

from dresspack_gym import ConfigError
from dresspack_gym.cli.main import build_parser
from dresspack_gym.env.config import NUMBER_RANGES as _NUMBER_ARGS
from dresspack_gym.env.dresspack_env import DresspackEnv, InvalidActionError
from dresspack_gym.errors import DresspackError, EnvUsageError
from dresspack_gym.io.loading import read_yaml, station_from_dict
from dresspack_gym.maps.robustness.grid import RobustnessGrid
from dresspack_gym.stations.station import Station

BAD_VALUES = (math.nan, math.inf, -math.inf, "x", True, 1e30, -1e30)


# ------------------------------------------------------------------------------------------- station configs
def _station_with_inline_dresspack() -> dict:
    d = default_station_dict()
    d["robots"][0]["dresspack"] = read_yaml(
        __import__("dresspack_gym.shipped", fromlist=["find_shipped"]).find_shipped(
            "thesis_stud_welding", "dresspacks", "dresspack"))
    return d


def _numeric_leaves(node, path=""):
    """(YAML field path, setter) of every number in a config tree, in the readers' path notation."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _numeric_leaves(v, f"{path}.{k}" if path else k)
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _numeric_leaves(v, f"{path}[{i}]")
    elif isinstance(node, (int, float)) and not isinstance(node, bool):
        yield path


def _set(tree, path, value):
    parts = path.replace("]", "").replace("[", ".").split(".")
    node = tree
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node[p]
    last = parts[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value


def _sweep(cases, field):
    """A fuzz table as parameters: every field with one of its bad values in the fast tier (the fields take the
    values in turn, so every kind of value is met too), its other values under ``slow`` (the whole table is ~1,800
    cases)."""
    groups = {}
    for case in cases:
        groups.setdefault(field(case), []).append(case)
    fast = {id(group[i % len(group)]) for i, group in enumerate(groups.values())}
    return [case if id(case) in fast else pytest.param(*case, marks=pytest.mark.slow) for case in cases]


STATION = _station_with_inline_dresspack()
LEAVES = list(_numeric_leaves(STATION))
CONFIG_CASES = [(leaf, v) for leaf in LEAVES for v in BAD_VALUES]


def test_the_config_fuzz_table_is_large():
    assert len(LEAVES) > 60 and len(CONFIG_CASES) > 400


@pytest.mark.parametrize("leaf,value", _sweep(CONFIG_CASES, lambda c: c[0]),
                         ids=[f"{leaf}={v}" for leaf, v in CONFIG_CASES])
def test_every_number_of_a_station_rejects_nonsense_naming_its_field(leaf, value):
    """NaN, infinities, strings, booleans and absurd magnitudes in any numeric field of a station (robots,
    dresspack, nodes, restrictions, obstacles, weld points, wear cost, simulation) are refused by the readers,
    and the error names that field (or the list it belongs to)."""
    d = copy.deepcopy(STATION)
    _set(d, leaf, value)
    with pytest.raises(ConfigError) as err:
        station_from_dict(d)
    field = err.value.field
    assert leaf == field or leaf.startswith(field + ".") or leaf.startswith(field + "["), (leaf, str(err.value))


def test_duplicate_yaml_key_is_refused_with_its_line(tmp_path):
    text = "name: a\nrobots: []\nname: b\n"
    (tmp_path / "s.yaml").write_text(text)
    with pytest.raises(ConfigError, match=r"duplicate key 'name' \(first at line 1\)"):
        read_yaml(tmp_path / "s.yaml", "station")


@pytest.mark.parametrize("kind", ["weld_points", "obstacles", "nodes"])
def test_names_must_be_unique(kind):
    d = _station_with_inline_dresspack()
    items = d["robots"][0]["dresspack"]["nodes"] if kind == "nodes" else d[kind]
    items[1]["name"] = items[0]["name"]
    with pytest.raises(ConfigError, match="used twice") as err:
        station_from_dict(d)
    assert err.value.field.endswith(f"{kind}[1].name")


# ------------------------------------------------------------------------- physical consistency at Home
def _station(**change):
    d = default_station_dict()
    for k, v in change.items():
        d[k] = v(d) if callable(v) else v
    return Station(station_from_dict(d))


def test_obstacle_overlapping_the_robot_at_home_is_named():
    box = {"name": "in_base", "type": "box", "pos": [-0.5, 0.0, 0.3], "half_size": [0.2, 0.2, 0.2]}
    with pytest.raises(ConfigError, match="'in_base' overlaps robot 'r1' \\(base\\)") as err:
        _station(obstacles=lambda d: d["obstacles"] + [box])
    assert err.value.field == f"obstacles[{len(default_station_dict()['obstacles'])}]"


def test_obstacle_through_the_home_cable_is_named():
    """A small sphere on the Home cable's middle, clear of the arm: the cable would start inside it."""
    base = Station(station_from_dict(default_station_dict()))
    shape = base.home_cable_shapes[0]
    mid = shape[len(shape) // 2]
    ball = {"name": "on_cable", "type": "sphere", "pos": [float(x) for x in mid], "radius": 0.06}
    with pytest.raises(ConfigError, match="'on_cable' cuts through the Home cable of robot 'r1'"):
        _station(obstacles=lambda d: d["obstacles"] + [ball])


def test_weld_point_inside_a_part_is_named():
    weld = {"name": "inside", "pos": [1.15, 0.0, 1.1], "approach": [1, 0, 0]}  # 6 cm inside the B-pillar
    with pytest.raises(ConfigError, match="'inside' lies 60 mm inside obstacle 'b_pillar_near'") as err:
        _station(weld_points=lambda d: d["weld_points"] + [weld])
    assert err.value.field == f"weld_points[{len(default_station_dict()['weld_points'])}].pos"


def test_cable_too_long_for_its_nodes_is_named():
    def long_cable(d):
        d["robots"][0]["dresspack_overrides"] = {"length": 15.0, "segments": 60}
        return d["robots"]

    with pytest.raises(ConfigError, match="would start below the floor at Home") as err:
        _station(robots=long_cable)
    assert err.value.field == "robots[0].dresspack.length"


def test_grid_size_is_bounded_before_anything_is_allocated():
    axis = {"start": -180, "stop": 180, "step": 30}
    with pytest.raises(ConfigError, match="at most 10,000") as err:
        RobustnessGrid.from_dict({"ry": {"start": -720, "stop": 720, "step": 1e-4}, "j4": axis, "j5": axis,
                                  "j6": axis})
    assert err.value.field == "grid.ry.step"
    fine = {"range": [-180, 180], "count": 100}
    with pytest.raises(ConfigError, match="100 x 100 x 100 x 100 = 100,000,000 configurations"):
        RobustnessGrid.from_dict({"ry": fine, "j4": fine, "j5": fine, "j6": fine})


# ------------------------------------------------------------------------------------- dresspack flags
def _numeric_flags():
    """(subcommand, flag, parse function) of every ranged numeric flag of the `dresspack` command line, the
    subcommands the packages built on the core register (plan, station-plan, demo, ...) included."""
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, p in sub.choices.items():
        for a in p._actions:
            if getattr(a.type, "bounds", None) is not None and a.option_strings:
                yield name, a.option_strings[0], a.type.bounds, a.nargs


REQUIRED = {"render": ["--out", "x.png"], "robustness-map": ["--grid", "small", "--station", "default", "--out", "m"],
            "robustness-paths": ["--grid", "small", "--station", "default", "--out", "m"],
            "restrictions": [], "twist-sweep": [], "bench": ["physics"], "inspect": [],
            "export": ["p.npz", "--format", "csv"], "animate": ["p.npz", "--out", "x.mp4"], "view": ["p.npz"],
            "wear-map": [], "robots": [], "plan": [], "station-plan": [], "demo": [], "eval": [],
            "train": ["stud_welding"],
            "select-model": ["run"], "self-imitate": ["policy", "--out", "o"], "counterfactuals": ["--out", "o"],
            "train-cost-model": ["--data", "d", "--out", "o"]}


def _out_of_range(bounds):
    lo, hi, lo_open, integer = bounds
    vals = ["nan", "inf", "-inf", "text"]
    if lo is not None:
        vals.append(str(lo if lo_open else (lo - 1 if integer else lo - 1e-3 * max(1, abs(lo)))))
    if hi is not None:
        vals.append(str(hi + 1 if integer else hi * 2 + 1))
    if integer:
        vals.append("1.5")
    return vals


FLAG_CASES = [(cmd, flag, v, nargs) for cmd, flag, bounds, nargs in _numeric_flags() for v in _out_of_range(bounds)
              if not (nargs is not None and v.startswith("-"))]


def test_the_flag_fuzz_table_covers_every_ranged_flag():
    flags = {(c, f) for c, f, _, _ in FLAG_CASES}
    assert len(flags) >= 20 and len(FLAG_CASES) >= 120
    assert {("render", "--distance"), ("bench", "--repeats"), ("robustness-map", "--limit"),
            ("robustness-map", "--threshold"), ("render", "--width"), ("station-plan", "--weld-time"),
            ("plan", "--iterations"), ("demo", "--seeds"), ("eval", "--jobs"), ("train", "--n-envs")} <= flags


@pytest.mark.parametrize("cmd,flag,value,nargs", _sweep(FLAG_CASES, lambda c: c[:2]),
                         ids=[f"{c} {f} {v}" for c, f, v, _ in FLAG_CASES])
def test_every_numeric_flag_refuses_out_of_range_values_naming_itself(cmd, flag, value, nargs, capsys):
    count = nargs if isinstance(nargs, int) else 1  # a list flag ("+") with one bad value
    given = [f"{flag}={value}"] if nargs is None else [flag, *[value] * count]  # "=": "-inf" is no option
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args([cmd, *REQUIRED[cmd], *given])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {flag}" in err and "must be" in err and "Traceback" not in err


@pytest.mark.parametrize("argv,match", [
    (["render", "--out", "{tmp}"], "is an existing folder"),
    (["render", "--out", "{tmp}/file.txt/x.png"], "is a file, not a folder"),
    (["robustness-map", "--grid", "small", "--station", "default", "--out", "{tmp}/file.txt"], "is an existing file"),
    (["twist-sweep", "--plot", "{tmp}"], "is an existing folder"),
    (["restrictions", "--station", "default", "--plot", "{tmp}/file.txt/p.png"], "is a file, not a folder"),
])
def test_output_paths_are_checked_before_any_work(tmp_path, capsys, argv, match):
    (tmp_path / "file.txt").write_text("x")
    with pytest.raises(SystemExit) as exc:
        build_parser(extensions=[]).parse_args([a.format(tmp=tmp_path) for a in argv])
    assert exc.value.code == 2 and match in capsys.readouterr().err


def test_missing_output_folders_are_made(tmp_path):
    from dresspack_gym.cli.main import main

    out = tmp_path / "a" / "b" / "p.png"
    assert main(["restrictions", "--plot", str(out)], extensions=[]) == 0
    assert out.is_file()


# --------------------------------------------------------------------------------------- env arguments
def _env_cases():
    for name, (lo, hi, integer) in _NUMBER_ARGS.items():
        for v in (math.nan, math.inf, "fast", True, hi * 2 + 1, lo - 1):
            yield name, v
        if integer:
            yield name, lo + 0.5
    for name in ("shuffle_welds", "goal_action", "wear_integral"):
        yield name, "yes"
    yield "render_size", (0, 0)
    yield "render_size", (-5, 10)
    yield "render_size", (100, 1e9)
    yield "render_size", "big"
    yield "welds", "sill_front"
    yield "cost_variant", "cheap"
    yield "invalid_action", "ignore"
    yield "station", 3


ENV_CASES = list(_env_cases())


@pytest.mark.parametrize("name,value", ENV_CASES, ids=[f"{n}={v!r}" for n, v in ENV_CASES])
def test_every_env_argument_is_checked_naming_it(name, value):
    with pytest.raises(ConfigError) as err:
        DresspackEnv(**{name: value})
    assert err.value.field.split(".")[0] == name, str(err.value)


@pytest.fixture(scope="module")
def env():
    e = DresspackEnv(max_steps=2, settle_time=0.0)
    yield e
    e.close()


def test_env_api_order_is_enforced(env):
    fresh = DresspackEnv(max_steps=2, settle_time=0.0)
    with pytest.raises(EnvUsageError, match="before reset"):
        fresh.step(12)
    env.reset(seed=0)
    env.step(np.int64(12))
    env.step(np.array(12))  # SB3 passes 0-d integer arrays
    with pytest.raises(EnvUsageError, match="after the episode ended"):
        env.step(12)
    env.reset(seed=0)
    env.step(12)


@pytest.mark.parametrize("action", [True, np.bool_(False), 1.0, np.array([1.5]), 99, -1, "1", None, [1, 2]])
def test_env_takes_actions_of_its_action_space_only(env, action):
    env.reset(seed=0)
    with pytest.raises(InvalidActionError, match=r"integer in \[0, 12\]"):
        env.step(action)


@pytest.mark.parametrize("options,field", [("start", "options"), ({"weld": ["sill_front"]}, "options.weld"),
                                           ({"welds": ["nope"]}, "options.welds"), ([1], "options")])
def test_env_rejects_bad_reset_options(env, options, field):
    with pytest.raises(DresspackError) as err:
        env.reset(seed=0, options=options)
    assert err.value.field == field


# ------------------------------------------------------------------------------------ map resume, limit
def test_map_row_that_lost_only_its_newline_is_kept_and_a_torn_one_recomputed(tmp_path):
    from dresspack_gym.maps.robustness.store import COLUMNS, done_indices, repair_last_line

    path = tmp_path / "results.csv"
    whole = "3,0,0,0,0,0.01,0.02,0.02,1,1.0e-01,0.25,1"
    path.write_text(",".join(COLUMNS) + "\n" + "2,0,0,0,0,0.01,0.02,0.02,1,1.0e-01,0.25,1\n" + whole)
    repair_last_line(path)
    assert path.read_text().endswith(whole + "\n") and done_indices(tmp_path) == {2, 3}
    path.write_text(path.read_text() + "4,0,0,0,0,0.01,0.0")
    repair_last_line(path)
    assert done_indices(tmp_path) == {2, 3} and path.read_text().endswith(whole + "\n")


def test_limit_caps_the_configurations_computed_not_only_reported():
    from dresspack_gym.maps.robustness.runner import _work_units

    axis = {"range": [-180, 180], "count": 5}
    grid = RobustnessGrid.from_dict({"ry": axis, "j4": axis, "j5": axis, "j6": axis})
    todo = [3, 4, 5, 6, 7, 8, 9]  # the end of row 0 and all of row 1
    units = _work_units(grid, todo, "row", limit=7)
    assert sum(len(c) for c, _ in units) <= 7
    assert units[0] == ([0, 1, 2, 3, 4], [3, 4])  # a begun row is recomputed from its start
    assert units[1] == ([5, 6], [5, 6])  # cut to a prefix: its results equal the whole row's
    assert _work_units(grid, todo, "row") == [([0, 1, 2, 3, 4], [3, 4]), ([5, 6, 7, 8, 9], [5, 6, 7, 8, 9])]


@pytest.mark.parametrize("argv,field", [
    (["inspect", "--station", "nope", "--json"], "station"),
    (["render", "--out", "x.png", "--width", "0", "--json"], "--width"),
    (["robustness-map", "--grid", "small", "--station", "default", "--out", "m", "--limit", "-1", "--json"],
     "--limit"),
    (["bench", "physics", "--repeats", "nan", "--json"], "--repeats"),
])
def test_json_calls_get_json_errors(argv, field, capsys):
    """A script that asked for --json gets one JSON object with the error and its field, exit code 2."""
    import json

    from dresspack_gym.cli.main import main

    assert main(argv, extensions=[]) == 2
    out = json.loads(capsys.readouterr().out)
    assert out["field"] == field and field.lstrip("-") in out["error"]


def test_damaged_robustness_map_folder_is_a_clear_error(tmp_path):
    from dresspack_gym.maps.robustness.query import RobustnessMap

    (tmp_path / "meta.json").write_text("{not json")
    with pytest.raises(ConfigError, match="damaged"):
        RobustnessMap(tmp_path)
    (tmp_path / "meta.json").write_text("{}")
    with pytest.raises(ConfigError, match="lacks"):
        RobustnessMap(tmp_path)
