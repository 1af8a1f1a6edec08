"""Small inline stations for tests: a parked robot and a cable held by world nodes (analytic cases)."""

from __future__ import annotations

import copy
import signal

import numpy as np

from dresspack_gym.io.loading import station_from_dict
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.stations.station import Station

THESIS_CABLE = {
    "name": "test_cable", "length": 1.74, "radius": 0.03, "linear_density": 1.25,
    "bending_stiffness": 0.1, "tensile_stiffness": 1400, "torsional_stiffness": 0.1,
    "segments": 24, "collide_with_robot": False,
}


def world_cable_station(nodes, *, cable=None, obstacles=(), gravity=9.81, floor=False, simulation=None):
    """A station whose only dresspack hangs from world nodes; the robot is parked far away."""
    dp = copy.deepcopy(THESIS_CABLE)
    dp.update(cable or {})
    dp["nodes"] = list(nodes)
    sim = {"gravity": gravity}
    sim.update(simulation or {})
    data = {
        "name": "test_station",
        "robots": [{"name": "r1", "robot": "abb_irb6700_200_260", "dresspack": dp,
                    "base_pos": [-20, -20, 0], "home_deg": [0, 0, 0, 0, 0, 0]}],
        "obstacles": list(obstacles),
        "floor": floor,
        "simulation": sim,
    }
    return Station(station_from_dict(data))


def settled(station: Station, seconds: float = 6.0) -> CableSimulator:
    sim = CableSimulator(station)
    sim.settle(seconds)
    return sim


def default_station_dict():
    from dresspack_gym.io.loading import read_yaml, resolve_station_path

    return read_yaml(resolve_station_path("default"))


# drawn_0 of `dresspack eval --drawn-tasks 30 --seeds 0` on the default station: a weld on the body's panel that no
# midpoint via leaves toward Home (docs/data/primitive_reach.json)
STUCK_WELD = np.array([0.7407122213013433, 1.0980702748831073, -0.7737209529340379, 3.4157926055470913,
                       -1.0514117569148649, 2.196833986149849])


NEAR_SIDE = ("r1_sill_1", "r1_b_pillar_1", "r2_b_pillar_1", "r2_sill_1")


def near_side_yaml(tmp_path, welds=NEAR_SIDE, extra=()):
    """The near side of the shipped side-framing station as a YAML file: robots r1 and r2, four of their welds (and
    any ``extra`` weld points)."""
    import yaml

    from dresspack_gym.shipped import find_shipped

    data = yaml.safe_load(find_shipped("side_framing_4r", "stations", "station").read_text())
    data["name"] = "near_side_2r"
    data["robots"] = data["robots"][:2]
    data["weld_points"] = [w for w in data["weld_points"] if w["name"] in welds] + list(extra)
    path = tmp_path / "near_side_2r.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def station_with_weld_csv(tmp_path, data: bytes):
    """The default station with its weld points read from a CSV file of these bytes (millimetres)."""
    from dresspack_gym.io.loading import station_from_dict

    (tmp_path / "welds.csv").write_bytes(data)
    d = default_station_dict()
    d["weld_points"] = []
    d["weld_points_csv"] = {"path": str(tmp_path / "welds.csv"), "units": "mm"}
    return station_from_dict(d)


def as_a_shell_starts_it() -> None:
    """``preexec_fn`` of a command a test interrupts: it starts with Ctrl-C at its default, as a shell starts it, so
    the test process's own disposition (a test before may have left SIGINT ignored in this worker) never reaches it."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
