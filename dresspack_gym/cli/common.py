"""What the core subcommands share: a station loaded with its simulator, a robot index checked, the Ctrl-C exit code."""

from __future__ import annotations

from ..errors import ConfigError


def load_simulated(station_ref: str):
    """The station ``station_ref`` names and a MuJoCo cable simulator of it."""
    from ..io.loading import load_station
    from ..physics.simulation import CableSimulator
    from ..stations.station import Station

    station = Station(load_station(station_ref))
    return station, CableSimulator(station)


def robot_index(config, robot: int) -> int:
    if not 0 <= robot < len(config.robots):
        raise ConfigError("--robot", f"robot index {robot} does not exist: the station has {len(config.robots)} "
                                     f"robot(s) (0..{len(config.robots) - 1})")
    return robot


INTERRUPTED = 130  # the shell's exit status of a command ended by Ctrl-C (128 + SIGINT)
