"""A learned cost: an MLP from (observation, action) to the step's time + ∫C dt, or to a proposal's cost to go (the
step's and the policy's continuation's), fit on simulated labels."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dresspack_gym.errors import ConfigError

OUTPUTS = ("total", "time", "wear")  # the heads with parts; without, the total alone
HUBER_DELTA = 1.0  # in standard deviations of the normalised target
STD_FLOOR = 1e-6  # a feature that varies less in the fit is constant there (e.g. an action never proposed)
# log(1 + cost) is read back at most this large (cost ~1e6): a far extrapolation stays finite and still ranks last
LOG_COST_MAX = 14.0


def _scale(std: np.ndarray) -> np.ndarray:
    """Each feature's scale: its spread in the fit, or 1 where it did not vary (a constant feature is left unscaled:
    a value it never took in the fit, such as an action never proposed there, moves the network's input by the
    change alone, where dividing by the floor moved it a millionfold and the prediction with it). Models saved with
    the floor as their scale are read with 1 instead: the same predictions where the feature is at its fit value."""
    std = np.asarray(std, np.float32)
    return np.where(std > STD_FLOOR, std, np.float32(1.0)).astype(np.float32)


def features(obs: np.ndarray, action: np.ndarray, target: np.ndarray, q: np.ndarray, n_actions: int) -> np.ndarray:
    """The model's input per row: the observation, the action one-hot, the target configuration and the joint
    change to it (/pi): the same action index means a different motion in every state, the target says which."""
    obs, action = np.atleast_2d(obs), np.atleast_1d(action)
    one_hot = np.zeros((len(action), n_actions), dtype=np.float32)
    one_hot[np.arange(len(action)), action] = 1.0
    target, q = np.atleast_2d(target), np.atleast_2d(q)
    return np.concatenate([obs, one_hot, target / np.pi, (target - q) / np.pi], axis=1).astype(np.float32)


def labels(data: dict, parts: bool, label: str = "step") -> np.ndarray:
    """(rows, heads): time + ∫C dt, then with ``parts`` the time and the wear integral; or (``label="to_go"``, rows
    of continued proposals) the cost to go, where a continuation that did not finish counts as the dearest that
    did (the search never takes one; it ranks last with them)."""
    if label == "to_go":
        done = data["to_go_finished"]
        worst = data["to_go"][done].max() if done.any() else 1.0
        return np.where(done, data["to_go"], worst)[:, None]
    total = data["time"] + data["wear"]
    return np.stack([total, data["time"], data["wear"]] if parts else [total], axis=1)


def labelled(data: dict, label: str) -> dict:
    """The rows that carry ``label``: all for the step's cost, the continued proposals for the cost to go."""
    if label == "step":
        return data
    if "proposal" not in data or not data["proposal"].any():
        raise ConfigError("model.label", "to_go needs labels made with counterfactuals.continued >= 1 (costs to "
                                         "go of the continued proposals); these data have none")
    keep = data["proposal"]
    return {k: v[keep] for k, v in data.items()}


def most_probable(data: dict, states: np.ndarray) -> np.ndarray:
    """A mask of each state's row of the policy's most probable action (the first such row where tied)."""
    best = np.zeros(len(states), bool)
    for s in np.unique(states):
        m = np.flatnonzero(states == s)
        best[m[int(np.argmax(data["prob"][m]))]] = True
    return best


def state_ids(data: dict) -> np.ndarray:
    """One id per (episode, step): the rows that share it are one state's actions."""
    return np.unique(np.stack([data["episode"], data["step"]], axis=1), axis=0, return_inverse=True)[1].ravel()


def split_by_episode(episodes: np.ndarray, held_out: float, seed: int) -> np.ndarray:
    """A boolean mask of the held-out rows: a ``held_out`` fraction of the episodes (at least one), drawn by seed."""
    ids = np.unique(episodes)
    if len(ids) < 2:
        raise ConfigError("held_out", f"needs at least 2 episodes to hold some out, the data has {len(ids)}")
    n = min(len(ids) - 1, max(1, round(held_out * len(ids))))
    held = np.random.default_rng(seed).permutation(ids)[:n]
    return np.isin(episodes, held)


