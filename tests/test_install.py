"""A regular (non-editable) wheel install works from outside the checkout: the commands find the shipped configs
and policies as package data, subcommands register themselves, and nothing generic lands top-level."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("pyproject.toml", "README.md", "dresspack_gym", "agents", "training", "eval", "configs")


def run(cmd, **kw) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=env, timeout=600, **kw)


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("install")
    src = tmp / "src"
    src.mkdir()
    for name in SOURCES:  # a clean copy: building must not write into the checkout
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
        else:
            shutil.copy(path, src / name)
    build = run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                 tmp / "dist", src])
    assert build.returncode == 0, build.stderr
    wheel = next((tmp / "dist").glob("dresspack_gym-*.whl"))
    venv = tmp / "venv"
    assert run([sys.executable, "-m", "venv", "--without-pip", venv]).returncode == 0
    # the fresh venv sees this venv's third-party packages (offline, fast) as a plain path: the .pth files there
    # (among them the editable install of this checkout) are not processed
    site = Path(run([venv / "bin" / "python", "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"])
                .stdout.strip())
    (site / "project_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    inst = run([sys.executable, "-m", "pip", "--python", venv / "bin" / "python", "install", "--no-deps",
                "--no-index", "-q", wheel])
    assert inst.returncode == 0, inst.stderr
    return wheel, venv, tmp


def test_wheel_installs_under_the_project_names_only(installed):
    wheel, venv, tmp = installed
    tops = {n.split("/")[0] for n in zipfile.ZipFile(wheel).namelist()}
    assert tops == {"dresspack_gym", "dresspack", wheel.name.split("-py3")[0] + ".dist-info"}
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {"dresspack_gym/configs/stations/default.yaml", "dresspack_gym/configs/training/stud_welding.yaml",
            "dresspack/agents/policies/stud_welding/model.zip", "dresspack/eval/cli.py"} <= names
    # its dependencies resolve among the installed distributions
    check = run([sys.executable, "-m", "pip", "--python", venv / "bin" / "python", "check"])
    assert not [line for line in check.stdout.splitlines() if line.lower().startswith("dresspack-gym")], check.stdout
    where = run([venv / "bin" / "python", "-c", "import dresspack_gym, dresspack.agents.learned.policy as p; "
                 "print(dresspack_gym.__file__); print(p.POLICY_DIR)"], cwd=tmp)
    assert all(line.startswith(str(venv)) for line in where.stdout.split()), where.stdout + where.stderr


def test_installed_commands_run_outside_the_checkout(installed):
    _, venv, tmp = installed
    out = run([venv / "bin" / "dresspack", "inspect", "--station", "default", "--json"], cwd=tmp)
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)
    assert report["station"] == "stud_welding_default" and report["weld_points"] and report["max_curvature"] > 0
    out = run([venv / "bin" / "dresspack", "plan", "--station", "thesis_curvature", "--planner", "ompl", "--json"],
              cwd=tmp)
    assert out.returncode == 0, out.stderr
    plan = json.loads(out.stdout)
    assert plan["success"] is True and plan["cycle_time"] > 0


def test_installed_eval_and_train_are_subcommands_and_the_old_executables_still_run(installed):
    """`dresspack eval` and `dresspack train` come from their packages' entry points; `dresspack-eval` and
    `dresspack-train` are installed for one release and run the subcommand after one deprecation line."""
    _, venv, tmp = installed
    listing = run([venv / "bin" / "dresspack", "--help"], cwd=tmp)
    assert listing.returncode == 0 and "eval" in listing.stdout and "train" in listing.stdout
    for old, new in (("dresspack-eval", "eval"), ("dresspack-train", "train")):
        out = run([venv / "bin" / old, "--help"], cwd=tmp)
        assert out.returncode == 0, out.stderr
        assert out.stderr.splitlines() == [f"dresspack: {old} is deprecated; use dresspack {new}"]
        assert out.stdout.startswith(f"usage: dresspack {new} ")
