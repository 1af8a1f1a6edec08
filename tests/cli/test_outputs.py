"""The fuzz table of what the commands write and read back: output paths that cannot be written or that name an
input, damaged or foreign artefacts (label shards, policies, station plans, maps, specs), and contradictory or
empty arguments. Every case is refused with exit code 2 and one error line naming its field, no traceback, and
leaves the folder it ran in exactly as it was: nothing written, nothing changed, no folder made.

A case joins the table as ``(case id, setup, expect)``: ``setup(tmp_path)`` writes the case's files and returns the
command line; ``expect`` is the field (or a phrase) the error line must name."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from dresspack_gym import ConfigError
from dresspack_gym.cli.main import main
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.trajectory import Trajectory, plan_fingerprint, save_trajectory
from dresspack_gym.shipped import find_shipped

POLICY = "stud_welding"  # a shipped policy without a cost-to-go model beside it
UNWRITABLE = ("/proc/dresspack-out", "/sys/dresspack-out")  # virtual file systems refuse new files even to root


def _plan_file(tmp: Path) -> Path:
    cfg = load_station("default")
    home = np.array(cfg.robots[0].home)
    traj = Trajectory(np.stack([home, home + np.radians([20, 5, 0, 30, 0, 0]), home]), (1, 2))
    save_trajectory(tmp / "q.npz", traj, station="default", robot="r1", speed_fraction=0.5,
                    fingerprint=plan_fingerprint(cfg, 0))
    return tmp / "q.npz"


def _shipped_policy_dir() -> Path:
    from dresspack.agents.learned.policy import resolve_policy

    model, _ = resolve_policy(POLICY)
    return model.parent


def _policy_with(tmp: Path, model: bytes, config: bool = True) -> Path:
    """A run folder with the shipped policy's config.yaml (unless not ``config``) and ``model`` as model.zip."""
    d = tmp / "pol"
    d.mkdir()
    if config:
        shutil.copy(_shipped_policy_dir() / "config.yaml", d / "config.yaml")
    (d / "model.zip").write_bytes(model)
    return d


def _label_folder(tmp: Path, shard: bytes) -> Path:
    d = tmp / "labels"
    (d / "episodes").mkdir(parents=True)
    (d / "spec.json").write_text(json.dumps({"policy_file": str(_shipped_policy_dir() / "model.zip")}))
    (d / "episodes" / "ep_00000.npz").write_bytes(shard)
    return d


def _station_plan(tmp: Path, text: str, trajectory: bytes | None = None) -> Path:
    d = tmp / "plans" / "time"
    d.mkdir(parents=True)
    (d / "plan.json").write_text(text)
    if trajectory is not None:
        (d / "r1.npz").write_bytes(trajectory)
    return d


def _npz_bytes(tmp: Path) -> bytes:
    np.savez(tmp / "x.npz", a=np.arange(3))
    data = (tmp / "x.npz").read_bytes()
    (tmp / "x.npz").unlink()
    return data


