"""The package's layout as users meet it: the names at the package face, and the old module paths as deprecated
aliases of the modules that hold the code now."""

import importlib
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import dresspack_gym
from dresspack_gym.moved_modules import MOVED, SPLIT


@pytest.mark.parametrize("name", sorted(dresspack_gym.PUBLIC))
def test_public_names_load_from_the_package_face(name):
    value = getattr(dresspack_gym, name)
    assert getattr(importlib.import_module(f"dresspack_gym.{dresspack_gym.PUBLIC[name]}"), name) is value


def test_an_old_module_path_of_a_public_name_leaves_the_name_alone():
    """``dresspack_gym.wear_cost`` is the function at the package face, whatever imported its old module path."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        module = importlib.import_module("dresspack_gym.wear_cost")
    assert module.__name__ == "dresspack_gym.physics.wear_cost" and dresspack_gym.wear_cost is module.wear_cost


def test_an_unknown_name_at_the_face_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_name"):
        dresspack_gym.no_such_name  # noqa: B018


def test_importing_the_package_loads_no_simulation():
    out = subprocess.run([sys.executable, "-c", "import sys, dresspack_gym; print('mujoco' in sys.modules)"],
                         capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_every_old_module_path_warns_on_its_first_import():
    code = ("import warnings, importlib\nfrom dresspack_gym.moved_modules import MOVED\n"
            "for old in sorted(MOVED):\n    with warnings.catch_warnings(record=True) as seen:\n"
            "        warnings.simplefilter('always')\n        importlib.import_module('dresspack_gym.' + old)\n"
            "    print(old, any(issubclass(w.category, DeprecationWarning) for w in seen))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split("\n")
    assert sorted(line for line in out if line) == sorted(f"{old} True" for old in MOVED)


@pytest.mark.parametrize("old", sorted(MOVED))
def test_an_old_module_path_is_the_new_module(old):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        module = importlib.import_module(f"dresspack_gym.{old}")
    new = importlib.import_module(f"dresspack_gym.{MOVED[old]}")
    assert module is new and new.__spec__.name == f"dresspack_gym.{MOVED[old]}"  # the real module keeps its spec


def test_the_split_config_module_offers_every_dataclass_it_held():
    with pytest.warns(DeprecationWarning):
        old = importlib.import_module("dresspack_gym.config")
    for part in SPLIT["config"]:
        module = importlib.import_module(f"dresspack_gym.{part}")
        for name in ("RobotConfig", "DresspackConfig", "StationConfig"):
            if hasattr(module, name) and getattr(module, name).__module__ == module.__name__:
                assert getattr(old, name) is getattr(module, name)


def test_a_module_nobody_moved_is_still_missing():
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("dresspack_gym.no_such_module")


def test_every_package_folder_is_listed_for_the_wheel():
    """A folder of modules missing from pyproject's ``packages`` installs nowhere (an installed command then fails)."""
    tomllib = pytest.importorskip("tomllib")  # Python 3.11 and newer
    root = Path(__file__).resolve().parents[1]
    listed = set(tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    folders = {"dresspack_gym": "dresspack_gym", "agents": "dresspack.agents", "training": "dresspack.training",
               "eval": "dresspack.eval"}
    found = {name + "".join("." + part for part in init.parent.relative_to(root / folder).parts)
             for folder, name in folders.items() for init in (root / folder).rglob("__init__.py")}
    assert found <= listed, f"not in pyproject.toml's packages: {sorted(found - listed)}"
