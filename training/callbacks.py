"""Training callbacks: per-episode task and wear metrics for TensorBoard, and a tqdm progress bar."""

from __future__ import annotations

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from tqdm.auto import tqdm


class EpisodeMetricsCallback(BaseCallback):
    """Logs, per finished episode (averaged over the episodes of each rollout), under ``episode/``:
    success, goals reached, cycle time, the episode's max curvature / tension / twist rate / total twist /
    clamp torque, min clearance, the smoothness of its path (reversals per second, peak joint acceleration, as the
    evaluation measures it) and the time-integrated cost terms (eq. 4.10) — the numbers the evaluation reports,
    seen while training."""

    MAX_KEYS = ("max_curvature", "max_tension", "max_twist_rate", "total_twist", "max_node_torque", "cost")
    COST_KEYS = ("cost", "cost_curvature", "cost_tension", "cost_distance", "cost_twist", "cost_damage")

    def _on_training_start(self) -> None:
        self._acc = [self._fresh() for _ in range(self.training_env.num_envs)]

    @staticmethod
    def _fresh() -> dict:
        return {"max_curvature": 0.0, "max_tension": 0.0, "max_twist_rate": 0.0, "total_twist": 0.0,
                "max_node_torque": 0.0, "cost": 0.0,
                "min_clearance": np.inf, "integral": dict.fromkeys(EpisodeMetricsCallback.COST_KEYS, 0.0)}

    def _on_step(self) -> bool:
        for i, (info, done) in enumerate(zip(self.locals["infos"], self.locals["dones"])):
            acc = self._acc[i]
            for k in self.MAX_KEYS:
                acc[k] = max(acc[k], float(info[k]))
            acc["min_clearance"] = min(acc["min_clearance"], float(info["min_clearance"]))
            for k in self.COST_KEYS:  # the env's integral over the step (sampled along the motion with wear_integral)
                acc["integral"][k] += float(info[f"integral_{k}"])
            if done:
                log = self.logger.record_mean
                log("episode/success", float(info["is_success"]))
                log("episode/goals_reached_fraction", float(info["progress"]))
                log("episode/cycle_time", float(info["cycle_time"]))
                log("episode/invalid_actions", float(info.get("invalid_action", False)))
                for k in ("max_curvature", "max_tension", "max_twist_rate", "total_twist", "max_node_torque",
                          "min_clearance"):
                    log(f"episode/{k}", acc[k])
                log("episode/max_cost", acc["cost"])
                log("episode/damage", float(info["damage"]))  # the worst segment's, over the episode
                if "life_cycles" in info:  # fatigue life of the episode as a station cycle (log10: spans decades)
                    log("episode/log10_life_cycles", float(np.log10(max(info["life_cycles"], 1e-12))))
                for k in ("reversals_per_s", "peak_joint_acceleration"):  # smoothness of the episode's path
                    if k in info:
                        log(f"episode/{k}", float(info[k]))
                for k, v in acc["integral"].items():
                    log(f"episode/integrated_{k}", v)
                self._acc[i] = self._fresh()
        return True


class ProgressBarCallback(BaseCallback):
    """A tqdm bar over the run's total environment steps (continues from the step count on resume)."""

    def __init__(self, total_timesteps: int):
        super().__init__()
        self.total = int(total_timesteps)
        self.bar = None
        self._successes: list[float] = []

    def _on_training_start(self) -> None:
        self.bar = tqdm(total=self.total, initial=self.model.num_timesteps, unit="step", desc="training",
                        dynamic_ncols=True, smoothing=0.05)

    def _on_step(self) -> bool:
        self.bar.update(self.training_env.num_envs)
        for info, done in zip(self.locals["infos"], self.locals["dones"]):
            if done:
                self._successes = (self._successes + [float(info["is_success"])])[-50:]
        if self._successes and self.n_calls % 20 == 0:
            self.bar.set_postfix(success=f"{np.mean(self._successes):.0%}", refresh=False)
        return True

    def _on_training_end(self) -> None:
        if self.bar is not None:
            self.bar.close()
