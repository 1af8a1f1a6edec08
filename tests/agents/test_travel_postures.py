"""scripts/studies/travel_postures.py: the postures a planner's plans share, greedily by how many plans pass near
them."""

import importlib.util
import json
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "studies" / "travel_postures.py"
spec = importlib.util.spec_from_file_location("travel_postures", SCRIPT)
travel_postures = importlib.util.module_from_spec(spec)
spec.loader.exec_module(travel_postures)


def test_the_posture_most_plans_pass_near_comes_first_and_its_plans_are_then_set_aside():
    tuck, side, lone = np.radians([-90, -50, -100, 50, 10, 220]), np.radians([50, -20, 0, 120, -40, 180]), np.zeros(6)
    rng = np.random.default_rng(0)
    jitter = lambda: np.radians(rng.uniform(-5, 5, 6))
    candidates = [(f"plan{k}", tuck + jitter()) for k in range(4)]  # four plans pass near the tuck
    candidates += [("plan0", side + jitter()), ("plan4", side + jitter()), ("plan5", side + jitter())]
    candidates += [("plan6", lone)]  # one plan alone: no shared posture
    chosen = travel_postures.shared_postures(candidates, count=5, radius=np.radians(20), min_plans=2)
    assert [plans for _, plans in chosen] == [4, 2]  # plan0 already counted for the tuck
    assert np.max(np.abs(chosen[0][0] - tuck)) < np.radians(5)
    assert np.max(np.abs(chosen[1][0] - side)) < np.radians(5)
    assert len(travel_postures.shared_postures(candidates, count=1, radius=np.radians(20), min_plans=2)) == 1


def test_vias_are_read_from_an_evaluation_folder_without_starts_stops_or_ends(tmp_path, capsys):
    (tmp_path / "trajectories").mkdir()
    wps = np.radians([[0, -20, 10, 180, -60, 180], [-90, -50, -100, 50, 10, 220], [40, 30, 0, 150, -80, 170],
                      [-90, -50, -100, 50, 10, 220], [0, -20, 10, 180, -60, 180]])
    rows = []
    for k in range(2):
        np.savez(tmp_path / "trajectories" / f"ompl-wear__drawn_{k}__0.npz", waypoints=wps, stops=np.array([2]))
        rows.append({"key": f"ompl-wear|drawn_{k}|0", "method": "ompl-wear", "task": f"drawn_{k}", "seed": 0,
                     "success": True})
    rows.append({"key": "ompl|drawn_0|0", "method": "ompl", "task": "drawn_0", "seed": 0, "success": True})
    (tmp_path / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    vias = travel_postures.interior_waypoints(tmp_path, "ompl-wear")
    assert len(vias) == 4  # two per plan: the stop (the weld) and the ends are not vias
    travel_postures.main([str(tmp_path), "--count", "3"])
    out = capsys.readouterr().out
    assert "via_postures_deg:" in out and out.count("  - [") == 1 and "-90.0, -50.0, -100.0" in out
