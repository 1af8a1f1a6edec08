"""Ctrl-C in a long ``dresspack`` command: one line (interrupted, what is saved, the command that resumes) and exit
code 130, from the parent and its worker processes alike."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from helpers import as_a_shell_starts_it

CLI = "import sys; from dresspack_gym.cli.main import main; sys.exit(main(sys.argv[1:], extensions=[]))"



def test_ctrl_c_in_robustness_map_prints_one_line_and_resumes(tmp_path):
    out = tmp_path / "map"
    args = ["robustness-map", "--grid", "small", "--station", "default", "--out", str(out), "--workers", "2"]
    proc = subprocess.Popen([sys.executable, "-c", CLI, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True,  # its own process group, as a terminal's job
                            preexec_fn=as_a_shell_starts_it)
    deadline = time.time() + 180
    results = out / "results.csv"
    while time.time() < deadline and not (results.is_file() and len(results.read_text().splitlines()) >= 2):
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C does: every process of the group gets it
    try:
        stdout, stderr = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        raise
    lines = [s for s in stderr.replace("\r", "\n").splitlines() if s.strip() and not s.startswith("robustness")]
    assert proc.returncode == 130 and len(lines) == 1, stderr[-3000:]
    saved = len(results.read_text().splitlines()) - 1
    assert lines[0] == (f"interrupted: {saved} configurations saved in {results}; resume with: dresspack "
                        + " ".join(args))
    assert stdout == ""


# --------------------------------------------------- plan, eval --jobs 2, train: once here, 20 times under load (slow)
def _wait_for(proc, ready, timeout: float = 180.0) -> None:
    deadline = time.time() + timeout
    while time.time() < deadline and proc.poll() is None and not ready():
        time.sleep(0.1)


def _interrupt(argv: list[str], ready, delay: float) -> tuple[int, list[str], float]:
    """Run ``dresspack argv`` in its own process group, press Ctrl-C (SIGINT to the group, as a terminal does)
    ``delay`` s after ``ready()``; (exit code, the stderr lines that are not progress bars, seconds to exit)."""
    proc = subprocess.Popen([sys.executable, "-m", "dresspack_gym.cli.main", *argv], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True, preexec_fn=as_a_shell_starts_it)
    _wait_for(proc, lambda: ready(proc))
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    t0 = time.time()
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        return -1, [], 60.0
    lines = [s for s in err.replace("\r", "\n").splitlines() if s.strip() and not s.startswith("evaluating")]
    return proc.returncode, lines, time.time() - t0


def _planning(proc) -> bool:
    """The planner's library is loaded: the command is past its start and into the work."""
    try:
        return "libompl" in open(f"/proc/{proc.pid}/maps").read()
    except OSError:
        return False


def _workers(n: int):
    """The command has ``n`` child processes (a spawn pool's workers and its resource tracker)."""
    def ready(proc) -> bool:
        try:
            children = open(f"/proc/{proc.pid}/task/{proc.pid}/children").read().split()
        except OSError:
            return False
        return len(children) >= n
    return ready


def _ctrl_c_in_plan(tmp_path, k: int) -> None:
    args = ["plan", "--planner", "ompl-wear", "--welds", "sill_rear", "roof_rail_top", "sill_front",
            "--out", str(tmp_path / f"p{k}.npz")]
    code, lines, seconds = _interrupt(args, _planning, 0.5 + 0.37 * (k % 5))
    assert code == 130 and len(lines) == 1 and seconds < 45, (code, lines, seconds)
    assert lines[0] == "interrupted: nothing was saved; run it again with: dresspack " + " ".join(args)
    assert not list(tmp_path.glob(f"*p{k}*"))  # no plan, no half of one


def _ctrl_c_in_eval(tmp_path, k: int) -> None:
    out = tmp_path / f"e{k}"
    args = ["eval", "--planners", "ompl", "--welds", "roof_rail_top", "sill_front", "roof_rail_top,sill_front",
            "--seeds", *[str(s) for s in range(6)], "--no-render", "--jobs", "2", "--out", str(out)]
    code, lines, seconds = _interrupt(args, _workers(3), 0.5 + 0.37 * (k % 5))
    assert code == 130 and len(lines) == 1 and seconds < 45, (code, lines, seconds)
    assert lines[0].startswith("interrupted: ") and "finished runs saved in" in lines[0]
    assert lines[0].endswith("resume with: dresspack " + " ".join(args))


def test_ctrl_c_in_plan_prints_one_line_and_exits_130(tmp_path):
    _ctrl_c_in_plan(tmp_path, 0)


def test_ctrl_c_in_eval_with_two_jobs_prints_one_line_and_exits_130(tmp_path):
    _ctrl_c_in_eval(tmp_path, 0)


@pytest.mark.slow
@pytest.mark.parametrize("k", range(20))
def test_ctrl_c_in_plan_under_load(tmp_path, busy_machine, k):
    _ctrl_c_in_plan(tmp_path, k)


@pytest.mark.slow
@pytest.mark.parametrize("k", range(20))
def test_ctrl_c_in_eval_with_two_jobs_under_load(tmp_path, busy_machine, k):
    _ctrl_c_in_eval(tmp_path, k)
