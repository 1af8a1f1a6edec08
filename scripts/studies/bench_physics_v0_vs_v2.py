"""Per-step cost of physics v2 against the v0 cable model (flexcomp + connect constraints), in one run.

Checks out the last v0 commit into a temporary git worktree and times both models on the default
station, interleaved (best of 3 rounds x 5 repeats): raw mj_step with the cable at rest, and steps/s of
a quasi-static move (j1 + 90 deg, j4 + 57 deg) through CableSimulator.move_to. Usage, from the repository
root: .venv/bin/python scripts/studies/bench_physics_v0_vs_v2.py
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

V0_COMMIT = "9220c8c"  # the last commit before physics v2
CODE = r'''
import sys, time, json, mujoco, numpy as np
sys.path.insert(0, ".")
from dresspack_gym.io.loading import load_station
from dresspack_gym.stations.station import Station
from dresspack_gym.physics.simulation import CableSimulator
st = Station(load_station("default")); sim = CableSimulator(st)
q = st.home.copy(); q[0, 0] += np.pi / 2; q[0, 3] += 1.0
best = {}
for label, target in (("rest", None), ("moving", q)):
    rates = []
    for _ in range(5):
        sim.reset()
        t0 = time.perf_counter()
        if target is None:
            for _ in range(1000):
                mujoco.mj_step(st.model, sim.data)
            rates.append(1000 / (time.perf_counter() - t0))
        else:
            n0 = sim.data.time
            sim.move_to(target, settle=False)
            rates.append((sim.data.time - n0) / st.model.opt.timestep / (time.perf_counter() - t0))
    best[label] = max(rates)
print(json.dumps(best))
'''


def main() -> None:
    root = Path(__file__).resolve().parents[2]
    with tempfile.TemporaryDirectory() as tmp:
        v0 = Path(tmp) / "v0"
        subprocess.run(["git", "worktree", "add", "--detach", str(v0), V0_COMMIT], cwd=root, check=True,
                       capture_output=True)
        try:
            runs = {"v0": [], "v2": []}
            for _ in range(3):
                for name, cwd in (("v0", v0), ("v2", root)):
                    out = subprocess.run([sys.executable, "-c", CODE], cwd=cwd, capture_output=True, text=True,
                                         check=True)
                    runs[name].append(json.loads(out.stdout.strip().splitlines()[-1]))
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(v0)], cwd=root, capture_output=True)
    report = {}
    for key in ("rest", "moving"):
        a, b = max(r[key] for r in runs["v0"]), max(r[key] for r in runs["v2"])
        report[key] = {"v0_steps_per_s": round(a), "v2_steps_per_s": round(b),
                       "v2_cost_per_step_vs_v0": round(a / b, 3)}
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
