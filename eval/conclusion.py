"""The report's opening answer from the rows: one verdict, the best on the station's objective W·T + ∫C dt, with the
fatigue life of every method beside it and, where the longest-lived cable is another method's, the segment and the
strain that shorten the chosen one's; by how much, and where each method fails."""

from __future__ import annotations

import math

import numpy as np

from .summary import significant

WEAR_UNAWARE = "ompl"  # the baseline every ratio is also given against: plans for time alone


def objective_name(time_weight: float) -> str:
    return "T + ∫C dt" if time_weight == 1 else f"{time_weight:g}·T + ∫C dt"


def conclude(rows: list[dict], methods, time_weight: float = 1.0) -> dict:
    """``{"bullets": [sentence, ...], "table": {"header", "rows"}}``.

    A method's score is its mean over the tasks that every ranked method solved (a method ranks if it solved at
    least half of the tasks, so that a floor that finishes one easy task does not shrink everyone's comparison to
    it; on a task the score is the mean over its successful seeds), so every method is scored on the same tasks.
    Life is the geometric mean of each run's shortest segment life over the same tasks (lives span decades)."""
    methods = list(methods)
    tasks = list(dict.fromkeys(r["task"] for r in rows))
    objective = _per_task(rows, methods, tasks, lambda r: _objective(r, time_weight), np.mean)
    ranked = [m for m in methods if objective[m] and 2 * len(objective[m]) >= len(tasks)]
    common = [t for t in tasks if all(t in objective[m] for m in ranked)]
    name = objective_name(time_weight)
    bullets = []
    if not any(objective.values()):
        bullets.append("No method completed any run: nothing to rank.")
    elif not ranked:
        bullets.append(f"No method solved half of the {len(tasks)} tasks: no like-for-like ranking on {name}; see "
                       "the per-task tables.")
    elif not common:
        bullets.append(f"No task was solved by every method that solved one ({', '.join(ranked)}): no "
                       f"like-for-like ranking on {name}; see the per-task tables.")
    else:
        score = {m: float(np.mean([objective[m][t] for t in common])) for m in ranked}
        who = "it" if len(ranked) == 1 else "every ranked method"
        over = (f"mean over the {len(common)} tasks {who} solved" if len(common) > 1
                else f"on {common[0]}, the one task {who} solved")
        alone = "the only method evaluated" if len(methods) == 1 else "the only method that solved a task"
        bullets.append(_ranking(f"{name} (lower is better)", score, lower_better=True, over=over, unit="",
                                alone=alone))
        life = _per_task(rows, ranked, common, lambda r: r.get("life_cycles"), _geometric_mean)
        if all(len(life[m]) == len(common) for m in ranked):
            lives = {m: _geometric_mean([life[m][t] for t in common]) for m in ranked}
            bullets.append(_life_beside(rows, sorted(ranked, key=score.get), common, lives))
            bullets.append(_verdict(rows, score, lives, common, name))
        unsolved = [m for m in methods if not objective[m]]
        few = [f"{m} ({len(objective[m])} of {len(tasks)})" for m in methods if m not in ranked and objective[m]]
        if few:
            bullets.append(f"Not ranked, having solved fewer than half the tasks: {', '.join(few)}.")
        if unsolved:
            bullets.append(f"Not ranked, having solved no task: {', '.join(unsolved)}.")
    bullets += [_failures(rows, m) for m in methods]
    return {"bullets": bullets, "table": _table(rows, ranked, common, time_weight)}


# what the strain that fails a segment does to the cable there, as a sentence's clause (fatigue.FatigueLife causes)
CAUSES = {"bending": ("it is bent back and forth", "bending"), "stretch": ("it is pulled and released", "axial"),
          "twist": ("it is twisted back and forth", "shear")}


def _spread(values) -> float:
    """The geometric standard deviation (a factor >= 1): lives span decades, so their spread is a factor."""
    return float(np.exp(np.std(np.log(np.maximum(values, 1e-300)))))


def _run_lives(rows, method, common) -> list[dict]:
    return [r for r in rows if r["method"] == method and r["task"] in common and r["success"]
            and r.get("life_cycles") is not None]


def _life_beside(rows, order, common, lives) -> str:
    """Every ranked method's fatigue life in the objective's order, with its spread over the method's runs."""
    parts = []
    for m in order:
        runs = [r["life_cycles"] for r in _run_lives(rows, m, common)]
        spread = f"×/÷ {_spread(runs):.2f}" if len(runs) > 1 else "one run"
        parts.append(f"{m} {significant(lives[m], 3)} cycles ({spread})")
    return ("Fatigue life beside it (station cycles to the first conductor failure, geometric mean over the same "
            "tasks, ×/÷ its spread over the runs; higher is better): " + ", ".join(parts) + ".")


