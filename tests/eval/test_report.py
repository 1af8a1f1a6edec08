"""The report's answer, figures and captions from rows written by hand: it concludes what the rows say."""

from __future__ import annotations

import re

import numpy as np
import pytest

pytest.importorskip("ompl")  # the report imports the planner registry (its colours)

from browser import find_browser, load_page  # noqa: E402
from dresspack.eval.conclusion import conclude  # noqa: E402
from dresspack.eval.report import write_report  # noqa: E402
from dresspack.eval.runs import METRICS, EvalSpec  # noqa: E402
from dresspack.eval.summary import aggregate, fmt  # noqa: E402

from dresspack_gym.io.loading import load_station  # noqa: E402
from dresspack_gym.physics.trajectory import Replay  # noqa: E402


def run(method, task, seed, *, T=None, cost=None, life=None, weakest=(0.87, "bending", 0.0012)):
    """A row as run_evaluation writes it: a success with the given cycle time, ∫C dt, life and weakest segment
    (arc length, the strain that fails it, its amplitude), or (no T) a failure."""
    row = {"key": f"{method}|{task}|{seed}", "method": method, "task": task, "welds": [task], "seed": seed,
           "success": T is not None, "error": None if T is not None else "no path found"}
    row |= dict.fromkeys(METRICS)
    if T is not None:
        row |= {m: 1.0 for m in METRICS} | {"cycle_time": T, "cost": cost, "life_cycles": life, "max_cost": 1.0,
                                            "unconverged_stops": 0, "weakest_segment_m": weakest[0],
                                            "weakest_cause": weakest[1], "weakest_strain_amplitude": weakest[2]}
    return row


# J = T + ∫C dt per run: ompl-wear 100 and 120 (a, b), thesis-local 125 and 150 (one of its b seeds fails), ompl
# 150 and 180; random fails everything. Lives: ompl 4000 on both, ompl-wear 1000 (one b seed 900, failing by
# stretch at 1.45 m), thesis-local 2000.
ROWS = [
    run("ompl", "a", 0, T=10, cost=140, life=4000), run("ompl", "a", 1, T=10, cost=140, life=4000),
    run("ompl", "b", 0, T=20, cost=160, life=4000), run("ompl", "b", 1, T=20, cost=160, life=4000),
    run("ompl-wear", "a", 0, T=12, cost=88, life=1000), run("ompl-wear", "a", 1, T=12, cost=88, life=1000),
    run("ompl-wear", "b", 0, T=22, cost=98, life=1000), run("ompl-wear", "b", 1, T=22, cost=98, life=900,
                                                             weakest=(1.45, "stretch", 0.0084)),
    run("thesis-local", "a", 0, T=11, cost=114, life=2000), run("thesis-local", "a", 1, T=11, cost=114, life=2000),
    run("thesis-local", "b", 0, T=21, cost=129, life=2000), run("thesis-local", "b", 1),
    *(run("random", t, s) for t in "ab" for s in (0, 1)),
]
METHODS = ["ompl", "ompl-wear", "thesis-local", "random"]


