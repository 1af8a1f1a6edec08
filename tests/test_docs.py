"""The docs: the site builds with mkdocs --strict, the README stays short and links into it, no session narration."""

import os
import re
import subprocess
import sys
from pathlib import Path

import yaml

import dresspack_gym

ROOT = Path(__file__).resolve().parents[1]
README_MAX_LINES = 250
LINE_MAX_CHARS = 120
# a work session's number ("stop" then a number), which the repository never names: git keeps the history
SESSION_NUMBER = re.compile(r"\bstop[ -][0-9]", re.IGNORECASE)
TEXT_SUFFIXES = {".md", ".py", ".yaml", ".yml", ".toml", ".txt", ".cfg", ".sh"}


def repository_text_files() -> list[Path]:
    """The checkout's text files: tracked ones and new ones git does not ignore."""
    out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout
    files = [ROOT / line for line in out.splitlines() if Path(line).suffix in TEXT_SUFFIXES]
    return [f for f in files if f.is_file()]


def nav_pages(nav) -> list[str]:
    """Every page file named in mkdocs.yml's nav, however deeply nested."""
    if isinstance(nav, str):
        return [nav]
    if isinstance(nav, list):
        return [page for item in nav for page in nav_pages(item)]
    if isinstance(nav, dict):
        return [page for value in nav.values() for page in nav_pages(value)]
    return []


def mkdocs_config() -> dict:
    # the config's !!python tags are not used; a plain YAML read is enough to see the nav
    return yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))


def test_readme_is_short_and_narrow():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines; at most {README_MAX_LINES}"
    wide = [(i, len(line)) for i, line in enumerate(lines, 1) if len(line) > LINE_MAX_CHARS]
    assert not wide, f"README.md lines longer than {LINE_MAX_CHARS} characters (line, length): {wide}"


def test_readme_keeps_the_main_commands():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    test_command = "bash scripts/setup.sh && .venv/bin/python -m pytest -q"
    assert test_command in readme, "the README must show the exact test command CI runs"
    assert test_command in ci
    assert "bash scripts/setup.sh && .venv/bin/dresspack demo" in readme


def test_readme_links_point_at_files():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    targets = re.findall(r"\]\(((?!https?://)[^)#\s]+)(?:#[^)]*)?\)", readme)
    assert targets, "the README links into the docs site"
    missing = sorted({t for t in targets if not (ROOT / t).exists()})
    assert not missing, f"README.md links to files that do not exist: {missing}"


def test_no_session_numbers_in_the_repository():
    hits = []
    for path in repository_text_files():
        for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            if SESSION_NUMBER.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:80]}")
    assert not hits, "work-session numbers in the repository (say what is, not which session did it):\n" + \
        "\n".join(hits)


def test_every_page_is_in_the_nav():
    pages = set(nav_pages(mkdocs_config()["nav"]))
    on_disk = {p.relative_to(ROOT / "docs").as_posix() for p in (ROOT / "docs").rglob("*.md")}
    assert not pages - on_disk, f"nav names pages that do not exist: {sorted(pages - on_disk)}"
    assert not on_disk - pages, f"pages missing from mkdocs.yml's nav: {sorted(on_disk - pages)}"


def test_site_builds_strict(tmp_path):
    site = tmp_path / "site"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)], cwd=ROOT,
                         capture_output=True, text=True, env=env, timeout=600)
    assert run.returncode == 0, f"mkdocs build --strict failed:\n{run.stdout}\n{run.stderr}"
    # the hooks filled their pages: the CLI reference from the parsers, the API reference from the package face
    cli = (site / "cli" / "index.html").read_text(encoding="utf-8")
    assert "cli-reference" not in cli, "the CLI reference hook left its marker in the page"
    for command in ("plan", "station-plan", "export", "robustness-map", "eval", "train"):
        assert f"dresspack {command}" in cli, f"the CLI reference lacks `dresspack {command}`"
    api = (site / "api" / "index.html").read_text(encoding="utf-8")
    assert "public-api" not in api, "the API reference hook left its marker in the page"
    for name, module in dresspack_gym.PUBLIC.items():
        assert f'id="dresspack_gym.{module}.{name}"' in api, f"the API reference lacks {name} ({module})"