class CostModel:
    """The MLP with its normalisers; ``predict`` returns costs in the labels' units (s + ∫C dt)."""

    def __init__(self, n_features: int, n_actions: int, hidden: tuple[int, ...], parts: bool, target: str,
                 x_mean: np.ndarray | None = None, x_std: np.ndarray | None = None,
                 y_mean: np.ndarray | None = None, y_std: np.ndarray | None = None, label: str = "step"):
        import torch

        self.n_features, self.n_actions, self.hidden = n_features, n_actions, tuple(hidden)
        self.parts, self.target, self.label = bool(parts), target, label
        n_out = len(OUTPUTS) if parts else 1
        layers, width = [], n_features
        for h in self.hidden:
            layers += [torch.nn.Linear(width, h), torch.nn.SiLU()]
            width = h
        self.net = torch.nn.Sequential(*layers, torch.nn.Linear(width, n_out))
        self.x_mean = np.zeros(n_features, np.float32) if x_mean is None else x_mean.astype(np.float32)
        self.x_std = np.ones(n_features, np.float32) if x_std is None else _scale(x_std)
        self.y_mean = np.zeros(n_out, np.float32) if y_mean is None else y_mean.astype(np.float32)
        self.y_std = np.ones(n_out, np.float32) if y_std is None else _scale(y_std)

    def fit_normalisers(self, x: np.ndarray, y: np.ndarray) -> None:
        self.x_mean, self.x_std = x.mean(0), _scale(x.std(0))
        self.y_mean, self.y_std = y.mean(0), _scale(y.std(0))

    def encode_y(self, cost: np.ndarray) -> np.ndarray:
        y = np.log1p(np.maximum(cost, 0.0)) if self.target == "log" else cost
        return y.astype(np.float32)

    def decode_y(self, y: np.ndarray) -> np.ndarray:
        return np.expm1(np.minimum(y, LOG_COST_MAX)) if self.target == "log" else y

    def net_input(self, x: np.ndarray):
        import torch

        return torch.as_tensor((x - self.x_mean) / self.x_std, dtype=torch.float32)

    def predict_all(self, x: np.ndarray) -> np.ndarray:
        """Per row and head (OUTPUTS order), the predicted cost."""
        import torch

        self.net.eval()
        with torch.no_grad():
            out = self.net(self.net_input(x)).numpy()
        return self.decode_y(out * self.y_std + self.y_mean)

    def predict(self, obs, action, target, q) -> np.ndarray:
        """Predicted time + ∫C dt (of the step, or to go: ``label``) of each (observation, action, target
        configuration, configuration) row."""
        return self.predict_all(features(obs, action, target, q, self.n_actions))[:, 0]

    def save(self, path: str | Path, extra: dict | None = None) -> None:
        import torch

        torch.save({"state_dict": self.net.state_dict(), "n_features": self.n_features, "n_actions": self.n_actions,
                    "hidden": list(self.hidden), "parts": self.parts, "target": self.target, "label": self.label,
                    "x_mean": self.x_mean, "x_std": self.x_std, "y_mean": self.y_mean, "y_std": self.y_std,
                    **(extra or {})}, path)

    @classmethod
    def load(cls, path: str | Path) -> CostModel:
        import torch

        d = torch.load(path, map_location="cpu", weights_only=False)
        model = cls(d["n_features"], d["n_actions"], tuple(d["hidden"]), d["parts"], d["target"],
                    d["x_mean"], d["x_std"], d["y_mean"], d["y_std"], d.get("label", "step"))
        model.net.load_state_dict(d["state_dict"])
        return model


