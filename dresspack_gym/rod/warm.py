"""Compile every kernel of the rod engine (and the robot collision checks') once into numba's disk cache:
``python -m dresspack_gym.rod.warm``.

The setup script runs it, so that the first simulation, and the test workers, load compiled code instead of each
compiling it (about a minute on 2 cores). Caches compiled from other sources of the engine are cleared first."""

from __future__ import annotations

import hashlib
import time
from pathlib import Path

import numpy as np

ROD = Path(__file__).resolve().parent
# The sources the caches were compiled from: numba keys a cached kernel on its own file's time stamp only, so a kernel
# whose callee in another file changed would load stale code; a change anywhere in the engine clears every cache.
STAMP = ROD / "__pycache__" / "rod_sources.sha256"


def sources_digest(root: Path = ROD) -> str:
    """SHA-256 over the source files under ``root`` (paths and contents)."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def clear_stale_caches(root: Path = ROD) -> bool:
    """Delete every numba cache file under ``root`` when its sources differ from those the caches were compiled
    from (the digest kept in ``root/__pycache__``); whether it did."""
    stamp = root / STAMP.relative_to(ROD)
    digest = sources_digest(root)
    if stamp.exists() and stamp.read_text() == digest:
        return False
    for cached in list(root.rglob("*.nbi")) + list(root.rglob("*.nbc")):
        cached.unlink(missing_ok=True)
    stamp.parent.mkdir(exist_ok=True)
    stamp.write_text(digest)
    return True


def compile_all() -> float:
    """Run every kernel once on small inputs (compiling it or loading it from the cache); the seconds it took."""
    from ..io.loading import load_station
    from ..physics.trajectory import Trajectory, replay
    from ..stations.station import Station
    from ..stations.validity import MotionValidity
    from .contact.warm import compile_kernels
    from .simulator import RodSimulator

    start = time.perf_counter()
    clear_stale_caches()
    compile_kernels()
    station = Station(load_station("default"))
    sim = RodSimulator(station)  # a rest solve with contact, the measures
    home = station.home[0]
    via = home + np.radians([10.0, 5.0, -5.0, 20.0, 10.0, -20.0])
    replay(sim, Trajectory(np.stack([home, via, home]), stops=(2,)))  # motion steps, segment states, damage
    sim.hold(0.1)
    # the robot collision checks' kernels (stations/clearance_kernels.py), which every planner and mask calls
    validity = MotionValidity(station, 0)
    validity.segment_valid(home, via)
    validity.checker.min_distances(np.stack([home, via]))
    validity.checker.collides(via)
    _called_from_python(sim)
    return time.perf_counter() - start


def _called_from_python(sim) -> None:
    """The kernels Python calls directly outside a replay (a rod's static forces, a link closing in on the cable,
    the benchmark adapter's reference twists) and the elastic pieces the tests check one by one: each is cached on
    its own, so a test worker would otherwise compile it."""
    from . import elastic
    from .band import band_matvec
    from .frames import reference_twists, unit_tangents
    from .station_scene import closing_fraction

    rod, scene = sim.rods[0], sim.scenes[0]
    rod.forget_forces()
    rod.static_forces()
    now = scene.at(sim.q)
    moved = scene.at(sim.q + np.radians(5.0))
    closing_fraction(rod.x, rod.radius, now, moved, np.ones(len(now.kind)))
    reference_twists(rod.ref, unit_tangents(rod.x)[0])
    band_matvec(np.ones((3, 6)), np.ones(6))
    e, f = np.array([1.0, 0.0, 0.0]), np.array([0.8, 0.6, 0.0])
    elastic.stretch_edge(e, 1.0, 1.0, True)
    elastic.bend_vertex(e, f, 1.0, True)
    elastic.twist_vertex(e, f)
    elastic.curvature_binormal(e, f)
    elastic.curvature_binormal_jacobian(e, f)
    elastic.edges_to_vertices_grad(np.ones(6))
    elastic.edges_to_vertices_hess(np.ones((6, 6)))
    elastic.vertex_block(np.ones((6, 6)), 0, 1, 0, 1)


if __name__ == "__main__":
    print(f"the rod engine's kernels are compiled ({compile_all():.0f} s)")
