"""The held-out evaluation callback: keeps the best model by success or by mean reward, and its history across resumes."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
from sb3_contrib.common.maskable.callbacks import MaskableEvalCallback

from dresspack_gym.errors import ConfigError

from .config import BEST_BY


class HeldOutEvalCallback(MaskableEvalCallback):
    """MaskableEvalCallback with two changes a long run needs.

    * ``best_by``: the best model is the one with the highest mean evaluation reward (``reward``, SB3's rule) or the
      highest success rate, ties broken by mean reward (``success``). Reward alone can prefer a model that finishes
      fewer welds more cheaply; for a planner that must reach its goal, success comes first.
    * Resume keeps the history: the evaluations already in ``<log_path>.npz`` up to the step the run resumes from
      are loaded back, so the file keeps every evaluation and the best so far is beaten only by a better one (the
      stock callback restarts both, overwriting the earlier evaluations and the best model with the first new one).

    * ``eval_seed``: the evaluation env is reseeded before every evaluation, so every checkpoint is judged on the
      same episodes (the same drawn welds and starts). The stock callback continues the env's random stream, so each
      evaluation drew other welds and two checkpoints' success rates were not comparable.

    ``best/best.json`` records which evaluation the best model is (steps, success rate, mean reward, rule).
    """

    def __init__(self, *args, best_by: str = "reward", eval_seed: int | None = None, **kwargs):
        if best_by not in BEST_BY:
            raise ConfigError("best_by", f"{best_by!r} is not one of the allowed values {list(BEST_BY)}")
        self.best_by = best_by
        self.eval_seed = eval_seed
        self._best_path = kwargs.pop("best_model_save_path", None)
        super().__init__(*args, best_model_save_path=None, **kwargs)  # saving the best is done here, by best_by
        self._best_score: tuple[float, float] | None = None

    def _score(self, successes, mean_reward: float) -> tuple[float, float]:
        if self.best_by == "success":  # an env that reports no success counts as 0: reward alone decides
            return (float(np.mean(successes)) if len(successes) else 0.0, float(mean_reward))
        return (float(mean_reward), 0.0)

    def _init_callback(self) -> None:
        super()._init_callback()
        if self._best_path is not None:
            os.makedirs(self._best_path, exist_ok=True)
        self._restore_history(self.model.num_timesteps)

    def _restore_history(self, resumed_at: int) -> None:
        """Evaluations of this run up to ``resumed_at`` steps (later ones belong to a continuation that was
        abandoned when the run went back to its checkpoint); the best score among them."""
        path = Path(f"{self.log_path}.npz") if self.log_path is not None else None
        if resumed_at == 0 or path is None or not path.is_file():
            return
        data = np.load(path)
        keep = [i for i, t in enumerate(data["timesteps"]) if t <= resumed_at]
        self.evaluations_timesteps = [int(data["timesteps"][i]) for i in keep]
        self.evaluations_results = [list(data["results"][i]) for i in keep]
        self.evaluations_length = [list(data["ep_lengths"][i]) for i in keep]
        has_successes = "successes" in data and len(data["successes"]) == len(data["timesteps"])
        self.evaluations_successes = [list(data["successes"][i]) for i in keep] if has_successes else []
        for i, rewards in enumerate(self.evaluations_results):
            score = self._score(self.evaluations_successes[i] if has_successes else [], np.mean(rewards))
            if self._best_score is None or score > self._best_score:
                self._best_score = score

    def _on_step(self) -> bool:
        evaluating = self.eval_freq > 0 and self.n_calls % self.eval_freq == 0
        if evaluating and self.eval_seed is not None:
            self.eval_env.seed(self.eval_seed)  # used by the reset that starts the evaluation
        go_on = super()._on_step()
        if evaluating:
            score = self._score(self._is_success_buffer, self.last_mean_reward)
            if self._best_score is None or score > self._best_score:
                self._best_score = score
                if self._best_path is not None:
                    self.model.save(os.path.join(self._best_path, "best_model"))
                    success = float(np.mean(self._is_success_buffer)) if self._is_success_buffer else None
                    record = {"timesteps": int(self.num_timesteps), "best_by": self.best_by,
                              "success_rate": success, "mean_reward": float(self.last_mean_reward)}
                    Path(self._best_path, "best.json").write_text(json.dumps(record, indent=2) + "\n")
        return go_on