def fit(data: dict, n_actions: int, *, hidden: tuple[int, ...], target: str, loss: str, parts: bool, epochs: int,
        batch_size: int, learning_rate: float, weight_decay: float, held_out: float, seed: int, label: str = "step",
        log=None, held_out_episodes=None) -> tuple[CostModel, dict]:
    """Fit a CostModel on the rows of the episodes not held out (``held_out_episodes``, or a ``held_out`` fraction
    drawn by ``seed``); returns it and the fit's record (losses per epoch on both sets, the held-out episodes).
    ``data``: rows that carry ``label`` (:func:`labelled`). ``log(epoch, train_loss, held_out_loss)`` is called per
    epoch."""
    import torch

    torch.set_num_threads(1)  # a small MLP on small batches: threads cost more than they give, and the cores are busy
    torch.manual_seed(seed)
    x = features(data["obs"], data["action"], data["target"], data["q"], n_actions)
    held = split_by_episode(data["episode"], held_out, seed) if held_out_episodes is None else \
        np.isin(data["episode"], np.asarray(held_out_episodes))
    if held.all() or not held.any():
        raise ConfigError("held_out_episodes", "must hold out some episodes of the data and keep some to fit on")
    model = CostModel(x.shape[1], n_actions, hidden, parts, target, label=label)
    y = model.encode_y(labels(data, parts, label))
    model.fit_normalisers(x[~held], y[~held])
    xt, yt = model.net_input(x), torch.as_tensor((y - model.y_mean) / model.y_std)
    criterion = torch.nn.HuberLoss(delta=HUBER_DELTA) if loss == "huber" else torch.nn.MSELoss()
    optimizer = torch.optim.AdamW(model.net.parameters(), lr=learning_rate, weight_decay=weight_decay)
    scheduler = torch.optim.lr_scheduler.CosineAnnealingLR(optimizer, T_max=epochs)
    train_idx, held_idx = np.flatnonzero(~held), np.flatnonzero(held)
    rng = np.random.default_rng(seed)
    record = {"train_loss": [], "held_out_loss": []}

    def mean_loss(idx) -> float:
        model.net.eval()
        with torch.no_grad():
            return float(criterion(model.net(xt[idx]), yt[idx]))

    record["train_loss"].append(mean_loss(train_idx))
    record["held_out_loss"].append(mean_loss(held_idx))
    for epoch in range(epochs):
        model.net.train()
        for batch in np.array_split(rng.permutation(train_idx), max(1, len(train_idx) // batch_size)):
            optimizer.zero_grad()
            criterion(model.net(xt[batch]), yt[batch]).backward()
            optimizer.step()
        scheduler.step()
        record["train_loss"].append(mean_loss(train_idx))
        record["held_out_loss"].append(mean_loss(held_idx))
        if log is not None:
            log(epoch + 1, record["train_loss"][-1], record["held_out_loss"][-1])
    record["held_out_episodes"] = np.unique(data["episode"][held]).tolist()
    record["train_rows"], record["held_out_rows"] = len(train_idx), len(held_idx)
    return model, record


def rank_metrics(predicted: np.ndarray, true: np.ndarray, states: np.ndarray, chosen: np.ndarray | None = None
                 ) -> dict:
    """How well ``predicted`` orders ``true`` costs: Spearman ρ over all rows; within each state of at least 3
    actions, ρ among its actions (mean over states where both vary); top-1 agreement (the predicted cheapest action
    is a truly cheapest one) and the regret of taking it; and the spread of true costs among a state's actions."""
    from scipy.stats import spearmanr

    per_state, top1, regret, spread = [], [], [], []
    policy_regret, policy_top1 = [], []
    for s in np.unique(states):
        m = np.flatnonzero(states == s)
        t, p = true[m], predicted[m]
        pick = int(np.argmin(p))
        top1.append(bool(t[pick] <= t.min() + 1e-9))
        regret.append(float(t[pick] - t.min()))
        spread.append((float(t.min()), float(np.median(t)), float(t.max())))
        if chosen is not None and chosen[m].any():
            policy_regret.append(float(t[chosen[m]][0] - t.min()))
            policy_top1.append(bool(t[chosen[m]][0] <= t.min() + 1e-9))
        if len(m) >= 3 and np.ptp(t) > 0 and np.ptp(p) > 0:
            per_state.append(float(spearmanr(p, t).statistic))
    spread = np.array(spread)
    out = {"rows": int(len(true)), "states": int(len(spread)),
           # undefined (None, not NaN) when either side is constant, as a barely trained model's can be
           "spearman_global": (float(spearmanr(predicted, true).statistic)
                               if np.ptp(predicted) > 0 and np.ptp(true) > 0 else None),
           "spearman_per_state_mean": float(np.mean(per_state)) if per_state else None,
           "spearman_per_state_median": float(np.median(per_state)) if per_state else None,
           "states_ranked": len(per_state),
           "top1_agreement": float(np.mean(top1)), "mean_regret": float(np.mean(regret)),
           "median_abs_log_error": float(np.median(np.abs(np.log1p(np.maximum(predicted, 0)) - np.log1p(true)))),
           "state_cost_min_median": float(np.median(spread[:, 0])),
           "state_cost_median_median": float(np.median(spread[:, 1])),
           "state_cost_max_median": float(np.median(spread[:, 2])),
           "state_cost_range_median": float(np.median(spread[:, 2] - spread[:, 0]))}
    if policy_regret:
        out["policy_action_regret_mean"] = float(np.mean(policy_regret))
        out["policy_action_top1"] = float(np.mean(policy_top1))
    return out
