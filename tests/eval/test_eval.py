"""The comparison report: built end to end on a tiny configuration; its numbers are results.json's numbers."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

pytest.importorskip("ompl")
pytest.importorskip("sb3_contrib")

from dresspack.eval.runs import METRICS, EvalSpec  # noqa: E402
from dresspack.eval.summary import JSON_KEYS, aggregate, by_method, fmt  # noqa: E402

from dresspack_gym.cli.main import main  # noqa: E402
from dresspack_gym.errors import ConfigError  # noqa: E402


@pytest.fixture(scope="module")
def tiny_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    code = main(["eval", "--planners", "ompl", "random", "--welds", "roof_rail_top", "--seeds", "0", "1",
                 "--time-budget", "5", "--out", str(out), "--json"])
    assert code == 0
    return out


def _table_rows(markdown: str, heading: str) -> dict[str, list[str]]:
    section = markdown.split(f"## {heading}", 1)[1].split("\n## ", 1)[0]
    rows = [line.strip("|").split(" | ") for line in section.splitlines() if line.startswith("| ")]
    header, *body = [[c.strip() for c in r] for r in rows]
    return {r[0]: dict(zip(header, r)) for r in body}


def test_report_numbers_equal_results_json_and_failures_are_shown(tiny_report):
    results = json.loads((tiny_report / "results.json").read_text())
    rows = results["rows"]
    assert len(rows) == 4 and {r["method"] for r in rows} == {"ompl", "random"}  # method x task x seed
    md = (tiny_report / "report.md").read_text()
    table = _table_rows(md, "All tasks")
    assert set(table) == {"ompl", "random"}  # a method that failed is listed, not dropped
    for method, shown in table.items():
        agg = aggregate([r for r in rows if r["method"] == method])
        assert shown["success"].startswith(f"{agg['n_success']}/{agg['n_runs']}")
        assert shown["∫C dt"] == fmt(agg["cost"]) and shown["cycle time [s]"] == fmt(agg["cycle_time"])
        assert shown["max κ [1/m]"] == fmt(agg["max_curvature"])
    assert table["ompl"]["success"].startswith("2/2")
    ompl = [r for r in rows if r["method"] == "ompl"]
    assert all(r["cost"] > 0 and r["cycle_time"] > 0 for r in ompl)
    # the random floor rarely completes in 100 steps; whatever it did, failures read "failed"
    failed = [r for r in rows if not r["success"]]
    assert all(r["error"] for r in failed)
    if all(not r["success"] for r in rows if r["method"] == "random"):
        assert table["random"]["∫C dt"] == "failed"
    assert results["summary"]["ompl"]["success_rate"] == 1.0


def test_report_files_and_embedded_figures(tiny_report):
    for name in ("report.md", "report.html", "results.json", "results.csv", "figures/overview.png",
                 "figures/restrictions.png", "figures/measures_roof_rail_top.png", "figures/worst_ompl.png"):
        assert (tiny_report / name).is_file(), name
    html = (tiny_report / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= 4 and "<table>" in html  # self-contained
    csv_lines = (tiny_report / "results.csv").read_text().strip().splitlines()
    assert len(csv_lines) == 1 + 4


def test_report_embeds_an_animation_per_successful_method(tiny_report):
    html_text = (tiny_report / "report.html").read_text()
    videos = sorted((tiny_report / "figures").glob("anim_*.mp4"))
    ok = {r["method"] for r in json.loads((tiny_report / "results.json").read_text())["rows"] if r["success"]}
    assert len(videos) == len(ok) >= 1 and all(v.stat().st_size > 1000 for v in videos)
    assert html_text.count("data:video/mp4;base64,") == len(videos)


def test_report_html_in_a_real_browser(tiny_report, tmp_path):
    """Headless Chromium: every figure decodes, every video loads, the console has no error, and the answer is on
    the first screen (saved as a screenshot). Before the resume test below, which redraws the report unrendered."""
    from browser import find_browser, load_page
    from PIL import Image

    browser = find_browser()
    if browser is None:
        pytest.skip("no Chromium or Chrome on PATH: apt-get install chromium (.ci/run installs it)")
    html = (tiny_report / "report.html").read_text()
    shot = tmp_path / "first_screen.png"
    page = load_page(browser, tiny_report / "report.html", shot)
    assert page["errors"] == []
    assert len(page["images"]) == html.count("<img ") >= 4
    assert [i["alt"] for i in page["images"] if i["width"] == 0] == []  # naturalWidth > 0: each figure decoded
    assert len(page["videos"]) == html.count("<video ")
    assert all(v["error"] is None and v["ready"] >= 1 for v in page["videos"])  # metadata read: the clip decodes
    answer = next(h for h in page["headings"] if h["text"] == "Answer")
    assert answer["top"] < page["viewport"][1] / 3  # the answer opens the first screen
    assert Image.open(shot).size == tuple(page["viewport"]) == (1280, 900)


def test_json_summary_keys_and_resume(tiny_report, capsys):
    code = main(["eval", "--planners", "ompl", "random", "--welds", "roof_rail_top", "--seeds", "0", "1",
                 "--time-budget", "5", "--out", str(tiny_report), "--json", "--no-render"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    for method in ("ompl", "random"):
        assert set(JSON_KEYS) <= set(summary[method])
    results = json.loads((tiny_report / "results.json").read_text())
    assert summary["ompl"]["cost"] == pytest.approx(aggregate([r for r in results["rows"]
                                                              if r["method"] == "ompl"])["cost"]["mean"])
    assert len((tiny_report / "results.jsonl").read_text().splitlines()) == 4  # resumed: nothing re-run
    from dresspack.eval.runs import CODE, LIBRARIES

    from dresspack_gym.io.provenance import code_fingerprint, library_versions

    written = json.loads((tiny_report / "spec.json").read_text())
    assert written["code"] == code_fingerprint(CODE)  # what resumes
    assert written["libraries"] == library_versions(LIBRARIES) and written["libraries"]["numpy"] == np.__version__
    setup = (tiny_report / "report.md").read_text().split("## Setup", 1)[1].split("##", 1)[0]
    assert f"Rows computed by code {written['code']}" in setup and f"numpy {np.__version__}" in setup


def test_bad_evaluation_input_names_the_field(tmp_path, capsys):
    with pytest.raises(ConfigError, match="methods"):
        EvalSpec(methods=("ompl", "astar"))
    assert main(["eval", "--welds", "nowhere", "--planners", "ompl", "--out", str(tmp_path)]) == 2
    assert re.search(r"welds|weld point", capsys.readouterr().err)


def test_report_shows_damage_and_life_per_method(tiny_report):
    """The damage section lists every method with its shortest life and weakest segment, and the figures of
    damage along the cable and of the damage strip are written."""
    md = (tiny_report / "report.md").read_text()
    table = _table_rows(md, "Damage and fatigue life")
    assert set(table) == {"ompl", "random"}
    for m, row in table.items():
        if row["shortest life [cycles]"] != "failed":
            assert float(row["shortest life [cycles]"]) > 0 and row["weakest segment (shortest)"].endswith(" m")
    assert list((tiny_report / "figures").glob("damage_roof_rail_top*.png"))
    assert list((tiny_report / "figures").glob("damage_strip_roof_rail_top*.png"))



def test_report_names_runs_whose_settles_missed_the_residual():
    from dresspack.eval.report import _settle_note

    rows = [{"method": "ompl", "task": "a", "seed": 0, "success": True, "unconverged_stops": 0},
            {"method": "ompl-wear", "task": "a", "seed": 1, "success": True, "unconverged_stops": 2}]
    assert _settle_note(rows) == ("Settles that did not reach the equilibrium residual within their cap (stops per "
                                  "run): ompl-wear on a (seed 1): 2")
    assert _settle_note(rows[:1]).startswith("Every settle")


def test_network_time_column_only_for_a_learned_planner():
    from dresspack.eval.report import _table

    def row(method, planning, inference=None):
        r = {"method": method, "success": True, **{m: 1.0 for m in METRICS}, "planning_time": planning}
        return r | ({"inference_time": inference} if inference is not None else {})

    rows = [row("ppo", 4.0, 0.002), row("ppo", 6.0, 0.004), row("ompl", 2.0)]
    table = _table(by_method(rows, ["ppo", "ompl"]))
    assert table["header"][-1] == "network [s]"
    assert table["rows"][0][-1].startswith("0.003") and table["rows"][1][-1] == "–"
    assert "network [s]" not in _table(by_method(rows[2:], ["ompl"]))["header"]


def test_an_evaluation_folder_takes_added_methods_but_no_other_change():
    from dresspack.eval.runs import _extends

    base = EvalSpec(methods=("ompl",), tasks=(("roof_rail_top",),), seeds=(0,)).to_dict()
    more = EvalSpec(methods=("ompl", "ppo"), tasks=(("roof_rail_top",),), seeds=(0,), policy="somewhere").to_dict()
    assert _extends(base, base) and _extends(base, more)
    assert not _extends(more, base)  # a stored method dropped
    assert not _extends(more, more | {"policy": "elsewhere"})  # the stored ppo rows came from another policy
    assert not _extends(base, more | {"seeds": [0, 1]}) and not _extends(base, more | {"iterations": 10})


@pytest.mark.parametrize("stored_code", ["0123456789ab", None])
def test_an_evaluation_folder_of_other_code_is_refused_before_anything_runs(tmp_path, stored_code):
    """A folder whose spec.json records another code fingerprint (or none: written before it was recorded) is not
    resumed: its rows would mix two versions of the code. The folder is left as it was."""
    from dresspack.eval.runs import CODE, run_evaluation

    from dresspack_gym.io.provenance import code_fingerprint

    spec = EvalSpec(methods=("ompl",), tasks=(("roof_rail_top",),), seeds=(0,))
    stored = spec.to_dict() | ({"code": stored_code} if stored_code else {})
    (tmp_path / "spec.json").write_text(json.dumps(stored))
    with pytest.raises(ConfigError, match=f"out.*other code.*{stored_code or 'none'}.*{code_fingerprint(CODE)}"):
        run_evaluation(spec, tmp_path, progress=False)
    assert json.loads((tmp_path / "spec.json").read_text()) == stored and list(tmp_path.iterdir()) == [
        tmp_path / "spec.json"]


def test_an_evaluation_folder_of_other_libraries_is_refused_naming_them(tmp_path):
    """The same code with another version of a library (or a folder written before the libraries were recorded)
    is not resumed: the message names each library that differs, with both versions. The folder is left as it
    was."""
    from dresspack.eval.runs import CODE, LIBRARIES, run_evaluation

    from dresspack_gym.io.provenance import code_fingerprint, library_versions

    spec = EvalSpec(methods=("ompl",), tasks=(("roof_rail_top",),), seeds=(0,))
    here = library_versions(LIBRARIES)
    for libraries, named in (({**here, "numpy": "1.0.0"}, f"numpy: 1.0.0 there, {np.__version__} here"),
                             ({k: v for k, v in here.items() if k != "ompl"}, f"ompl: None there, {here['ompl']}"),
                             (None, "python: None there")):
        stored = spec.to_dict() | {"code": code_fingerprint(CODE)} | ({"libraries": libraries} if libraries else {})
        (tmp_path / "spec.json").write_text(json.dumps(stored))
        with pytest.raises(ConfigError, match="other libraries") as e:
            run_evaluation(spec, tmp_path, progress=False)
        assert named in str(e.value)
        assert json.loads((tmp_path / "spec.json").read_text()) == stored and list(tmp_path.iterdir()) == [
            tmp_path / "spec.json"]


def test_time_weight_is_checked_stored_and_older_folders_still_resume(capsys):
    from dresspack.eval.runs import _extends

    for bad in (-0.5, -1.0, 1001, float("nan"), float("inf"), True, "2"):
        with pytest.raises(ConfigError, match="time_weight"):
            EvalSpec(methods=("ompl-wear",), time_weight=bad)
    with pytest.raises(SystemExit):
        main(["eval", "--planners", "ompl-wear", "--time-weight", "-1"])
    assert "--time-weight" in capsys.readouterr().err
    base = EvalSpec(methods=("ompl-wear",), tasks=(("roof_rail_top",),), seeds=(0,)).to_dict()
    faster = base | {"time_weight": 10.0}
    older = {k: v for k, v in base.items() if k != "time_weight"}  # written before the setting existed (weight 1)
    assert _extends(older, base) and not _extends(older, faster) and not _extends(base, faster)


def test_time_weight_and_cost_variant_reach_the_wear_aware_leg_cost(monkeypatch, tmp_path):
    """The weight and the wear cost are the planners' LegCost's (J = weight x seconds + ∫C dt): the one place they
    act; ppo-search's other routes and refinement use ompl-wear's."""
    from dresspack.eval import runs

    from dresspack_gym.io.loading import load_station
    from dresspack_gym.stations.station import Station

    real = runs.make_planner
    for method in ("ompl-wear", "ppo-search"):
        spec = EvalSpec(methods=(method,), tasks=(("roof_rail_top",),), seeds=(0,), time_weight=7.5,
                        cost_variant="damage")
        for name, value in (("time_weight", 7.5), ("cost_variant", "damage")):
            assert _argument_reaching_the_planner(monkeypatch, tmp_path / method, spec, name) == {method: value}
    station = Station(load_station("default"))
    wear = real("ompl-wear", station, 0, seed=0, time_weight=7.5, cost_variant="damage", routes=1, evaluations=1,
                iterations=100).leg_cost
    search = real("ppo-search", station, 0, seed=0, time_weight=7.5, cost_variant="damage").refiner.cost
    assert wear.time_weight == search.time_weight == 7.5 and wear.cost_variant == search.cost_variant == "damage"


def test_a_policy_evaluation_names_its_policy_so_a_changed_default_cannot_mix_rows():
    from dresspack.agents.learned.policy import DEFAULT_POLICY
    from dresspack.eval.runs import _extends

    assert EvalSpec(methods=("ompl",)).policy is None
    named = EvalSpec(methods=("ompl", "ppo"), tasks=(("roof_rail_top",),), seeds=(0,)).to_dict()
    assert named["policy"] == DEFAULT_POLICY
    older = named | {"policy": None}  # ppo rows of a folder written when the default was another policy
    assert not _extends(older, named)


@pytest.mark.parametrize("name, bads, cli_bad, older_value, other, given", [
    ("proposals", (0, 65, 2.5, True, "3"), "0", 3, 5, 5),  # folders written before a setting existed used older_value
    ("refine", (-1, 10_001, 2.5, True, "3"), "-1", 0, 20, 7),
    ("alternatives", (-1, 1001, 2.5, True, "3"), "-1", 0, 4, 3),
])
def test_search_settings_are_checked_stored_and_reach_the_search(monkeypatch, tmp_path, capsys, name, bads, cli_bad,
                                                                  older_value, other, given):
    from dresspack.eval.runs import _extends

    for bad in bads:
        with pytest.raises(ConfigError, match=f"^{name}: must be an integer in"):
            EvalSpec(methods=("ppo-search",), **{name: bad})
    with pytest.raises(SystemExit):
        main(["eval", "--planners", "ppo-search", f"--{name}", cli_bad])
    assert f"--{name}" in capsys.readouterr().err
    spec = EvalSpec(methods=("ppo-search",), tasks=(("roof_rail_top",),), seeds=(0,), **{name: older_value}).to_dict()
    older = {k: v for k, v in spec.items() if k != name}  # a folder written before the setting existed
    assert _extends(older, spec) and not _extends(older, spec | {name: other})
    spec = EvalSpec(methods=("ppo-search",), tasks=(("roof_rail_top",),), seeds=(0,), **{name: given})
    assert _argument_reaching_the_planner(monkeypatch, tmp_path, spec, name) == {"ppo-search": given}


def test_a_cost_to_go_model_is_checked_stored_and_reaches_the_search(monkeypatch, tmp_path):
    from dresspack.eval.runs import _extends

    with pytest.raises(ConfigError, match="^cost_to_go: .*missing.pt is neither auto, none, a file"):
        EvalSpec(methods=("ppo-search",), cost_to_go=str(tmp_path / "missing.pt"))
    (tmp_path / "ctg.pt").write_bytes(b"")
    spec = EvalSpec(methods=("ppo-search",), tasks=(("roof_rail_top",),), seeds=(0,),
                    cost_to_go=str(tmp_path / "ctg.pt"))
    plain = {k: v for k, v in spec.to_dict().items() if k != "cost_to_go"}  # a folder written before the setting
    assert _extends(plain, plain | {"cost_to_go": None}) and not _extends(plain, spec.to_dict())
    # the default simulates the continuations, as those older folders did; "none" says so; "auto" ranks by the
    # model shipped with the policy: not those folders' settings
    default = EvalSpec(methods=("ppo-search",), tasks=(("roof_rail_top",),), seeds=(0,))
    assert default.cost_to_go is None and _extends(plain, default.to_dict())
    simulated = EvalSpec(methods=("ppo-search",), tasks=(("roof_rail_top",),), seeds=(0,), cost_to_go="none")
    assert simulated.cost_to_go is None and _extends(plain, simulated.to_dict())
    auto = EvalSpec(methods=("ppo-search",), tasks=(("roof_rail_top",),), seeds=(0,), cost_to_go="auto")
    assert not _extends(plain, auto.to_dict())
    assert _argument_reaching_the_planner(monkeypatch, tmp_path, spec, "cost_to_go") == {
        "ppo-search": str(tmp_path / "ctg.pt")}


def _argument_reaching_the_planner(monkeypatch, tmp_path, spec: EvalSpec, name: str) -> dict:
    """Per method, the keyword argument ``name`` the evaluation builds its planner with (the evaluation is stopped
    as soon as the planner would be built)."""
    from dresspack.eval import runs

    made = {}

    def spy(method, *args, **kwargs):
        made[method] = kwargs.get(name)
        raise ConfigError("methods", "stopped by the test after the planner's arguments were seen")

    monkeypatch.setattr(runs, "make_planner", spy)
    with pytest.raises(ConfigError, match="stopped by the test"):
        runs.run_evaluation(spec, tmp_path / name, progress=False)
    return made