def _verdict(rows, score, lives, common, name) -> str:
    """The one answer: the best on the objective; where another method's cable lives longer, which segment of the
    chosen method's cable fails first and by what strain, and how to plan for life instead."""
    best, longest = min(score, key=score.get), max(lives, key=lives.get)
    if best == longest or lives[longest] <= lives[best]:
        return (f"The answer is {best}: the lowest {name}, the station's objective, and its cable also lives "
                f"longest ({significant(lives[best], 3)} cycles).")
    weakest = min(_run_lives(rows, best, common), key=lambda r: r["life_cycles"])
    where = (f"at {weakest['weakest_segment_m']:.2f} m along the cable"
             if weakest.get("weakest_segment_m") is not None else "at one segment")
    cause = CAUSES.get(weakest.get("weakest_cause") or "")
    why = (f", where {cause[0]} ({cause[1]} strain amplitude {100 * weakest['weakest_strain_amplitude']:.2g} %)"
           if cause and weakest.get("weakest_strain_amplitude") is not None else "")
    return (f"The answer is {best}, the lowest {name}, the station's objective; but {longest}'s cable lives "
            f"{lives[longest] / lives[best]:.1f}× as long ({significant(lives[longest], 3)} cycles against "
            f"{significant(lives[best], 3)}): {best}'s cable fails first {where}{why}, which {name} does not count "
            f"as fatigue. To plan for cable life instead, plan with --cost-variant life.")


def _objective(row: dict, time_weight: float) -> float | None:
    if row.get("cycle_time") is None or row.get("cost") is None:
        return None
    return time_weight * row["cycle_time"] + row["cost"]


def _per_task(rows, methods, tasks, value, reduce) -> dict[str, dict[str, float]]:
    """Per method, per task it solved: ``reduce`` of ``value`` over its successful seeds."""
    out = {}
    for m in methods:
        out[m] = {}
        for t in tasks:
            values = [value(r) for r in rows if r["method"] == m and r["task"] == t and r["success"]]
            values = [v for v in values if v is not None]
            if values:
                out[m][t] = float(reduce(values))
    return out


def _geometric_mean(values) -> float:
    return float(np.exp(np.mean(np.log(np.maximum(values, 1e-300)))))


def _ranking(what: str, score: dict[str, float], *, lower_better: bool, over: str, unit: str, alone: str) -> str:
    """One sentence: the best method, its score, and by what factor (>= 1) it beats the runner-up and the
    wear-unaware baseline: the other's score over the best's when lower is better, the inverse when higher is."""
    order = sorted(score, key=score.get, reverse=not lower_better)
    best = order[0]
    if len(order) == 1:
        return f"{what[0].upper()}{what[1:]}: {best}, {significant(score[best], 3)}{unit} ({over}); {alone}."
    text = f"Best on {what}: {best}, {significant(score[best], 3)}{unit} ({over})"

    def against(other: str, role: str) -> str:
        a, b = score[best], score[other]
        ratio = b / a if lower_better else a / b
        factor = f"{ratio:.2f}×" if math.isfinite(ratio) and ratio > 0 else "an undefined factor"
        if lower_better:
            return f"{role} {other} {significant(b, 3)}{unit} ({factor} as much)"
        return f"{factor} the {role} {other}'s {significant(b, 3)}{unit}"

    runner_up = order[1]
    if runner_up == WEAR_UNAWARE:
        text += "; " + against(runner_up, "runner-up and wear-unaware")
    else:
        text += "; " + against(runner_up, "runner-up")
        if best == WEAR_UNAWARE:
            text += f"; {WEAR_UNAWARE} is itself the wear-unaware baseline"
        elif WEAR_UNAWARE in score:
            text += "; " + against(WEAR_UNAWARE, "wear-unaware")
    return text + "."


def _failures(rows: list[dict], method: str) -> str:
    mine = [r for r in rows if r["method"] == method]
    ok = sum(r["success"] for r in mine)
    text = f"{method}: {ok}/{len(mine)} runs succeeded ({ok / len(mine):.0%})" if mine else f"{method}: no runs"
    failed = []
    for t in dict.fromkeys(r["task"] for r in mine):
        runs = [r for r in mine if r["task"] == t]
        bad = sum(not r["success"] for r in runs)
        if bad:
            failed.append(f"{t} ({bad}/{len(runs)} seeds)" if len(runs) > 1 else t)
    return text + (f"; failed on {', '.join(failed)}." if failed else "; no failure.")


def _table(rows, ranked, common, time_weight) -> dict:
    """The ranked methods, best first, with the per-task means the answer rests on."""
    header = ["method", f"{objective_name(time_weight)} (lower is better)", "cycle time T [s]", "∫C dt",
              "life [cycles] ×/÷ spread (higher is better)", "tasks compared"]
    if not ranked or not common:
        return {"header": header, "rows": []}

    def mean(key, reduce=np.mean):
        per = _per_task(rows, ranked, common, key, reduce)
        return {m: (float(reduce([per[m][t] for t in common])) if len(per[m]) == len(common) else None)
                for m in ranked}

    objective = mean(lambda r: _objective(r, time_weight))
    cycle, cost = mean(lambda r: r.get("cycle_time")), mean(lambda r: r.get("cost"))
    life = mean(lambda r: r.get("life_cycles"), _geometric_mean)

    def life_cell(m):
        runs = [r["life_cycles"] for r in _run_lives(rows, m, common)]
        return significant(life[m], 3) + (f" ×/÷ {_spread(runs):.2f}" if len(runs) > 1 else "")

    body = [[m, *(significant(v[m], 3) if v[m] is not None else "–" for v in (objective, cycle, cost)),
             life_cell(m) if life[m] is not None else "–", str(len(common))] for m in sorted(ranked, key=objective.get)]
    return {"header": header, "rows": body}