def test_the_answer_names_the_best_by_how_much_and_every_failure():
    answer = conclude(ROWS, METHODS)
    bullets = answer["bullets"]
    # means over a and b: ompl-wear 110, thesis-local 137.5, ompl 165 -> 1.25x and 1.5x the best
    assert bullets[0] == ("Best on T + ∫C dt (lower is better): ompl-wear, 110 (mean over the 2 tasks every ranked "
                          "method solved); runner-up thesis-local 138 (1.25× as much); wear-unaware ompl 165 (1.50× "
                          "as much).")
    # ompl-wear's life: geometric mean over a (1000) and b (1000 and 900: 948.7) = 974.0; spread over its 4 runs
    spread = np.exp(np.std(np.log([1000, 1000, 1000, 900])))
    assert bullets[1] == ("Fatigue life beside it (station cycles to the first conductor failure, geometric mean over "
                          "the same tasks, ×/÷ its spread over the runs; higher is better): ompl-wear 974 cycles "
                          f"(×/÷ {spread:.2f}), thesis-local 2000 cycles (×/÷ 1.00), ompl 4000 cycles (×/÷ 1.00).")
    # one verdict: the objective decides; the longer life is named with the segment and strain that shorten it
    assert bullets[2] == ("The answer is ompl-wear, the lowest T + ∫C dt, the station's objective; but ompl's cable "
                          "lives 4.1× as long (4000 cycles against 974): ompl-wear's cable fails first at 1.45 m along "
                          "the cable, where it is pulled and released (axial strain amplitude 0.84 %), which T + ∫C dt "
                          "does not count as fatigue. To plan for cable life instead, plan with --cost-variant life.")
    assert not any("choose by what" in b for b in bullets)
    assert "Not ranked, having solved no task: random." in bullets
    assert "thesis-local: 3/4 runs succeeded (75%); failed on b (1/2 seeds)." in bullets
    assert "random: 0/4 runs succeeded (0%); failed on a (2/2 seeds), b (2/2 seeds)." in bullets
    assert "ompl: 4/4 runs succeeded (100%); no failure." in bullets
    table = answer["table"]
    assert [r[0] for r in table["rows"]] == ["ompl-wear", "thesis-local", "ompl"]  # best first; random unranked
    assert table["rows"][0][1:] == ["110", "17.0", "93.0", f"974 ×/÷ {spread:.2f}", "2"]
    assert table["rows"][2][4] == "4000 ×/÷ 1.00"


def test_the_verdict_agrees_when_the_best_on_the_objective_also_lives_longest():
    rows = [run("ompl", "a", 0, T=10, cost=140, life=500), run("ompl-wear", "a", 0, T=12, cost=88, life=3000)]
    bullets = conclude(rows, ["ompl", "ompl-wear"])["bullets"]
    assert bullets[1].endswith("ompl-wear 3000 cycles (one run), ompl 500 cycles (one run).")
    assert bullets[2] == ("The answer is ompl-wear: the lowest T + ∫C dt, the station's objective, and its cable also "
                          "lives longest (3000 cycles).")


def test_the_answer_compares_only_on_tasks_every_ranked_method_solved():
    rows = [*ROWS, run("ompl-wear-fmt", "a", 0, T=1, cost=1, life=10)]
    bullets = conclude(rows, [*METHODS, "ompl-wear-fmt"])["bullets"]
    # ompl-wear-fmt solved a alone: every method is then scored on a only (ompl-wear 100, ompl 150)
    assert bullets[0].startswith("Best on T + ∫C dt (lower is better): ompl-wear-fmt, 2.00 (on a, the one task every "
                                 "ranked method solved); runner-up ompl-wear 100 (50.00× as much); wear-unaware "
                                 "ompl 150 (75.00× as much)")
    assert "ompl-wear-fmt: 1/1 runs succeeded (100%); no failure." in bullets


def test_a_method_that_solved_fewer_than_half_the_tasks_does_not_narrow_the_ranking():
    """A floor that finishes one easy task of three is listed, not ranked: the others are compared on all three."""
    rows = [*ROWS, *(run(m, "c", s, T=5, cost=50, life=100) for m in ("ompl", "ompl-wear", "thesis-local")
                     for s in (0, 1)), run("random", "c", 0, T=1, cost=1, life=1)]
    answer = conclude(rows, METHODS)
    assert "mean over the 3 tasks every ranked method solved" in answer["bullets"][0]
    assert "Not ranked, having solved fewer than half the tasks: random (1 of 3)." in answer["bullets"]
    assert [r[0] for r in answer["table"]["rows"]] == ["ompl-wear", "thesis-local", "ompl"]
    assert {r[-1] for r in answer["table"]["rows"]} == {"3"}
    few = conclude([r for r in rows if r["method"] == "random"], ["random"])["bullets"][0]
    assert few == ("No method solved half of the 3 tasks: no like-for-like ranking on T + ∫C dt; see the per-task "
                   "tables.")


