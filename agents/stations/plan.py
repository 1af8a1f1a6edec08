"""A planned station (StationPlan: task, chosen options, coordinated schedule, checks, bounds) and its files."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from dresspack_gym.multi.replay import StationReplay
from dresspack_gym.multi.schedule import StationSchedule
from dresspack_gym.multi.tasks import StationTask, WeldOption

from .config import StationPlanConfig
from .solver import Assignment


@dataclass
class StationPlan:
    """A planned station: the task, the chosen options per robot, the coordinated schedule, its checks."""

    task: StationTask
    names: list[str]  # robot names, by index
    options: list[WeldOption]  # node k -> option (nodes 0..R-1 are the Homes: None)
    assignment: Assignment
    schedule: StationSchedule
    coordination: dict
    verification: dict
    bound: dict
    config: StationPlanConfig
    replay: StationReplay | None = None
    info: dict | None = None
    # the wear objective: the least wear estimate any routes over these options could have within its makespan
    # cap (solver.wear_relaxation_bound on straight-move times)
    wear_bound: dict | None = None

    def robot_welds(self) -> dict[str, list[str]]:
        names = self.names
        return {names[s.robot]: list(s.welds) for s in self.schedule.robots}

    def summary(self) -> dict:
        s = {
            "objective": self.config.objective,
            "makespan": round(self.schedule.makespan, 3),
            "makespan_lower_bound": round(self.bound["bound"], 3),
            "gap_to_bound": round(self.schedule.makespan / self.bound["bound"] - 1.0, 4),
            "lower_bounds": {k: round(v, 3) if isinstance(v, float) else v for k, v in self.bound.items()},
            "total_wait": round(self.schedule.total_wait(), 3),
            "estimate": self.assignment.estimate,
            "coordination": self.coordination,
            "verification": self.verification,
            "welds": self.robot_welds(),
            "robot_end_times": {self.names[s.robot]: round(s.end_time, 3) for s in self.schedule.robots},
            "info": self.info or {},
        }
        if self.wear_bound is not None:
            s["wear_estimate_bound"] = {k: round(v, 3) if isinstance(v, float) else v
                                        for k, v in self.wear_bound.items()}
        if self.replay is not None:
            s["replay"] = self.replay.summary(self.names)
            split = self.replay.wear_split(self.schedule)
            s["replay"]["wear_split"] = {self.names[i]: v for i, v in split.items()}
        return s


def save_plan(plan: StationPlan, out: Path) -> None:
    """plan.json (summary, per-robot timing) and one trajectory .npz per robot under ``out``."""
    from dresspack_gym.physics.trajectory import save_trajectory

    out.mkdir(parents=True, exist_ok=True)
    robots = {}
    for s in plan.schedule.robots:
        name = plan.names[s.robot]
        # the .npz holds the waypoints (a single-robot trajectory, stopping at each: what `dresspack export` writes);
        # which legs fly by their via points is in its meta and plan.json
        save_trajectory(out / f"{name}.npz", s.trajectory(), robot=s.robot, robot_name=name,
                        leg_start=s.leg_start.tolist(), weld_time=s.weld_time, fly_by=list(s.fly_by))
        robots[name] = {"welds": list(s.welds), "leg_start": s.leg_start.round(4).tolist(), "fly_by": list(s.fly_by),
                        "waits": s.waits().round(4).tolist(), "end_time": round(s.end_time, 4),
                        "trajectory": f"{name}.npz"}
    data = {"summary": plan.summary(), "robots": robots, "config": asdict(plan.config)}
    (out / "plan.json").write_text(json.dumps(data, indent=1, default=_json_default))


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x)}")
