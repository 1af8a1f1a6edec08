"""What the subcommands share: a station loaded with its simulator, a robot index checked, Ctrl-C's exit code and
its handling around a planner."""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

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


@contextmanager
def ctrl_c_remembered():
    """Ctrl-C raises KeyboardInterrupt as usual and is also remembered (``pressed()``): pressed while OMPL's C++
    planner is calling back into Python, the interrupt surfaces inside that callback, where the planner may swallow
    it as a failed check and go on, so the command also stops after the plan in progress."""
    if threading.current_thread() is not threading.main_thread():  # signals reach the main thread only
        yield lambda: False
        return
    pressed = []

    def on_ctrl_c(signum, frame):
        pressed.append(signum)
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, on_ctrl_c)
    try:
        yield lambda: bool(pressed)
    finally:
        signal.signal(signal.SIGINT, previous)
