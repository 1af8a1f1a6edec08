"""A robustness map switched on from the station YAML removes non-robust weld configurations."""

import csv
import json

import numpy as np
import pytest
import yaml
from helpers import default_station_dict

from dresspack_gym import ConfigError
from dresspack_gym.env.dresspack_env import DresspackEnv
from dresspack_gym.maps.robustness.grid import RobustnessGrid
from dresspack_gym.maps.robustness.query import RobustnessMap, configuration_vector
from dresspack_gym.maps.robustness.store import COLUMNS, grid_to_meta
from dresspack_gym.stations.tasks import allowed_weld_configurations

STEP30 = {"start": -180, "stop": 150, "step": 30}


def write_map(folder, grid, non_robust_v, threshold=0.1):
    """A map folder whose only measured rows are the grid cells nearest to ``non_robust_v`` (deviation 0.5 m)."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "meta.json").write_text(json.dumps({"settings": {"threshold": threshold},
                                                  "grid_axes": grid_to_meta(grid)}))
    with open(folder / "results.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(COLUMNS)
        for i in sorted(set(grid.nearest_index(np.atleast_2d(non_robust_v)).tolist())):
            v = np.degrees(grid.configurations()[i])
            w.writerow([i, *v, 0.5, 0.5, 0.5, 1, 0.0, 1.0, 0])  # converged, dynamic ratio, speed, robust
    return folder


def station_file(tmp_path, map_ref):
    data = default_station_dict()
    data["robots"][0]["robustness_map"] = map_ref
    path = tmp_path / "station.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def test_configuration_vector_is_link3_pitch_and_wrist():
    q = np.radians([[10, 100, 120, 1, 2, 3], [0, -30, 20, 0, 0, 0]])
    v = np.degrees(configuration_vector(q))
    assert v[0].tolist() == pytest.approx([-140, 1, 2, 3])  # 220 deg pitch wraps to -140
    assert v[1].tolist() == pytest.approx([-10, 0, 0, 0])


def test_map_on_station_changes_the_weld_goal_to_a_robust_configuration(tmp_path):
    plain = DresspackEnv(station="default")
    weld = next(iter(plain.weld_goals))
    q_goal = plain.weld_goals[weld]
    grid = RobustnessGrid.from_dict({"name": "g30", "ry": STEP30, "j4": STEP30, "j5": STEP30, "j6": STEP30})
    folder = write_map(tmp_path / "map", grid, configuration_vector(q_goal))
    rmap = RobustnessMap(folder)
    assert rmap.n_measured == 1 and not rmap.robust_joints(q_goal)[0]

    env = DresspackEnv(station=station_file(tmp_path, "map"))  # relative to the station YAML
    q_new = env.weld_goals[weld]
    assert not np.allclose(q_new, q_goal)
    assert rmap.robust_joints(q_new)[0]
    allowed = allowed_weld_configurations(env.station, 0, weld)
    assert rmap.robust_joints(allowed).all() and len(allowed) < len(allowed_weld_configurations(plain.station, 0, weld))
    for other in plain.weld_goals:  # goals whose cells were not measured non-robust stay as they were
        if other != weld and rmap.robust_joints(plain.weld_goals[other])[0]:
            assert np.allclose(env.weld_goals[other], plain.weld_goals[other])


def test_a_map_that_rejects_everything_is_a_clear_error(tmp_path):
    one_cell = RobustnessGrid.from_dict({"name": "one", **{k: {"start": 0, "stop": 0, "step": 1}
                                                           for k in ("ry", "j4", "j5", "j6")}})
    write_map(tmp_path / "map", one_cell, np.zeros(4))
    with pytest.raises(ConfigError, match="robustness map") as exc:
        DresspackEnv(station=station_file(tmp_path, {"path": "map", "threshold": 0.2}))
    assert exc.value.field.startswith("weld_points.")


def test_missing_map_folder_names_the_field(tmp_path):
    with pytest.raises(ConfigError, match="not a robustness map folder") as exc:
        DresspackEnv(station=station_file(tmp_path, "nowhere"))
    assert exc.value.field == "robots[0].robustness_map"
    with pytest.raises(ConfigError) as exc:
        DresspackEnv(station=station_file(tmp_path, 3))
    assert exc.value.field == "robots[0].robustness_map"
