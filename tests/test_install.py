"""A plain install works: the wheel, installed with pip into a fresh virtual environment without extras, runs every
command from outside the checkout (the shipped configs and policies are package data, subcommands register
themselves, nothing generic lands top-level), and a command that needs an extra names it in one line."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
import zipfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from dresspack_gym.cli.main import build_parser

# pip resolves every dependency from the package index (about 2 min on 2 cores, mostly unpacking torch; the
# module about 4 min)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("pyproject.toml", "README.md", "dresspack_gym", "agents", "training", "eval", "configs")
# the CPU build scripts/setup.sh installs; the package's own spec (torch>=2.3) would let pip take a CUDA build
TORCH = "torch==2.13.0"
EXTRAS = ("ray", "compas_fab", "mkdocs", "pytest")  # one module of each extra: none may be installed


def run(cmd, **kw) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=env, timeout=900, **kw)


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
    assert run([sys.executable, "-m", "venv", venv]).returncode == 0  # its own pip, none of this venv's packages
    start = time.perf_counter()
    # as a user would: no extras (--no-compile: Python compiles what a command imports when it runs; compiling all
    # of torch and the rest up front doubles pip's CPU time, 46 s against 23 s)
    inst = run([venv / "bin" / "python", "-m", "pip", "install", "-q", "--no-compile", wheel, TORCH])
    assert inst.returncode == 0, inst.stderr
    print(f"pip install of the wheel and its dependencies: {time.perf_counter() - start:.0f} s")
    return wheel, venv, tmp


def test_wheel_installs_under_the_project_names_only_with_its_dependencies_and_no_extra(installed):
    wheel, venv, tmp = installed
    tops = {n.split("/")[0] for n in zipfile.ZipFile(wheel).namelist()}
    assert tops == {"dresspack_gym", "dresspack", wheel.name.split("-py3")[0] + ".dist-info"}
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {"dresspack_gym/configs/stations/default.yaml", "dresspack_gym/configs/training/stud_welding.yaml",
            "dresspack/agents/policies/stud_welding/model.zip", "dresspack/eval/cli.py"} <= names
    check = run([venv / "bin" / "python", "-m", "pip", "check"])
    assert check.returncode == 0, check.stdout
    where = run([venv / "bin" / "python", "-c", "import dresspack_gym, dresspack.agents.learned.policy as p; "
                 "print(dresspack_gym.__file__); print(p.POLICY_DIR)"], cwd=tmp)
    assert where.returncode == 0 and all(line.startswith(str(venv)) for line in where.stdout.split()), where.stderr
    probe = "import importlib.util as u, torch; print(torch.__version__); print(*[u.find_spec(m) is None for m in %r])"
    found = run([venv / "bin" / "python", "-c", probe % (EXTRAS,)], cwd=tmp)
    torch_version, absent = found.stdout.splitlines()
    assert torch_version.endswith("+cpu"), torch_version
    assert absent.split() == ["True"] * len(EXTRAS), f"an extra is installed: {dict(zip(EXTRAS, absent.split()))}"


def test_every_subcommand_has_help_in_the_plain_install(installed):
    """The installed ``dresspack`` lists the same subcommands as the checkout's parser, and each one's ``--help``
    runs: every entry-point command imports with the plain install's packages."""
    _, venv, tmp = installed
    expected = sorted(build_parser()._subparsers._group_actions[0].choices)
    listing = run([venv / "bin" / "dresspack", "--help"], cwd=tmp)
    assert listing.returncode == 0, listing.stderr
    assert all(f"    {name} " in listing.stdout or f"    {name}\n" in listing.stdout for name in expected), \
        listing.stdout
    with ThreadPoolExecutor(2) as pool:  # each one starts its own interpreter
        helps = dict(zip(expected, pool.map(lambda name: run([venv / "bin" / "dresspack", name, "--help"], cwd=tmp),
                                            expected)))
    failed = {name: out.stderr[-400:] for name, out in helps.items()
              if out.returncode != 0 or not out.stdout.startswith(f"usage: dresspack {name} ")}
    assert not failed, failed


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


@pytest.mark.parametrize("argv, extra", [
    (["robots", "abb_irb4600_40_255"], "robots"),
    (["robustness-map", "--grid", "small", "--station", "default", "--out", "map", "--backend", "ray",
      "--limit", "1"], "ray"),
])
def test_a_command_that_needs_a_missing_extra_names_it_in_one_line(installed, argv, extra):
    _, venv, tmp = installed
    out = run([venv / "bin" / "dresspack", *argv], cwd=tmp)
    assert out.returncode == 2, out.stdout + out.stderr
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and f"pip install 'dresspack-gym[{extra}]'" in lines[0], out.stderr


def test_installed_eval_and_train_are_subcommands_and_the_old_executables_still_run(installed):
    """`dresspack eval` and `dresspack train` come from their packages' entry points; `dresspack-eval` and
    `dresspack-train` are installed for one release and run the subcommand after one deprecation line."""
    _, venv, tmp = installed
    for old, new in (("dresspack-eval", "eval"), ("dresspack-train", "train")):
        out = run([venv / "bin" / old, "--help"], cwd=tmp)
        assert out.returncode == 0, out.stderr
        assert out.stderr.splitlines() == [f"dresspack: {old} is deprecated; use dresspack {new}"]
        assert out.stdout.startswith(f"usage: dresspack {new} ")
