"""dresspack train, dresspack eval and dresspack plan: bad input refused before any work, naming the flag or
field; a finished run never overwritten without --force; Ctrl-C always exits; resumed evaluations equal
uninterrupted ones."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from helpers import as_a_shell_starts_it

pytest.importorskip("sb3_contrib")
pytest.importorskip("ompl")

from test_training import SMOKE  # noqa: E402

from dresspack_gym.cli.main import main as dresspack_main  # noqa: E402


def train_main(argv: list[str]) -> int:
    """``dresspack train ARGV``."""
    return dresspack_main(["train", *argv])


def eval_main(argv: list[str]) -> int:
    """``dresspack eval ARGV``."""
    return dresspack_main(["eval", *argv])


def _smoke_yaml(tmp_path, **changes) -> str:
    path = tmp_path / "smoke.yaml"
    path.write_text(yaml.safe_dump({**SMOKE, **changes}))
    return str(path)


TRAIN_FLAG_CASES = [
    (["--n-envs", "65"], "--n-envs"), (["--n-envs", "0"], "--n-envs"), (["--seed", "-1"], "--seed"),
    (["--seed", str(2**32)], "--seed"), (["--total-timesteps", "0"], "--total-timesteps"),
    (["--total-timesteps", "1e30"], "--total-timesteps"), (["--total-timesteps", "nan"], "--total-timesteps"),
]


@pytest.mark.parametrize("flags,flag", TRAIN_FLAG_CASES, ids=[" ".join(f) for f, _ in TRAIN_FLAG_CASES])
def test_train_flags_are_ranged(tmp_path, capsys, flags, flag):
    with pytest.raises(SystemExit) as exc:
        train_main([_smoke_yaml(tmp_path), "--run-dir", str(tmp_path / "r"), *flags])
    assert exc.value.code == 2 and f"argument {flag}" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("changes,field", [
    ({"total_timesteps": 10**12}, "total_timesteps"), ({"total_timesteps": 1e30}, "total_timesteps"),
    ({"seed": 2**32}, "seed"), ({"n_envs": 65}, "n_envs"),
    ({"ppo": {"n_steps": 64, "batch_size": 256}}, "ppo.batch_size"),
    ({"env_kwargs": {"max_steps": 1.5}}, "env_kwargs.max_steps"),
    ({"env_kwargs": {"goal_reward": float("inf")}}, "env_kwargs.goal_reward"),
    ({"env_kwargs": {"wear_weight": float("nan")}}, "env_kwargs.wear_weight"),
    ({"env_kwargs": {"start_noise_deg": 1e6}}, "env_kwargs.start_noise_deg"),
])
def test_train_config_values_are_checked_before_any_file_is_written(tmp_path, capsys, changes, field):
    assert train_main([_smoke_yaml(tmp_path, **changes), "--run-dir", str(tmp_path / "r")]) == 2
    assert f"error: {field}" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_cli_n_envs_override_passes_the_config_checks(tmp_path, capsys):
    """--n-envs goes through the same reader as the YAML: batch_size must still fit one rollout."""
    path = _smoke_yaml(tmp_path, n_envs=2, ppo={"n_steps": 64, "batch_size": 128})
    assert train_main([path, "--run-dir", str(tmp_path / "r"), "--n-envs", "1"]) == 2
    assert "ppo.batch_size" in capsys.readouterr().err


def test_finished_run_is_never_overwritten_without_force(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "final_model.zip").write_bytes(b"model")
    (run / "config.yaml").write_text(yaml.safe_dump({**SMOKE}))
    assert train_main([_smoke_yaml(tmp_path), "--run-dir", str(run)]) == 2
    assert "holds a finished run" in capsys.readouterr().err and (run / "final_model.zip").read_bytes() == b"model"
    assert train_main(["--resume", str(run)]) == 2
    assert "finished run" in capsys.readouterr().err
    (tmp_path / "file").write_text("x")
    assert train_main([_smoke_yaml(tmp_path), "--run-dir", str(tmp_path / "file")]) == 2
    assert "existing file" in capsys.readouterr().err


def test_resume_with_a_broken_config_names_the_file(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.yaml").write_text("n_envs: [unclosed\n")
    assert train_main(["--resume", str(run)]) == 2
    err = capsys.readouterr().err
    assert "--resume" in err and "config.yaml" in err
    (run / "config.yaml").write_text(yaml.safe_dump({**SMOKE, "n_envs": "two"}))
    assert train_main(["--resume", str(run)]) == 2
    assert "not a valid training config" in capsys.readouterr().err


def _ctrl_c_once(tmp_path: Path, k: int) -> tuple[int, float, bool, list[str]]:
    """Start a 2-process training run, press Ctrl-C (SIGINT to the whole process group, as a terminal does)
    once it steps, and return (exit code, seconds from the signal to exit, a checkpoint was saved, the stderr
    lines)."""
    run = tmp_path / f"ctrl_c_{k}"
    cfg = {**SMOKE, "vec_env": "subproc", "total_timesteps": 100_000, "eval_every": 0, "checkpoint_every": 10**6}
    path = tmp_path / f"ctrl_c_{k}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    proc = subprocess.Popen([sys.executable, "-m", "dresspack_gym.cli.main", "train", str(path), "--run-dir",
                             str(run), "--no-progress"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True, preexec_fn=as_a_shell_starts_it, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not list((run / "tb").rglob("events.out.tfevents*")):
        time.sleep(0.2)  # TensorBoard's event file appears when learning starts
    time.sleep(1.0 + 0.37 * (k % 5))  # land the interrupt at different points of a rollout
    os.killpg(proc.pid, signal.SIGINT)
    t0 = time.time()
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        return -1, 60.0, False, []
    lines = [line for line in err.splitlines() if line.strip()]
    return proc.returncode, time.time() - t0, bool(list((run / "checkpoints").glob("ckpt_*_steps.zip"))), lines


REPEATS = int(os.environ.get("DRESSPACK_CTRLC_REPEATS", "1"))


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
@pytest.mark.parametrize("k", range(REPEATS))
def test_ctrl_c_in_training_always_exits_with_a_checkpoint(tmp_path, k):
    code, seconds, saved, lines = _ctrl_c_once(tmp_path, k)
    assert code == 130 and saved and seconds < 45 and len(lines) == 1, (code, seconds, saved, lines)
    assert lines[0].startswith("interrupted: saved ") and "continue with: dresspack train --resume " in lines[0]


@pytest.mark.slow
@pytest.mark.parametrize("k", range(20))
def test_ctrl_c_in_training_under_load(tmp_path, busy_machine, k):
    code, seconds, saved, lines = _ctrl_c_once(tmp_path, k)
    assert code == 130 and saved and seconds < 45 and len(lines) == 1, (code, seconds, saved, lines)


# ----------------------------------------------------------------------------------------------- eval, plan
EVAL_FLAG_CASES = [
    (["--seeds", "-1"], "--seeds"), (["--seeds", str(2**32)], "--seeds"), (["--time-budget", "nan"], "--time-budget"),
    (["--time-budget", "0"], "--time-budget"), (["--iterations", "0"], "--iterations"),
    (["--routes", "-3"], "--routes"), (["--evaluations", "x"], "--evaluations"),
    (["--start-noise-deg", "inf"], "--start-noise-deg"), (["--planners", "fast"], "--planners"),
]


@pytest.mark.parametrize("flags,flag", EVAL_FLAG_CASES, ids=[" ".join(f) for f, _ in EVAL_FLAG_CASES])
def test_eval_flags_are_ranged(tmp_path, capsys, flags, flag):
    with pytest.raises(SystemExit) as exc:
        eval_main(["--planners", "ompl", "--out", str(tmp_path / "e"), *flags])
    assert exc.value.code == 2 and f"argument {flag}" in capsys.readouterr().err
    assert not (tmp_path / "e").exists()


@pytest.mark.parametrize("args,field", [
    (["--welds", "nope"], "tasks"), (["--robustness-map", "no_such_map"], "robustness_map"),
    (["--station", "no_station"], "station"), (["--planners", "ppo", "--policy", "no_policy"], "policy"),
])
def test_eval_inputs_are_checked_before_anything_is_written(tmp_path, capsys, args, field):
    out = tmp_path / "e"
    assert eval_main(["--planners", "ompl", "--welds", "roof_rail_top", "--seeds", "0", *args, "--out", str(out)]) == 2
    assert field in capsys.readouterr().err
    assert not out.exists()  # no spec.json left behind to refuse the corrected rerun


def test_eval_out_that_is_a_file_is_refused(tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    with pytest.raises(SystemExit):
        eval_main(["--out", str(tmp_path / "f")])
    assert "is an existing file" in capsys.readouterr().err


@pytest.mark.slow  # an evaluation of two planners, run and resumed (~65 s)
def test_resumed_evaluation_equals_an_uninterrupted_one(tmp_path):
    """Rows computed after a resume equal those of one uninterrupted run (per-plan seeding): the first run is
    cut after its first row by removing the later rows from the log, as an interruption leaves it."""
    args = ["--planners", "ompl", "thesis-local", "--welds", "roof_rail_top", "sill_front", "--seeds", "0",
            "--iterations", "300", "--evaluations", "4", "--no-render", "--json"]
    full, part = tmp_path / "full", tmp_path / "part"
    assert eval_main([*args, "--out", str(full)]) == 0
    assert eval_main([*args, "--out", str(part)]) == 0
    lines = (part / "results.jsonl").read_text().splitlines()
    (part / "results.jsonl").write_text(lines[0] + "\n" + lines[1][: len(lines[1]) // 2])  # torn second row
    assert eval_main([*args, "--out", str(part)]) == 0

    def rows(folder):
        out = {}
        for line in (folder / "results.jsonl").read_text().splitlines():
            r = json.loads(line)
            r.pop("planning_time", None)
            out[r["key"]] = r
        return out

    assert rows(full) == rows(part) and len(rows(full)) == 4


PLAN_CASES = [
    (["plan", "--station", "default", "--seed", "-1"], "--seed"),
    (["plan", "--station", "default", "--time-budget", "inf"], "--time-budget"),
    (["plan", "--station", "default", "--iterations", "0"], "--iterations"),
    (["plan", "--station", "default", "--plot", "{tmp}"], "--plot"),
    (["plan", "--station", "default", "--plot", "{tmp}/f/x.png"], "--plot"),
]


@pytest.mark.parametrize("argv,flag", PLAN_CASES, ids=[" ".join(a) for a, _ in PLAN_CASES])
def test_plan_flags_and_paths_are_checked_before_planning(tmp_path, capsys, argv, flag):
    (tmp_path / "f").write_text("x")
    argv = [a.format(tmp=tmp_path) for a in argv]
    with pytest.raises(SystemExit) as exc:
        dresspack_main(argv)
    assert exc.value.code == 2 and f"argument {flag}" in capsys.readouterr().err
    assert dresspack_main([*argv, "--json"]) == 2  # under --json: one JSON error object
    assert json.loads(capsys.readouterr().out)["field"] == flag


def test_plan_json_errors_are_json(capsys):
    assert dresspack_main(["plan", "--station", "default", "--welds", "nope", "--json"]) == 2
    out = json.loads(capsys.readouterr().out)
    assert out["field"] == "welds" and "nope" in out["error"]
    assert dresspack_main(["plan", "--station", "default", "--robot", "3", "--json"]) == 2  # the station has one robot
    out = json.loads(capsys.readouterr().out)
    assert out["field"] == "robot" and "r1" in out["error"]


def test_plan_for_one_robot_of_the_four_robot_station(capsys):
    assert dresspack_main(["plan", "--station", "side_framing_4r", "--robot", "2", "--welds", "r3_sill_1",
                           "--iterations", "300",
                           "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["success"] and out["welds"] == ["r3_sill_1"] and out["life_cycles"] > 0


def test_eval_cost_variant_damage_reports_the_integrated_damage_rate(tmp_path, capsys):
    out = tmp_path / "e"
    assert eval_main(["--planners", "ompl", "--welds", "roof_rail_top", "--seeds", "0", "--iterations", "300",
                      "--cost-variant", "damage", "--no-render", "--json", "--out", str(out)]) == 0
    row = json.loads((out / "results.jsonl").read_text().splitlines()[0])
    assert row["cost_terms"]["damage"] == pytest.approx(row["cost"]) and row["cost_terms"]["curvature"] == 0.0
    assert "damage rate" in (out / "report.md").read_text()
    with pytest.raises(SystemExit):
        eval_main(["--cost-variant", "cheap", "--out", str(tmp_path / "x")])


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_close_vec_env_frees_a_close_stuck_on_an_answer_already_read():
    """The Ctrl-C hang, made deterministic (found by the issue-19 helper): step_wait() had read worker 0's answer
    when the interrupt came, so SubprocVecEnv.close() waits for that answer again, forever; close_vec_env returns
    within its deadline and ends the workers."""
    import threading

    from dresspack.training.config import train_config_from_dict
    from dresspack.training.train import close_vec_env, make_vec_env

    venv = make_vec_env(train_config_from_dict({**SMOKE, "vec_env": "subproc"}), seed=0)
    venv.reset()
    venv.step_async([12, 12])
    venv.remotes[0].recv()  # what step_wait() had done when the interrupt arrived

    def plain_close():
        try:
            venv.close()
        except (EOFError, OSError):  # once close_vec_env has ended the workers
            pass

    blocked = threading.Thread(target=plain_close, daemon=True)
    blocked.start()
    blocked.join(3.0)
    assert blocked.is_alive()  # the bug: close() is stuck on worker 0
    t0 = time.time()
    close_vec_env(venv, timeout=1.0)
    assert time.time() - t0 < 15.0
    assert not any(p.is_alive() for p in venv.processes)


def _interrupt_after_first_row(argv: list[str], log: Path) -> tuple[int, list[str]]:
    """Run ``argv``, press Ctrl-C (SIGINT to its process group) once ``log`` holds a finished row, and return
    (exit code, the stderr lines that are not progress bars)."""
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=as_a_shell_starts_it)
    deadline = time.time() + 180
    while time.time() < deadline and not (log.is_file() and log.read_text().count("\n") >= 1):
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        return -1, []
    return proc.returncode, [line for line in err.replace("\r", "\n").splitlines() if line.strip()
                             and not line.startswith("evaluating")]


def test_ctrl_c_in_eval_prints_one_line_and_exits_130(tmp_path):
    out = tmp_path / "e"
    # far more runs than can finish between the first row and the signal, however loaded the machine
    args = ["--planners", "ompl", "--welds", "roof_rail_top", "sill_front", "roof_rail_top,sill_front", "--seeds",
            *[str(s) for s in range(12)], "--iterations", "300", "--no-render", "--jobs", "1", "--out", str(out)]
    code, lines = _interrupt_after_first_row([sys.executable, "-m", "dresspack_gym.cli.main", "eval", *args],
                                             out / "results.jsonl")
    assert code == 130 and len(lines) == 1, lines
    assert lines[0].startswith("interrupted: ") and "finished runs saved in" in lines[0]
    assert lines[0].endswith("resume with: dresspack eval " + " ".join(args))


def test_the_run_records_its_version_without_touching_the_repository(tmp_path):
    """``git status`` would refresh the index (taking .git/index.lock and rewriting .git/index) of a checkout
    whose files were touched: the version is read without writing anything, and a changed file still counts."""
    from dresspack.training.train import git_state

    def git(*args):
        subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=tmp_path, check=True,
                       capture_output=True)

    git("init", "-q")
    (tmp_path / "a.txt").write_text("a\n")
    git("add", "a.txt")
    git("commit", "-q", "-m", "a")
    time.sleep(1.1)
    os.utime(tmp_path / "a.txt")  # same content, newer time: a stat-dirty index entry that a refresh rewrites
    index = tmp_path / ".git" / "index"
    before = (index.read_bytes(), index.stat().st_mtime_ns)
    commit, dirty = git_state(tmp_path)
    assert len(commit) == 40 and dirty is False
    assert (index.read_bytes(), index.stat().st_mtime_ns) == before
    (tmp_path / "a.txt").write_text("b\n")
    assert git_state(tmp_path)[1] is True
    assert (index.read_bytes(), index.stat().st_mtime_ns) == before