def _cases():
    # --------------------------------------------------------------------------------------- output paths
    yield "export onto its own plan", lambda t: ["export", _plan_file(t), "--format", "csv", "--out", t / "q.npz"], \
        "--out"
    yield "export onto its plan, spelt another way", lambda t: [
        "export", _plan_file(t), "--format", "json", "--out", t / "sub" / ".." / "q.npz"], "--out"

    def through_link(t):
        plan = _plan_file(t)
        (t / "link.npz").symlink_to(plan)
        return ["export", plan, "--format", "csv", "--out", t / "link.npz"]
    yield "export onto a link to its plan", through_link, "--out"
    yield "export --json onto its plan", lambda t: [
        "export", _plan_file(t), "--format", "csv", "--out", t / "q.npz", "--json"], "--out"
    for where in UNWRITABLE:
        yield f"export --out {where}", lambda t, w=where: [
            "export", _plan_file(t), "--format", "csv", "--out", f"{w}/p.csv"], "--out"
        yield f"export --json --out {where}", lambda t, w=where: [
            "export", _plan_file(t), "--format", "csv", "--out", f"{w}/p.csv", "--json"], "--out"
        yield f"animate --out {where}", lambda t, w=where: ["animate", _plan_file(t), "--out", f"{w}/a.gif"], "--out"
        yield f"render --out {where}", lambda t, w=where: ["render", "--out", f"{w}/r.png"], "--out"
        yield f"restrictions --plot {where}", lambda t, w=where: ["restrictions", "--plot", f"{w}/p.png"], "--plot"
        yield f"twist-sweep --out {where}", lambda t, w=where: ["twist-sweep", "--out", f"{w}/s.json"], "--out"
        yield f"wear-map --out {where}", lambda t, w=where: ["wear-map", "--out", f"{w}/m.npz"], "--out"
        yield f"plan --out {where}", lambda t, w=where: ["plan", "--out", f"{w}/p.npz"], "--out"
        yield f"plan --plot {where}", lambda t, w=where: ["plan", "--plot", f"{w}/p.png"], "--plot"
        yield f"eval --out {where}", lambda t, w=where: ["eval", "--out", f"{w}/e"], "--out"
        yield f"demo --out {where}", lambda t, w=where: ["demo", "--out", f"{w}/e"], "--out"
        yield f"counterfactuals --out {where}", lambda t, w=where: ["counterfactuals", "--out", f"{w}/c"], "--out"
        yield f"train-cost-model --out {where}", lambda t, w=where: [
            "train-cost-model", "--data", t, "--out", f"{w}/m"], "--out"
        yield f"robustness-map --out {where}", lambda t, w=where: [
            "robustness-map", "--grid", "small", "--station", "default", "--out", f"{w}/m"], "--out"
        yield f"station-plan --out {where}", lambda t, w=where: ["station-plan", "--out", f"{w}/s"], "--out"
    for cmd, flag, name in (("render", "--out", "r.txt"), ("render", "--out", "r.jpg"),
                            ("restrictions", "--plot", "p.txt"), ("twist-sweep", "--plot", "s.csv"),
                            ("twist-sweep", "--out", "s.txt"), ("wear-map", "--out", "m.json"),
                            ("plan", "--out", "p.csv"), ("plan", "--out", "p"), ("plan", "--plot", "p.gif")):
        yield f"{cmd} {flag} {name}", lambda t, c=cmd, f=flag, n=name: [c, f, t / "new" / n], flag
    yield "animate --out a.txt", lambda t: ["animate", _plan_file(t), "--out", t / "new" / "a.txt"], "--out"
    yield "train-cost-model --out onto its --data", lambda t: [
        "train-cost-model", "--data", _label_folder(t, _npz_bytes(t)), "--out", t / "labels"], "--out"

    # ------------------------------------------------------------------------------- artefacts read back
    yield "train-cost-model: a truncated shard", lambda t: [
        "train-cost-model", "--data", _label_folder(t, _npz_bytes(t)[:60]), "--out", t / "m"], "ep_00000.npz"
    yield "train-cost-model: a shard that is text", lambda t: [
        "train-cost-model", "--data", _label_folder(t, b"episode 0\n"), "--out", t / "m"], "ep_00000.npz"
    yield "train-cost-model: a shard of other arrays", lambda t: [
        "train-cost-model", "--data", _label_folder(t, _npz_bytes(t)), "--out", t / "m"], "lacks"

    def spec_not_json(t):
        d = _label_folder(t, b"")
        (d / "spec.json").write_text("{policy")
        (d / "episodes" / "ep_00000.npz").unlink()
        return ["counterfactuals", "--out", d, "--episodes", "1"]
    yield "counterfactuals resuming: spec.json not JSON", spec_not_json, "spec.json"
    yield "plan ppo: model.zip corrupt", lambda t: [
        "plan", "--planner", "ppo", "--policy", _policy_with(t, b"PK\x03\x04 not a zip")], "model.zip"
    yield "plan ppo-search: model.zip empty", lambda t: [
        "plan", "--planner", "ppo-search", "--policy", _policy_with(t, b"")], "model.zip"
    yield "plan ppo: a .zip with no run beside it", lambda t: [
        "plan", "--planner", "ppo", "--policy", _policy_with(t, b"x", config=False) / "model.zip"], "config.yaml"
    yield "eval --station-plans: plan.json not JSON", lambda t: [
        "eval", "--station-plans", _station_plan(t, "{robots"), "--station", "default", "--out", t / "e"], \
        "plan.json"
    yield "eval --station-plans: plan.json a list", lambda t: [
        "eval", "--station-plans", _station_plan(t, "[1, 2]"), "--station", "default", "--out", t / "e"], \
        "plan.json"
    yield "eval --station-plans: plan.json lacks config", lambda t: [
        "eval", "--station-plans", _station_plan(t, '{"robots": {}}'), "--station", "default", "--out", t / "e"], \
        "lacks"
    yield "eval --station-plans: its trajectory truncated", lambda t: [
        "eval", "--station-plans", _station_plan(t, json.dumps(
            {"robots": {"r1": {"trajectory": "r1.npz", "welds": [], "leg_start": []}}, "config": {"weld_time": 1}}),
            _npz_bytes(t)[:50]), "--station", "default", "--out", t / "e"], "r1.npz"

    # ------------------------------------------------------------------ contradictory or empty arguments
    for welds in ("sill_rear,,roof_rail_top", "sill_rear,", ",sill_rear", ""):
        yield f"eval --welds {welds!r}", lambda t, w=welds: ["eval", "--welds", w, "--out", t / "e"], "--welds"
    yield "eval --drawn-tasks with --welds", lambda t: [
        "eval", "--drawn-tasks", "1", "--welds", "sill_rear", "--out", t / "e"], "--drawn-tasks"
    yield "plan --welds with an empty name", lambda t: ["plan", "--welds", "sill_rear", " "], "--welds"
    yield "counterfactuals --max-minutes inf", lambda t: ["counterfactuals", "--out", t / "c", "--max-minutes",
                                                          "inf"], "must be finite"


CASES = list(_cases())


