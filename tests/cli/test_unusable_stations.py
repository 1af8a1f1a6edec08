"""Stations that load but cannot be used are said to be so: a robot that reaches none of its welds is refused
naming its base, and a cable that does not settle at Home makes `dresspack inspect` say the station cannot be
used (exit code 1), with the residual and the stiffnesses."""

from __future__ import annotations

import json

import pytest
from helpers import default_station_dict

from dresspack_gym import ConfigError
from dresspack_gym.cli.main import main
from dresspack_gym.io.loading import station_from_dict


def test_a_base_in_millimetres_read_as_metres_is_refused_naming_it():
    d = default_station_dict()
    d["robots"][0]["base_pos"] = [500.0, 0.0, 0.0]
    with pytest.raises(ConfigError) as err:
        station_from_dict(d)
    assert err.value.field == "robots[0].base_pos"
    assert "reaches none of its 5 weld point(s)" in str(err.value) and "millimetres given as metres" in str(err.value)


def test_one_weld_out_of_reach_still_loads():
    d = default_station_dict()
    d["weld_points"].append({"name": "far", "pos": [40.0, 0.0, 1.0], "approach": [1, 0, 0]})
    assert len(station_from_dict(d).weld_points) == 6


def test_a_cable_that_does_not_settle_at_home_makes_the_station_unusable(tmp_path, capsys, monkeypatch):
    import yaml

    monkeypatch.chdir(tmp_path)  # MuJoCo logs its warnings about the stiff cable to MUJOCO_LOG.TXT here
    d = default_station_dict()
    d["robots"][0]["dresspack_overrides"] = {"bending_stiffness": 1e4}  # the largest a dresspack may state
    (tmp_path / "stiff.yaml").write_text(yaml.safe_dump(d))
    assert main(["inspect", "--station", str(tmp_path / "stiff.yaml")], extensions=[]) == 1
    out = capsys.readouterr().out
    assert "THE STATION CANNOT BE USED: the cable does not settle at Home" in out and "EI=10000 N m^2" in out
    assert main(["inspect", "--station", str(tmp_path / "stiff.yaml"), "--json"], extensions=[]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["usable"] is False and report["equilibrium"]["force_residual"] > 1.0
    assert main(["inspect", "--station", "default", "--json"], extensions=[]) == 0
    assert json.loads(capsys.readouterr().out)["usable"] is True
