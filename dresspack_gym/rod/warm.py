"""Compile every kernel of the rod engine once into numba's disk cache: ``python -m dresspack_gym.rod.warm``.

The setup script runs it, so that the first simulation, and the test workers, load compiled code instead of each
compiling it (about a minute on 2 cores)."""

from __future__ import annotations

import time

import numpy as np


def compile_all() -> float:
    """Run every kernel once on small inputs (compiling it or loading it from the cache); the seconds it took."""
    from ..io.loading import load_station
    from ..physics.trajectory import Trajectory, replay
    from ..stations.station import Station
    from .contact.warm import compile_kernels
    from .simulator import RodSimulator

    start = time.perf_counter()
    compile_kernels()
    station = Station(load_station("default"))
    sim = RodSimulator(station)  # a rest solve with contact, the measures
    home = station.home[0]
    via = home + np.radians([10.0, 5.0, -5.0, 20.0, 10.0, -20.0])
    replay(sim, Trajectory(np.stack([home, via, home]), stops=(2,)))  # motion steps, segment states, damage
    sim.hold(0.1)
    return time.perf_counter() - start


if __name__ == "__main__":
    print(f"the rod engine's kernels are compiled ({compile_all():.0f} s)")
