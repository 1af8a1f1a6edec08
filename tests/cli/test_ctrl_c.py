"""Ctrl-C in a long ``dresspack`` command: one line (interrupted, what is saved, the command that resumes) and exit
code 130, from the parent and its worker processes alike."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

CLI = "import sys; from dresspack_gym.cli.main import main; sys.exit(main(sys.argv[1:], extensions=[]))"


def test_ctrl_c_in_robustness_map_prints_one_line_and_resumes(tmp_path):
    out = tmp_path / "map"
    args = ["robustness-map", "--grid", "small", "--station", "default", "--out", str(out), "--workers", "2"]
    proc = subprocess.Popen([sys.executable, "-c", CLI, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)  # its own process group, as a terminal's job
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
