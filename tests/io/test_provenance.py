"""The code fingerprint: any change to a package's files changes it, compiled caches and other packages do not."""

from __future__ import annotations

import sys

import pytest

from dresspack_gym.errors import ConfigError
from dresspack_gym.io.provenance import FINGERPRINT_DIGITS, code_fingerprint, library_versions


@pytest.fixture
def package(tmp_path, monkeypatch):
    """A package ``fp_probe`` (a module and a data file) on sys.path; the fingerprint cache cleared around it."""
    root = tmp_path / "fp_probe"
    (root / "data").mkdir(parents=True)
    (root / "__init__.py").write_text('"""A probe."""\nVALUE = 1  # one\n')
    (root / "data" / "table.yaml").write_text("a: 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    code_fingerprint.cache_clear()
    yield root
    code_fingerprint.cache_clear()
    sys.modules.pop("fp_probe", None)


def _fresh(*packages):
    code_fingerprint.cache_clear()
    return code_fingerprint(packages)


def test_any_change_of_a_file_changes_the_fingerprint_and_caches_do_not(package):
    first = _fresh("fp_probe")
    assert len(first) == FINGERPRINT_DIGITS and int(first, 16) >= 0
    assert _fresh("fp_probe") == first  # the same files, the same fingerprint
    (package / "__pycache__").mkdir()
    (package / "__pycache__" / "x.cpython-311.pyc").write_bytes(b"\x00compiled")
    assert _fresh("fp_probe") == first
    for change in (lambda: (package / "__init__.py").write_text('"""A probe."""\nVALUE = 1  # One\n'),  # a comment
                   lambda: (package / "data" / "table.yaml").write_text("a: 2\n"),  # a config
                   lambda: (package / "data" / "table.yaml").rename(package / "data" / "other.yaml"),  # a name
                   lambda: (package / "extra.py").write_text("")):  # a new empty file
        before = _fresh("fp_probe")
        change()
        assert _fresh("fp_probe") != before
    assert _fresh("fp_probe", "dresspack_gym") != _fresh("fp_probe")


def test_an_unknown_package_is_named():
    for name in ("no_such_package_here", "no_such_parent.child"):
        with pytest.raises(ConfigError, match=f"packages.*{name}"):
            _fresh(name)


def test_library_versions_are_the_installed_ones_and_none_for_a_missing_one():
    import platform

    import numpy as np
    import yaml

    got = library_versions(("numpy", "PyYAML", "no-such-distribution-xyz"))
    assert got == {"python": platform.python_version(), "numpy": np.__version__, "PyYAML": yaml.__version__,
                   "no-such-distribution-xyz": None}