def test_the_answer_with_one_method_or_none_solving():
    alone = conclude([r for r in ROWS if r["method"] == "ompl"], ["ompl"])["bullets"]
    assert alone[0] == ("T + ∫C dt (lower is better): ompl, 165 (mean over the 2 tasks it solved); the only method "
                        "evaluated.")
    none = conclude([r for r in ROWS if r["method"] == "random"], ["random"])
    assert none["bullets"][0] == "No method completed any run: nothing to rank." and none["table"]["rows"] == []
    weighted = conclude(ROWS, METHODS, time_weight=2.0)["bullets"][0]
    # 2·T + ∫C dt: ompl-wear 127, thesis-local 153.5, ompl 180
    assert weighted.startswith("Best on 2·T + ∫C dt (lower is better): ompl-wear, 127 ")
    assert "runner-up thesis-local 154 (1.21× as much)" in weighted


def test_one_run_has_no_spread_to_show():
    one = aggregate([run("ompl", "a", 0, T=7.25, cost=3.0)])
    assert fmt(one["cycle_time"]) == "7.25"  # not "7.25 ± 0": one run says nothing of the spread
    two = aggregate([run("ompl", "a", s, T=7.25, cost=3.0) for s in (0, 1)])
    assert fmt(two["cycle_time"]) == "7.25 ± 0"  # two equal runs: no spread, measured
    noisy = {"mean": 14.7, "std": 1.3e-15, "n": 2}
    assert fmt(noisy) == "14.7 ± 0"  # float round-off of equal values is no spread


@pytest.fixture(scope="module")
def one_method_report(tmp_path_factory):
    """The report of ompl alone on two tasks, one seed each, from rows (no trajectories: no per-task figures)."""
    out = tmp_path_factory.mktemp("one_method")
    rows = [run("ompl", "a", 0, T=10, cost=140, life=4000), run("ompl", "b", 0, T=20, cost=160, life=3000)]
    spec = EvalSpec(methods=("ompl",), tasks=(("a",), ("b",)), seeds=(0,))
    paths = write_report(spec, rows, out, render=False)
    return out, paths


def test_the_report_opens_with_the_answer(one_method_report):
    out, _ = one_method_report
    md = (out / "report.md").read_text()
    headings = re.findall(r"^## (.+)$", md, flags=re.M)
    assert headings[0] == "Answer" and headings[1] == "Setup"
    answer = md.split("## Answer", 1)[1].split("\n## ", 1)[0]
    assert "- T + ∫C dt (lower is better): ompl, 165 (mean over the 2 tasks it solved)" in answer
    for task in ("a", "b"):  # one seed per task: the mean alone
        section = md.split(f"## Task: home → {task} → home", 1)[1].split("\n## ", 1)[0]
        assert "| 10.0 |" in section or "| 20.0 |" in section
        assert "±" not in section


def test_one_method_overview_has_a_bar_per_task_and_says_which_way_is_better(kept_figures, tmp_path):
    figures = kept_figures
    rows = [run("ompl", "a", 0, T=10, cost=140, life=4000), run("ompl", "b", 0, T=20, cost=160, life=3000)]
    write_report(EvalSpec(methods=("ompl",), tasks=(("a",), ("b",)), seeds=(0,)), rows, tmp_path, render=False)
    overview = next(f for f in figures if len(f.axes) == 6)
    for ax in overview.axes:
        assert [t.get_text() for t in ax.get_xticklabels()] == ["a", "b"]  # one bar per task, not one per panel
        assert ax.get_ylabel() in ("lower is better", "higher is better")
    by_title = {ax.get_title(): ax for ax in overview.axes}
    assert by_title["min d [m]"].get_ylabel() == "higher is better"
    assert by_title["cycle time [s]"].get_ylabel() == "lower is better"
    clearance = load_station("default").wear_cost.clearance
    legend = [t.get_text() for t in by_title["min d [m]"].get_legend().get_texts()]
    assert legend == [f"c = {clearance:g} m"]  # the clearance threshold has its legend entry


def test_one_method_on_one_task_has_no_bar_chart(tmp_path):
    rows = [run("ompl", "a", 0, T=10, cost=140, life=4000)]
    paths = write_report(EvalSpec(methods=("ompl",), tasks=(("a",),), seeds=(0,)), rows, tmp_path, render=False)
    assert "overview" not in paths["figures"] and not (tmp_path / "figures" / "overview.png").exists()
    assert "One method on one task: the table above is the whole overview." in (tmp_path / "report.md").read_text()