def _snapshot(folder: Path) -> dict:
    """Every path under ``folder`` and its content's digest (folders: None)."""
    return {str(p.relative_to(folder)): None if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*"))}


def test_the_output_table_covers_every_writing_command():
    commands = {case.split()[0] for case, _, _ in CASES}
    assert {"export", "animate", "render", "restrictions", "twist-sweep", "wear-map", "plan", "eval", "demo",
            "counterfactuals", "train-cost-model", "robustness-map", "station-plan"} <= commands
    assert len(CASES) >= 60


@pytest.mark.parametrize("case,setup,expect", CASES, ids=[c[0] for c in CASES])
def test_every_bad_output_artefact_or_argument_is_refused_and_changes_nothing(tmp_path, capsys, case, setup,
                                                                              expect):
    argv = [str(a) for a in setup(tmp_path)]
    before = _snapshot(tmp_path)
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's refusal of a flag: usage, one error line, exit code 2
        code = exc.code
    out, err = capsys.readouterr()
    assert code == 2 and "Traceback" not in err + out, (code, err[-2000:])
    if "--json" in argv:
        report = json.loads(out)
        message, field = report["error"], report["field"]
        assert err == ""
    else:
        lines = [line for line in err.splitlines() if "error:" in line]
        assert len(lines) == 1, err
        message, field = lines[0], ""
    assert expect in message or expect == field, (expect, message)
    assert _snapshot(tmp_path) == before, "the refused command wrote or changed a file"


def test_export_onto_its_own_plan_leaves_it_byte_identical(tmp_path):
    plan = _plan_file(tmp_path)
    data = plan.read_bytes()
    assert main(["export", str(plan), "--format", "csv", "--out", str(plan)]) == 2
    assert plan.read_bytes() == data


# ----------------------------------------------------------------------------------- the one owner, directly
def test_a_failed_write_leaves_the_old_file_and_no_folder(tmp_path):
    from dresspack_gym.io.outputs import replacing, write_text

    target = write_text(tmp_path / "a.json", "old")
    with pytest.raises(RuntimeError):
        with replacing(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("the writer failed")
    assert target.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["a.json"]
    with pytest.raises(KeyboardInterrupt):
        with replacing(tmp_path / "new" / "deeper" / "b.png") as tmp:
            tmp.write_bytes(b"\x89PNG half")
            raise KeyboardInterrupt
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


def test_a_refused_command_removes_the_folder_it_made_and_keeps_one_it_did_not(tmp_path):
    from dresspack_gym.io.outputs import output_folder

    with pytest.raises(ConfigError):
        with output_folder(tmp_path / "new" / "run") as out:
            (out / "config.yaml").write_text("x")
            raise ConfigError("--data", "refused")
    assert not (tmp_path / "new").exists()
    (tmp_path / "old").mkdir()
    with pytest.raises(ConfigError):
        with output_folder(tmp_path / "old"):
            raise ConfigError("--data", "refused")
    assert (tmp_path / "old").is_dir()
    with pytest.raises(KeyboardInterrupt):  # a resumable command keeps what it saved
        with output_folder(tmp_path / "resumable") as out:
            (out / "row").write_text("1")
            raise KeyboardInterrupt
    assert (tmp_path / "resumable" / "row").is_file()


def test_a_damaged_shard_met_on_resume_says_how_to_recover(tmp_path):
    from dresspack.training.counterfactuals import load_counterfactuals

    folder = _label_folder(tmp_path, b"\x00" * 40)
    with pytest.raises(ConfigError) as err:
        load_counterfactuals(folder, field="--out")
    assert err.value.field == "--out" and "ep_00000.npz" in str(err.value)
    assert f"dresspack counterfactuals --out {folder}" in str(err.value)


def test_a_damaged_wear_map_names_its_file_and_how_to_rebuild_it(tmp_path):
    from dresspack_gym.maps.wear_map import WearMap

    (tmp_path / "m.npz").write_bytes(b"PK\x03\x04 cut")
    with pytest.raises(ConfigError) as err:
        WearMap.load(tmp_path / "m.npz", load_station("default"))
    assert err.value.field == "wear_map" and "m.npz" in str(err.value) and "dresspack wear-map" in str(err.value)


def test_a_damaged_cost_model_names_its_file(tmp_path):
    from dresspack.agents.learned.search import load_cost_to_go

    (tmp_path / "model.pt").write_bytes(b"not torch")
    with pytest.raises(ConfigError) as err:
        load_cost_to_go(tmp_path / "model.pt", 13)
    assert "model.pt" in str(err.value)


def test_cost_to_go_auto_without_a_model_says_what_runs_instead():
    from dresspack.agents.learned.search import auto_fallback

    note = auto_fallback("auto", POLICY)
    assert note is not None and "ships no cost_to_go.pt" in note and "--cost-to-go none" in note
    assert auto_fallback("auto", "goal_conditioned") is None  # it ships one: nothing falls back
    assert auto_fallback("none", POLICY) is None
    assert find_shipped(POLICY, "policies", "policy", package="dresspack.agents", suffix="").is_dir()
