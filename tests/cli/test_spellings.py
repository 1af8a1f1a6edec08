"""One vocabulary on every command line: --station, --planner(s), --welds; the old spellings (a positional station,
--methods, --tasks, the dresspack-eval and dresspack-train executables) still work for one release with one
deprecation line on stderr, and a value given by an old and a new spelling at once is refused."""

from __future__ import annotations

import argparse
import json

import pytest

from dresspack_gym.cli.args import DeprecatedPositional, Renamed
from dresspack_gym.cli.main import build_parser, main

PARSER = build_parser()
SUB = next(a for a in PARSER._actions if isinstance(a, argparse._SubParsersAction))
# what each command needs beside its station to parse
NEEDS = {"render": ["--out", "x.png"]}
STATION_LINE = "dresspack: the positional station is deprecated; use --station NAME"


def _parse(argv, capsys):
    """(namespace, stderr lines) of parsing ``argv`` with the full `dresspack` parser."""
    args = build_parser().parse_args(argv)
    return args, capsys.readouterr().err.splitlines()


def _with_positional_station() -> list[str]:
    return sorted(name for name, p in SUB.choices.items()
                  if any(isinstance(a, DeprecatedPositional) for a in p._actions))


def test_the_commands_that_took_a_positional_station_keep_it_deprecated():
    assert _with_positional_station() == ["inspect", "plan", "render", "restrictions", "station-plan",
                                          "twist-sweep", "wear-map"]


def test_every_station_is_given_by_the_station_flag():
    """Whatever the subcommand, its station is --station (and no other positional carries one)."""
    taking = []
    for name, p in SUB.choices.items():
        stations = [a for a in p._actions if a.dest == "station"]
        if not stations:
            continue
        taking.append(name)
        flags = [a for a in stations if a.option_strings]
        assert len(flags) == 1 and flags[0].option_strings == ["--station"], name
        assert all(isinstance(a, DeprecatedPositional) for a in stations if not a.option_strings), name
    assert {"inspect", "plan", "eval", "demo", "bench", "export", "robustness-map", "station-plan"} <= set(taking)


@pytest.mark.parametrize("command", _with_positional_station())
def test_a_positional_station_still_works_and_says_once_it_is_deprecated(command, capsys):
    old, err_old = _parse([command, "thesis_tension", *NEEDS.get(command, [])], capsys)
    new, err_new = _parse([command, *NEEDS.get(command, []), "--station", "thesis_tension"], capsys)
    assert old.station == new.station == "thesis_tension"
    assert err_old == [STATION_LINE] and err_new == []


@pytest.mark.parametrize("command", _with_positional_station())
def test_the_default_station_needs_no_argument(command, capsys):
    args, err = _parse([command, *NEEDS.get(command, [])], capsys)
    assert args.station == "default" and err == []


@pytest.mark.parametrize("argv", [["inspect", "default", "--station", "thesis_tension"],
                                  ["plan", "--station", "thesis_tension", "default"]])
def test_a_station_given_both_ways_is_refused_naming_the_flag(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert "argument --station: given both as" in err and "the positional STATION" in err
    assert err.splitlines()[-1].endswith("give --station only")


def test_a_station_given_both_ways_under_json_is_one_json_error(capsys):
    assert main(["inspect", "default", "--station", "default", "--json"]) == 2
    out = json.loads(capsys.readouterr().out)
    assert out["field"] == "--station" and "given both" in out["error"]


@pytest.mark.parametrize("command", ["eval", "demo"])
@pytest.mark.parametrize("old,new,dest,values", [
    ("--methods", "--planners", "planners", ["ompl", "ompl-wear"]),
    ("--tasks", "--welds", "welds", ["sill_rear,roof_rail_top", "floor_pan_inner"]),
])
def test_renamed_flags_still_work_and_say_once_they_are_deprecated(command, old, new, dest, values, capsys):
    args_old, err_old = _parse([command, old, *values], capsys)
    args_new, err_new = _parse([command, new, *values], capsys)
    assert getattr(args_old, dest) == getattr(args_new, dest) == values
    assert err_old == [f"dresspack: {old} is deprecated; use {new}"] and err_new == []


@pytest.mark.parametrize("argv,flag", [(["eval", "--planners", "ompl", "--methods", "random"], "--planners"),
                                       (["demo", "--tasks", "sill_rear", "--welds", "sill_front"], "--welds")])
def test_a_flag_given_by_two_spellings_is_refused(argv, flag, capsys):
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and f"argument {flag}: given both as" in err
    assert err.splitlines()[-1].endswith(f"give {flag} only")


def test_a_flag_repeated_in_its_own_spelling_is_not_a_conflict(capsys):
    args, err = _parse(["eval", "--planners", "ompl", "--planners", "random"], capsys)
    assert args.planners == ["random"] and err == []  # argparse's rule: the last one counts


def test_planners_are_checked_against_the_registry_naming_the_flag(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["eval", "--planners", "ompl", "astar"])
    err = capsys.readouterr().err
    assert "argument --planners" in err and "invalid choice: 'astar'" in err and "'ompl-wear'" in err


def test_every_deprecated_spelling_is_declared_by_the_shared_mechanism():
    """The deprecated spellings are the Renamed flags' extra option strings and the DeprecatedPositionals: no
    command declares an alias of its own."""
    aliases = {(name, o) for name, p in SUB.choices.items() for a in p._actions if isinstance(a, Renamed)
               for o in a.option_strings[1:]}
    assert aliases == {("eval", "--methods"), ("eval", "--tasks"), ("demo", "--methods"), ("demo", "--tasks"),
                       ("station-plan", "--leg-workers")}


def test_the_old_executables_say_once_they_are_deprecated_and_run_the_subcommand(tmp_path, capsys):
    """`dresspack-train X` is `dresspack train X` after one line on stderr (same exit code, same other output)."""
    pytest.importorskip("sb3_contrib")
    from dresspack.training.train import main as old_train

    assert main(["train", "no_such_config"]) == 2
    new = capsys.readouterr()
    assert old_train(["no_such_config"]) == 2
    old = capsys.readouterr()
    assert old.out == new.out and old.err.splitlines() == ["dresspack: dresspack-train is deprecated; use dresspack "
                                                           "train", *new.err.splitlines()]
    assert "no_such_config" in new.err


def test_the_old_eval_executable_is_dresspack_eval(tmp_path, capsys):
    pytest.importorskip("ompl")
    from dresspack.eval.compare import main as old_eval

    argv = ["--station-plans", str(tmp_path), "--out", str(tmp_path / "o")]  # no plan.json: refused at once
    assert main(["eval", *argv]) == 2
    new = capsys.readouterr()
    assert old_eval(argv) == 2
    old = capsys.readouterr()
    assert old.out == new.out and old.err.splitlines() == ["dresspack: dresspack-eval is deprecated; use dresspack "
                                                           "eval", *new.err.splitlines()]
    assert "plan.json" in new.err
