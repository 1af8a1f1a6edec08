"""The fuzz table of input files: CSV weld lists, URDF robot models and plan files for `dresspack export` and
`dresspack animate`, each mutated every way a generator here knows; every mutation is refused by a ConfigError (a
command: exit code 2 and one `error:` line) naming its field, never a traceback or a silent result.

A file kind joins the table by adding a generator to FILE_FUZZ: a function yielding ``(case id, run)`` where
``run(tmp_path, capsys)`` writes the mutated file, reads it the way the product does and returns the field of the
refusal (``refused_field`` and ``command_field`` do the catching), and the field that refusal must name."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import station_with_weld_csv

from dresspack_gym import ConfigError
from dresspack_gym.cli.main import main
from dresspack_gym.io.loading import load_robot, load_station
from dresspack_gym.io.weld_csv import OPTIONAL, REQUIRED
from dresspack_gym.physics.trajectory import plan_fingerprint

sys.path.insert(0, str(Path(__file__).parents[1] / "robots"))
from test_robots import MAKER_CHAINS, _chain_urdf  # noqa: E402

BAD_CELLS = ("nan", "inf", "-inf", "x", "1e30", "")


def refused_field(load) -> str:
    """The field of the ConfigError ``load()`` raises (the test fails if it raises nothing or something else)."""
    with pytest.raises(ConfigError) as err:
        load()
    return err.value.field


def command_field(argv, capsys) -> str:
    """The field named by the one `error:` line of `dresspack` ``argv`` (which must exit with code 2)."""
    code = main([str(a) for a in argv], extensions=[])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0].removeprefix("error: ").split(": ", 1)[0]


# ------------------------------------------------------------------------------------------- CSV weld lists
CSV_HEADER = list(REQUIRED + OPTIONAL[1:]) + ["robot"]
CSV_ROW = ["stud_a", "1085", "0", "1100", "1", "0", "0", "0", "90", "30", "r1"]




def _csv(header=CSV_HEADER, rows=(CSV_ROW,)) -> bytes:
    return "".join(",".join(r) + "\n" for r in [header, *rows]).encode()


def _csv_cases():
    row = "weld_points_csv[welds.csv:row 2]"
    for i, col in enumerate(CSV_HEADER):
        for bad in BAD_CELLS:
            if col == "robot" and bad == "":
                continue  # an empty robot cell means the station's first robot
            if col in OPTIONAL and bad == "":
                continue  # optional: empty means the default
            cells = list(CSV_ROW)
            cells[i] = bad
            expect = {"name": f"{row}.name" if bad == "" else None, "robot": f"{row}.robot"}.get(col, f"{row}.{col}")
            if col == "name" and bad != "":
                continue  # any non-empty text is a name
            if col in ("x", "y", "z") and bad == "1e30":
                expect = f"{row}.pos[{'xyz'.index(col)}]"
            if col.startswith("approach") and bad == "1e30":
                expect = f"{row}.approach[{'xyz'.index(col[-1])}]"
            if col == "spin_step_deg" and bad == "1e30":
                continue  # one spin: a valid (if coarse) step
            if col == "spin_min_deg" and bad == "-inf":
                expect = f"{row}.spin_min_deg"
            if col == "spin_step_deg" and bad == "-inf":
                expect = f"{row}.spin_step_deg"
            yield (f"csv {col}={bad!r}", lambda t, c, data=_csv(rows=[cells]): refused_field(
                lambda: station_with_weld_csv(t, data)), expect)
    structural = {
        "latin-1 byte": (_csv().replace(b"stud_a", "stud_\xe4".encode("latin-1")), row),
        "header only": (_csv(rows=()), "weld_points_csv"),
        "empty file": (b"", "weld_points_csv"),
        "cell too many": (_csv(rows=[CSV_ROW + ["7"]]), row),
        "cell too few": (_csv(rows=[CSV_ROW[:5]]), row),
        "column twice": (_csv(header=CSV_HEADER[:-1] + ["x"]), "weld_points_csv"),
        "unknown column": (_csv(header=CSV_HEADER[:-1] + ["colour"]), "weld_points_csv"),
        "missing column": (_csv(header=CSV_HEADER[1:], rows=[CSV_ROW[1:]]), "weld_points_csv"),
        "spin 0..1e9 step 1e-3": (_csv(rows=[CSV_ROW[:7] + ["0", "1e9", "1e-3", "r1"]]), f"{row}.spin_max_deg"),
        "spin 0..360 step 1e-3": (_csv(rows=[CSV_ROW[:7] + ["0", "360", "1e-3", "r1"]]), f"{row}.spin_step_deg"),
        "binary": (bytes(range(256)) * 4, "weld_points_csv[welds.csv:row 2]"),  # 0x80 follows the first 0x0a
    }
    for name, (data, expect) in structural.items():
        yield f"csv {name}", lambda t, c, data=data: refused_field(lambda: station_with_weld_csv(t, data)), expect


# --------------------------------------------------------------------------------------------- URDF models
def _urdf_robot(tmp_path, text: str):
    (tmp_path / "m.urdf").write_text(text)
    (tmp_path / "x.yaml").write_text("name: x\nsource: y\ntool: {tcp_pos: [0.4, 0, 0]}\nmodel_file: m.urdf\n")
    return load_robot(tmp_path / "x.yaml")


def _urdf_cases():
    good = _chain_urdf(MAKER_CHAINS["kuka_kr210_r2700_extra"])
    joints = good.split('<joint name="')
    for j in range(1, 7):
        for attr, value in (("lower", "-3.0"), ("upper", "3.0"), ("velocity", "2")):
            for bad in ("nan", "x", "inf", "1e30", "-5"):
                if attr == "lower" and bad == "-5":
                    continue  # a valid lower limit
                part = joints[j].replace(f'{attr}="{value}"', f'{attr}="{bad}"', 1)
                text = '<joint name="'.join(joints[:j] + [part] + joints[j + 1:])
                yield (f"urdf joint_{j} {attr}={bad}", lambda t, c, text=text: refused_field(
                    lambda: _urdf_robot(t, text)), None)
    entity = '<!DOCTYPE robot [<!ENTITY a "2"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;">]>\n'
    for name, text in {"entities": entity + good.replace('velocity="2"', 'velocity="&b;"'),
                       "doctype": '<!DOCTYPE robot SYSTEM "robot.dtd">\n' + good,
                       "truncated": good[: len(good) // 2], "not xml": "robot: yes\n", "empty": "",
                       "swapped limits": good.replace('lower="-3.0" upper="3.0"', 'lower="3.0" upper="-3.0"', 1),
                       "five joints": good.split('<link name="link_6">')[0] + "</robot>"}.items():
        yield f"urdf {name}", lambda t, c, text=text: refused_field(lambda: _urdf_robot(t, text)), None


# ------------------------------------------------------------------------------------ plans: export, animate
def _write_plan(path: Path, waypoints=None, stops=None, meta=None, raw: bytes | None = None):
    if raw is not None:
        path.write_bytes(raw)
        return
    arrays = {"waypoints": waypoints, "stops": stops}
    if meta is not None:
        arrays["meta"] = meta if isinstance(meta, str) else json.dumps(meta)
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None})


def _plan_cases():
    cfg = load_station("default")
    home = np.array(cfg.robots[0].home)
    good_q = np.stack([home, home + np.radians([20, 5, 0, 30, 0, 0]), home])
    meta = {"station": "default", "robot": "r1", "speed_fraction": 0.5, "fingerprint": plan_fingerprint(cfg, 0)}
    good = {"waypoints": good_q, "stops": np.array([1, 2]), "meta": meta}
    limits = np.array(cfg.robots[0].robot.joint_limits_rad)
    variants = {"waypoint nan": ({**good, "waypoints": np.where(np.eye(3, 6, 1, dtype=bool), np.nan, good_q)},
                                 "plan"),
                "waypoints (3, 5)": ({**good, "waypoints": good_q[:, :5]}, "plan"),
                "one waypoint": ({**good, "waypoints": good_q[:1], "stops": np.array([], dtype=int)}, "plan"),
                "stops out of range": ({**good, "stops": np.array([1, 7])}, "plan"),
                "stops as text": ({**good, "stops": np.array(["a"])}, "plan"),
                "no stops": ({**good, "stops": None}, "plan"),
                "meta not json": ({**good, "meta": "{station"}, "plan"),
                "meta a list": ({**good, "meta": "[1, 2]"}, "plan"),
                "unknown station": ({**good, "meta": {**meta, "station": "no_such", "fingerprint": None}}, "station"),
                "unknown robot": ({**good, "meta": {**meta, "robot": "r9"}}, "plan.robot"),
                "fingerprint text": ({**good, "meta": {**meta, "fingerprint": "abc"}}, "plan.fingerprint"),
                "fingerprint of another robot": ({**good, "meta": {**meta, "fingerprint": {
                    **meta["fingerprint"], "robot": "0" * 16}}}, "plan"),
                "no station named": ({**good, "meta": {"speed_fraction": 0.5}}, "--station")}
    for side in (0, 1):
        for j in range(6):
            q = good_q.copy()
            q[1, j] = limits[j, side] + (0.01 if side else -0.01)
            variants[f"joint {j + 1} {('below', 'above')[side]} its limit"] = ({**good, "waypoints": q},
                                                                                f"plan.waypoints[1][{j}]")
    for bad in (math.nan, math.inf, -1.0, 0.0, 1.5, "fast", True):
        variants[f"speed_fraction={bad!r}"] = ({**good, "meta": {**meta, "speed_fraction": bad}}, "speed_fraction")
    for name, (arrays, expect) in variants.items():
        for cmd in ("export", "animate"):
            def run(t, c, arrays=arrays, cmd=cmd):
                _write_plan(t / "p.npz", arrays["waypoints"], arrays["stops"], arrays["meta"])
                extra = ["--format", "rapid"] if cmd == "export" else ["--out", t / "a.gif"]
                return command_field([cmd, t / "p.npz", *extra], c)
            yield f"{cmd} {name}", run, expect
    for cut in (0, 10, 100, 400, -20):
        for cmd in ("export", "animate"):
            def run(t, c, cut=cut, cmd=cmd):
                _write_plan(t / "full.npz", **good)
                data = (t / "full.npz").read_bytes()
                _write_plan(t / "p.npz", raw=data[:cut])
                extra = ["--format", "krl"] if cmd == "export" else ["--out", t / "a.gif"]
                return command_field([cmd, t / "p.npz", *extra], c)
            yield f"{cmd} plan cut at {cut} bytes", run, "plan"


# Every file kind of the table. The station-plan folder (plan.json and one .npz per robot) joins here.
FILE_FUZZ = {"csv": _csv_cases, "urdf": _urdf_cases, "plan": _plan_cases}
FILE_CASES = [(kind, *case) for kind, cases in FILE_FUZZ.items() for case in cases()]


def test_the_file_fuzz_table_is_large():
    per_kind = {k: sum(1 for c in FILE_CASES if c[0] == k) for k in FILE_FUZZ}
    assert per_kind["csv"] >= 50 and per_kind["urdf"] >= 90 and per_kind["plan"] >= 60, per_kind


@pytest.mark.parametrize("kind,case,run,expect", FILE_CASES, ids=[c[1] for c in FILE_CASES])
def test_every_bad_file_is_refused_naming_its_field(tmp_path, capsys, kind, case, run, expect):
    field = run(tmp_path, capsys)
    if expect is None:  # a robot model file: refused as the model file, or the robot field the value lands in
        assert field == "model_file" or field.startswith("x.yaml."), field
    else:
        assert field == expect, (case, field)