def test_every_caption_is_written_once(one_method_report):
    out, _ = one_method_report
    md = (out / "report.md").read_text()
    captions = re.findall(r"^\*(.+)\*$", md, flags=re.M)
    alts = re.findall(r"^!\[(.+?)\]\(", md, flags=re.M)
    assert captions and len(captions) == len(alts)
    for caption in captions:
        assert md.count(caption) == 1, caption  # the alt text is a short title, not the caption again
    html = (out / "report.html").read_text()
    figcaptions = re.findall(r"<figcaption>(.+?)</figcaption>", html)
    assert len(figcaptions) == len(set(figcaptions)) == len(captions)


def test_the_restrictions_figure_names_joints_and_labels_each_zone(kept_figures, tmp_path):
    from dresspack_gym.plots.restrictions import plot_restrictions, rule_label

    figures = kept_figures
    config = load_station("default")
    summary = plot_restrictions(config, str(tmp_path / "zones.png"))
    (ax,) = figures[0].axes
    assert ax.get_xlabel() == "j6, tool flange turn [deg]" and ax.get_ylabel() == "j5, wrist bend [deg]"
    rules = config.robots[0].restrictions.rules
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend[:3] == [f"({i + 1}) forbidden: {rule_label(rule)}" for i, rule in enumerate(rules)]
    assert legend[:3] == ["(1) forbidden: cable twist j4 + j6 below 90°",
                          "(2) forbidden: cable twist j4 + j6 - 360° outside [-270°, 270°]",
                          "(3) forbidden: cable support closer than 50 mm to the forearm (cylinder)"]
    assert legend[3].startswith("Home (j5 -60°, j6 180°)")
    numbers = {t.get_text() for t in ax.texts}
    assert {"(1)", "(2)", "(3)"} <= numbers  # each zone numbered inside the plot
    assert set(summary) == {"r1"} and 0 < summary["r1"] < 1


def test_the_measures_figure_has_a_legend_entry_for_each_threshold(kept_figures, tmp_path):
    from dresspack_gym.plots.replay import plot_replays

    figures = kept_figures
    t = np.linspace(0, 2, 21)
    measures = {name: np.full_like(t, 0.5) for name in ("curvature", "tension", "clearance", "twist_rate")}
    rep = Replay(t, np.zeros((21, 6)), measures, np.zeros_like(t), {}, [1.0, 2.0], 2.0,
                 {"curvature": 8.0, "clearance": 0.05})
    plot_replays({"ompl (seed 0)": rep}, tmp_path / "m.png")
    curvature, tension, clearance, twist = figures[0].axes
    assert [x.get_text() for x in curvature.get_legend().get_texts()] == ["ompl (seed 0)",
                                                                          "curvature threshold κ0 = 8 1/m"]
    assert [x.get_text() for x in clearance.get_legend().get_texts()] == ["clearance threshold c = 0.05 m"]
    assert tension.get_legend() is None and twist.get_legend() is None
    assert clearance.get_ylabel().endswith("higher is better") and tension.get_ylabel().endswith("lower is better")


def test_the_browser_check_catches_a_broken_image_and_console_errors(tmp_path):
    """The check the report's browser test relies on fails on a page that is broken."""
    browser = find_browser()
    if browser is None:
        pytest.skip("no Chromium or Chrome on PATH: apt-get install chromium (.ci/run installs it)")
    page = tmp_path / "broken.html"
    page.write_text("<!doctype html><html><body><h1>Broken</h1><img alt='cut' src='data:image/png;base64,AAAA'>"
                    "<img alt='missing' src='missing.png'><script>console.error('boom'); not_defined();</script>"
                    "</body></html>")
    seen = load_page(browser, page, tmp_path / "shot.png", width=640, height=480)
    assert [i["width"] for i in seen["images"]] == [0, 0]
    assert any("boom" in e for e in seen["errors"]) and any("not_defined" in e for e in seen["errors"])
    assert any("missing.png" in e for e in seen["errors"])
    assert (tmp_path / "shot.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.fixture
def kept_figures(monkeypatch):
    """Figures the plotting code closes, kept open for the test to read (and closed after it)."""
    import matplotlib.pyplot as plt

    close = plt.close
    kept = []
    monkeypatch.setattr(plt, "close", lambda fig=None: kept.append(fig))
    yield kept
    for fig in kept:
        close(fig)
