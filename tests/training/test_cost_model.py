"""The segment-cost model's data and fit: counterfactual labels, their independence of --jobs, restore, the MLP."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

pytest.importorskip("sb3_contrib")

from dresspack.training.cost_config import cost_config_from_dict, load_cost_config  # noqa: E402

from dresspack_gym.errors import ConfigError  # noqa: E402

# A cheap env (10-degree joint steps at a 4 ms physics step, one decision per episode) and an untrained policy:
# the labels' bookkeeping is under test here, not the shipped policy's quality.
TINY_ENV = {"goal_action": True, "wear_integral": True, "settle_time": 0.0, "sim_timestep": 0.004,
            "collision_margin": 0.005, "start_noise_deg": 5.0, "max_steps": 1, "tasks": [["sill_front"]]}


@pytest.fixture(scope="module")
def tiny_policy(tmp_path_factory):
    import gymnasium as gym
    from sb3_contrib import MaskablePPO

    import dresspack_gym  # noqa: F401

    folder = tmp_path_factory.mktemp("tiny_policy")
    env = gym.make("dresspack_gym/StudWelding-v0", **TINY_ENV)
    MaskablePPO("MlpPolicy", env, policy_kwargs={"net_arch": [8]}, seed=0, device="cpu").save(folder / "model.zip")
    (folder / "config.yaml").write_text(yaml.safe_dump({"env_id": "dresspack_gym/StudWelding-v0",
                                                        "env_kwargs": TINY_ENV}))
    return env.unwrapped, folder


@pytest.mark.slow  # labels made three times, once on two processes (~30 s)
def test_labels_are_the_same_for_one_and_two_jobs_and_a_resumed_run_remakes_only_missing_episodes(tiny_policy,
                                                                                                  tmp_path):
    from dresspack.training.counterfactuals import generate, load_counterfactuals, shard_path

    _, folder = tiny_policy
    cfg = cost_config_from_dict({"counterfactuals": {"policy": str(folder), "episodes": 2, "seed": 7,
                                                     "rollout": "sample"}}).counterfactuals
    one = generate(cfg, tmp_path / "one", jobs=1, progress=False)
    two = generate(cfg, tmp_path / "two", jobs=2, progress=False)
    a, b = load_counterfactuals(tmp_path / "one"), load_counterfactuals(tmp_path / "two")
    assert one["rows"] == two["rows"] == len(a["action"]) > 10 and one["episodes"] == 2
    assert set(a) == set(b) and all(_same(a[k], b[k]) for k in a)
    assert a["chosen"].sum() == 2 and (a["time"] > 0).any() and (a["wear"] > 0).any()
    assert not np.array_equal(a["obs"][a["episode"] == 0][0], a["obs"][a["episode"] == 1][0])  # own seeds
    shard_path(tmp_path / "one", 1).unlink()
    again = generate(cfg, tmp_path / "one", jobs=1, progress=False)
    assert again["sessions"][-1]["episodes"] == 1 and again["rows"] == one["rows"]
    assert all(_same(a[k], v) for k, v in load_counterfactuals(tmp_path / "one").items())
    # the model's stage on these labels: a run folder whose model predicts every row
    from dresspack.agents.learned.cost_model import CostModel
    from dresspack.training.train_cost_model import train_cost_model

    study = cost_config_from_dict({"model": {"hidden": [8], "epochs": 2, "held_out": 0.5}})
    metrics = train_cost_model(study, tmp_path / "one", tmp_path / "model", tensorboard=False, folds=2)
    assert metrics["rows"] == one["rows"] and metrics["held_out"]["states"] == 1
    # cross-validated by episode: every row predicted by the model fit on the other episode
    assert metrics["cross_validation"]["folds"] == 2 and metrics["cross_validation"]["rows"] == one["rows"]
    assert metrics["cross_validation"]["states"] == 2
    with pytest.raises(ConfigError, match="^--folds: 3 folds need as many episodes; the data have 2"):
        train_cost_model(study, tmp_path / "one", tmp_path / "model3", tensorboard=False, folds=3)
    cost = CostModel.load(tmp_path / "model" / "model.pt").predict(a["obs"], a["action"], a["target"], a["q"])
    assert cost.shape == a["time"].shape and np.isfinite(cost).all()
    with pytest.raises(ConfigError, match="^counterfactuals.seed"):
        generate(cost_config_from_dict({"counterfactuals": {"policy": str(folder), "episodes": 2,
                                                            "seed": 8}}).counterfactuals, tmp_path / "one")
    spec = json.loads((tmp_path / "one" / "spec.json").read_text())
    (tmp_path / "one" / "spec.json").write_text(json.dumps(spec | {"code": "0" * 12}))  # labelled by other code
    with pytest.raises(ConfigError, match="^counterfactuals.code.*000000000000"):
        generate(cfg, tmp_path / "one", jobs=1, progress=False)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal arrays, NaN (a label not made: no cost to go) equal to NaN."""
    return np.array_equal(a, b, equal_nan=a.dtype.kind == "f")


def test_counterfactuals_leave_the_env_as_it_was():
    import gymnasium as gym
    from dresspack.training.counterfactuals import counterfactual_rows

    twin = gym.make("dresspack_gym/StudWelding-v0", **{**TINY_ENV, "max_steps": 3}).unwrapped
    env = gym.make("dresspack_gym/StudWelding-v0", **{**TINY_ENV, "max_steps": 3}).unwrapped
    obs, _ = env.reset(seed=3)
    twin.reset(seed=3)
    for _ in range(2):
        masks = env.action_masks()
        a = int(np.flatnonzero(masks)[0])
        rows, kept = counterfactual_rows(env, obs, masks)
        assert kept is None
        assert [r["action"] for r in rows] == np.flatnonzero(masks).tolist()
        assert len({round(r["time"] + r["wear"], 9) for r in rows}) > 1  # the actions really were simulated
        assert np.array_equal(env.action_masks(), twin.action_masks())
        obs, reward, terminated, truncated, info = env.step(a)
        t_obs, t_reward, t_terminated, t_truncated, t_info = twin.step(a)
        assert np.array_equal(obs, t_obs) and reward == t_reward and (terminated, truncated) == (t_terminated,
                                                                                                t_truncated)
        assert info["integral_cost"] == t_info["integral_cost"] and info["cycle_time"] == t_info["cycle_time"]
        assert np.array_equal(env.sim.get_state(), twin.sim.get_state())


def test_continued_proposals_hold_the_cost_to_go_of_the_policys_continuation(tiny_policy):
    """Each state's K most probable moves carry the time + ∫C dt of the step and of the policy's most probable
    actions after it to the episode's end (stepped again here in a twin env); the other rows carry none."""
    import gymnasium as gym
    from dresspack.agents.learned.policy import PolicyAgent, moving_masks
    from dresspack.agents.learned.search import ranked_proposals
    from dresspack.training.counterfactuals import episode_seed, run_episode

    _, folder = tiny_policy
    kwargs = {**TINY_ENV, "max_steps": 3}
    env, twin = (gym.make("dresspack_gym/StudWelding-v0", **kwargs).unwrapped for _ in range(2))
    agent = PolicyAgent(folder / "model.zip")
    every = run_episode(env, agent, 0, 5, "argmax", continued=2)
    only = run_episode(env, agent, 0, 5, "argmax", continued=2, every_action=False)
    proposals = [r for r in every["rows"] if r["proposal"]]
    assert [r["action"] for r in only["rows"]] == [r["action"] for r in proposals] and len(proposals) >= 4
    assert all(np.isnan(r["to_go"]) for r in every["rows"] if not r["proposal"])
    assert all(r["to_go"] == o["to_go"] and r["prob"] == o["prob"] for r, o in zip(proposals, only["rows"]))
    obs, _ = twin.reset(seed=episode_seed(5, 0))
    first = [r for r in only["rows"] if r["step"] == 0]
    moving = moving_masks(twin, twin.action_masks())
    assert [r["action"] for r in first] == sorted(ranked_proposals(agent.probabilities(obs, moving), moving,
                                                                   twin.stay_action, 2))
    snap = twin.snapshot()
    for row in first:
        twin.restore(snap)
        obs, _, terminated, truncated, info = twin.step(row["action"])
        total = info["step_time"] + info["integral_cost"]
        while not (terminated or truncated):
            a = agent.predict(obs, moving_masks(twin, twin.action_masks()), deterministic=True)
            obs, _, terminated, truncated, info = twin.step(a)
            total += info["step_time"] + info["integral_cost"]
        assert row["to_go"] == pytest.approx(total, rel=1e-12) and row["to_go"] > row["time"] + row["wear"]
        assert row["to_go_finished"] == bool(terminated and info["is_success"])


def test_an_unfinished_continuation_ranks_with_the_dearest_finished_one():
    from dresspack.agents.learned.cost_model import labelled, labels

    data = {"to_go": np.array([5.0, 9.0, 3.0, np.nan]), "to_go_finished": np.array([True, True, False, False]),
            "proposal": np.array([True, True, True, False]), "time": np.ones(4), "wear": np.ones(4)}
    rows = labelled(data, "to_go")
    assert labels(rows, False, "to_go")[:, 0].tolist() == [5.0, 9.0, 9.0]
    with pytest.raises(ConfigError, match="^model.label: to_go needs"):
        labelled({**data, "proposal": np.zeros(4, bool)}, "to_go")


def _index_model(env, path, n_actions: int):
    """A linear cost-to-go model.pt that predicts a proposal cheaper the lower its action index."""
    import torch
    from dresspack.agents.learned.cost_model import CostModel

    n_obs = env.observation_space.shape[0]
    model = CostModel(n_obs + n_actions + 12, n_actions, (), parts=False, target="linear", label="to_go")
    with torch.no_grad():
        model.net[0].weight.zero_()
        model.net[0].bias.fill_(10.0)
        model.net[0].weight[0, n_obs:n_obs + n_actions] = torch.arange(n_actions, dtype=torch.float32)
    model.save(path)
    return path


@pytest.mark.slow  # about 15-20 s on 2 cores: the fast tier's time
def test_a_ranked_rollout_labels_the_states_ppo_search_s_ranked_rule_visits(tiny_policy, tmp_path):
    """DAgger labels: each step is the one ppo-search's ranked rule takes (here with a model preferring the lowest
    action index among the policy's 3 most probable moves), and each state's proposals are labelled as for the
    policy's own rollout; the same labels on one and two processes; the spec names the model by its digest."""
    import gymnasium as gym
    from dresspack.agents.learned.policy import PolicyAgent, moving_masks
    from dresspack.agents.learned.search import ranked_proposals
    from dresspack.training.counterfactuals import episode_seed, generate, load_counterfactuals

    env, folder = tiny_policy
    agent = PolicyAgent(folder / "model.zip")
    model = _index_model(env, tmp_path / "ctg.pt", agent.n_actions)
    raw = {"counterfactuals": {"policy": str(folder), "episodes": 2, "seed": 3, "rollout": "ranked",
                               "cost_to_go": str(model), "continued": 4, "every_action": False}}
    cfg = cost_config_from_dict(raw).counterfactuals
    one = generate(cfg, tmp_path / "one", jobs=1, progress=False)
    two = generate(cfg, tmp_path / "two", jobs=2, progress=False)
    a, b = load_counterfactuals(tmp_path / "one"), load_counterfactuals(tmp_path / "two")
    assert one["rows"] == two["rows"] and set(a) == set(b) and all(_same(a[k], b[k]) for k in a)
    assert a["proposal"].all() and a["settled"].all() and {"to_go_settled", "to_go"} <= set(a)
    twin = gym.make("dresspack_gym/StudWelding-v0", **TINY_ENV).unwrapped
    for episode in (0, 1):
        obs, _ = twin.reset(seed=episode_seed(3, episode))
        moving = moving_masks(twin, twin.action_masks())
        proposals = ranked_proposals(agent.probabilities(obs, moving), moving, twin.stay_action, 3)
        rows = a["episode"] == episode
        assert a["action"][rows & a["chosen"]].tolist() == [min(proposals)]  # one decision an episode here
        assert len(proposals) == 3 and rows.sum() == 4
    spec = json.loads((tmp_path / "one" / "spec.json").read_text())
    assert spec["cost_to_go_file"] == str(model.resolve()) and len(spec["cost_to_go_digest"]) == 12
    assert spec["libraries"]["numpy"] == np.__version__
    _index_model(env, model, agent.n_actions + 1)  # another model at the same path: not these labels' model
    with pytest.raises(ConfigError, match="^counterfactuals.cost_to_go: .*fit for a policy of"):
        generate(cfg, tmp_path / "one", jobs=1, progress=False)


def test_a_model_is_fit_to_several_label_folders_of_one_policy(tiny_policy, tmp_path):
    """A DAgger round's labels beside the first: their episodes keep apart (ids offset by folder), the metrics
    name each folder's episodes; folders of two policies are refused."""
    from dresspack.training.cost_config import MAX_EPISODES
    from dresspack.training.counterfactuals import generate, load_label_folders
    from dresspack.training.train_cost_model import _ranges, train_cost_model

    _, folder = tiny_policy
    for seed, out in ((7, "a"), (8, "b")):
        generate(cost_config_from_dict({"counterfactuals": {"policy": str(folder), "episodes": 2, "seed": seed,
                                                            "rollout": "sample"}}).counterfactuals,
                 tmp_path / out, jobs=1, progress=False)
    data, specs = load_label_folders([tmp_path / "a", tmp_path / "b"])
    assert sorted(set(data["episode"].tolist())) == [0, 1, MAX_EPISODES, MAX_EPISODES + 1]
    assert [s["seed"] for s in specs] == [7, 8]
    study = cost_config_from_dict({"model": {"hidden": [8], "epochs": 2, "held_out": 0.5}})
    metrics = train_cost_model(study, [tmp_path / "a", tmp_path / "b"], tmp_path / "m", tensorboard=False)
    assert metrics["episodes"] == 4 and [d["episodes"] for d in metrics["data"]] == ["0-1", "0-1"]
    assert [d["seed"] for d in metrics["data"]] == [7, 8]
    assert _ranges([0, 1, 2, 5, 7, 8]) == "0-2,5,7-8"
    spec = json.loads((tmp_path / "b" / "spec.json").read_text())
    moved = tmp_path / "elsewhere.zip"  # the same policy in another checkout: the same policy
    moved.write_bytes((folder / "model.zip").read_bytes())
    (tmp_path / "b" / "spec.json").write_text(json.dumps(spec | {"policy_file": str(moved)}))
    assert load_label_folders([tmp_path / "a", tmp_path / "b"])[0]["episode"].size == data["episode"].size
    (tmp_path / "b" / "spec.json").write_text(json.dumps(spec | {"policy_file": str(moved), "policy_digest": "0" * 12}))
    with pytest.raises(ConfigError, match="^--data: .*one model is fit to one policy's labels"):
        load_label_folders([tmp_path / "a", tmp_path / "b"])


def _synthetic(episodes=12, steps=3, n_actions=6, seed=0):
    """Rows whose cost is a smooth function of the action's joint change: a model must learn it from features."""
    rng = np.random.default_rng(seed)
    rows = {k: [] for k in ("obs", "action", "target", "q", "time", "wear", "episode", "step", "chosen")}
    for e in range(episodes):
        for s in range(steps):
            q = rng.uniform(-1, 1, 6)
            obs = np.concatenate([q, rng.normal(size=4)]).astype(np.float32)
            for a in range(n_actions):
                target = q + rng.uniform(-1, 1, 6)
                move = np.abs(target - q).sum()
                for k, v in zip(rows, (obs, a, target, q, 0.5 + move, 2.0 * move ** 2 + 0.3 * a, e, s, a == 0)):
                    rows[k].append(v)
    return {k: np.array(v) for k, v in rows.items()}, n_actions


def test_the_cost_model_fits_a_tiny_dataset_and_ranks_held_out_actions(tmp_path):
    from dresspack.agents.learned.cost_model import CostModel, features, fit, labels, rank_metrics, state_ids

    data, n_actions = _synthetic(episodes=24)
    model, record = fit(data, n_actions, hidden=(64, 64), target="log", loss="huber", parts=True, epochs=60,
                        batch_size=32, learning_rate=3e-3, weight_decay=0.0, held_out=0.25, seed=0)
    assert record["train_loss"][-1] < 0.1 * record["train_loss"][0]
    held = np.isin(data["episode"], record["held_out_episodes"])
    assert 0 < held.sum() < len(held) and len(record["held_out_episodes"]) == 6
    x = features(data["obs"], data["action"], data["target"], data["q"], n_actions)
    predicted = model.predict_all(x)
    assert predicted.shape == (len(x), 3)
    m = rank_metrics(predicted[held, 0], labels(data, False)[held, 0], state_ids(data)[held], data["chosen"][held])
    assert m["spearman_global"] > 0.8 and m["spearman_per_state_mean"] > 0.6 and m["states"] == 18
    model.save(tmp_path / "m.pt")
    again = CostModel.load(tmp_path / "m.pt")
    assert np.allclose(again.predict(data["obs"], data["action"], data["target"], data["q"]), predicted[:, 0])
    perfect = rank_metrics(labels(data, False)[:, 0], labels(data, False)[:, 0], state_ids(data))
    assert perfect["spearman_global"] == perfect["spearman_per_state_mean"] == perfect["top1_agreement"] == 1.0
    assert perfect["mean_regret"] == 0.0
    flat = rank_metrics(np.ones(len(data["action"])), labels(data, False)[:, 0], state_ids(data))
    assert flat["spearman_global"] is None and flat["spearman_per_state_mean"] is None  # undefined, not NaN


def test_a_feature_constant_in_the_fit_is_left_unscaled(tmp_path):
    """An action never proposed in the fit (its one-hot column constant) moves the network's input by 1, not by the
    millionfold of dividing by the floor: its prediction stays in the range of the others'. A model saved with the
    floor as a scale reads with 1 there, predicting the same on the rows it was fit on."""
    import torch
    from dresspack.agents.learned.cost_model import STD_FLOOR, CostModel, features, fit

    data, n_actions = _synthetic(episodes=16)
    fit_rows = {k: v[data["action"] != 5] for k, v in data.items()}
    model, _ = fit(fit_rows, n_actions, hidden=(32,), target="log", loss="huber", parts=False, epochs=30,
                   batch_size=32, learning_rate=3e-3, weight_decay=0.0, held_out=0.25, seed=0)
    column = data["obs"].shape[1] + 5  # action 5's one-hot
    assert model.x_std[column] == 1.0 and model.x_mean[column] == 0.0
    unseen = data["action"] == 5
    p = model.predict(data["obs"], data["action"], data["target"], data["q"])
    assert np.isfinite(p).all() and p[unseen].max() < 10 * p[~unseen].max()
    model.save(tmp_path / "m.pt")
    saved = torch.load(tmp_path / "m.pt", weights_only=False)
    saved["x_std"] = np.where(saved["x_std"] == 1.0, np.float32(STD_FLOOR), saved["x_std"])  # as the floor was kept
    torch.save(saved, tmp_path / "floor.pt")
    again = CostModel.load(tmp_path / "floor.pt")
    x = features(fit_rows["obs"], fit_rows["action"], fit_rows["target"], fit_rows["q"], n_actions)
    assert again.x_std[column] == 1.0 and np.array_equal(again.predict_all(x), model.predict_all(x))


@pytest.mark.parametrize("data, field", [
    ({"model": {"loss": "l1"}}, "model.loss"),
    ({"model": {"hidden": [0]}}, "model.hidden"),
    ({"model": {"held_out": 0.0}}, "model.held_out"),
    ({"model": {"epoch": 3}}, "model.epoch"),
    ({"counterfactuals": {"rollout": "greedy"}}, "counterfactuals.rollout"),
    ({"counterfactuals": {"episodes": 0}}, "counterfactuals.episodes"),
    ({"counterfactuals": {"env_kwargs": {"action_set": "joint_steps"}}}, "counterfactuals.env_kwargs.action_set"),
    ({"counterfactuals": {"continued": -1}}, "counterfactuals.continued"),
    ({"counterfactuals": {"every_action": False}}, "counterfactuals.every_action"),
    ({"model": {"label": "return"}}, "model.label"),
    ({"model": {"label": "to_go"}}, "model.parts"),
    ({"counterfactuals": {"rollout": "ranked"}}, "counterfactuals.cost_to_go"),
    ({"counterfactuals": {"rollout": "sample", "cost_to_go": "cost_to_go"}}, "counterfactuals.cost_to_go"),
    ({"counterfactuals": {"rollout": "ranked", "cost_to_go": 3}}, "counterfactuals.cost_to_go"),
])
def test_bad_cost_config_fields_are_named(data, field):
    with pytest.raises(ConfigError) as err:
        cost_config_from_dict(data)
    assert err.value.field == field


def test_the_shipped_cost_config_loads_and_the_cli_names_a_bad_field(tmp_path, capsys):
    from dresspack.training.counterfactuals import add_counterfactuals_command
    from dresspack.training.train_cost_model import add_train_cost_model_command

    from dresspack_gym.cli.main import main

    cfg = load_cost_config("cost_model")
    assert cfg.counterfactuals.policy == "goal_conditioned" and cfg.model.held_out > 0
    assert cost_config_from_dict(cfg.to_dict()) == cfg
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"model": {"target": "sqrt"}}))
    commands = [add_counterfactuals_command, add_train_cost_model_command]
    assert main(["counterfactuals", "--config", str(bad), "--out", str(tmp_path / "x")], extensions=commands) == 2
    assert "model.target" in capsys.readouterr().err
    assert main(["train-cost-model", "--data", str(tmp_path), "--out", str(tmp_path / "m")], extensions=commands) == 2
    assert "--data" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


@pytest.mark.slow  # Ray's start-up (its own processes, each actor importing torch and MuJoCo): minutes on 2 cores
def test_labels_on_ray_are_the_ones_made_here(tiny_policy, tmp_path):
    """Data generation beyond one machine: Ray actors (here two on this machine) write the same shards as one
    process."""
    ray = pytest.importorskip("ray")
    from dresspack.training.counterfactuals import generate, load_counterfactuals

    _, folder = tiny_policy
    cfg = cost_config_from_dict({"counterfactuals": {"policy": str(folder), "episodes": 2, "seed": 7,
                                                     "rollout": "sample"}}).counterfactuals
    generate(cfg, tmp_path / "here", jobs=1, progress=False)
    try:
        on_ray = generate(cfg, tmp_path / "ray", jobs=2, progress=False, backend="ray")
    finally:
        ray.shutdown()
    a, b = load_counterfactuals(tmp_path / "here"), load_counterfactuals(tmp_path / "ray")
    assert on_ray["episodes"] == 2 and set(a) == set(b) and all(_same(a[k], b[k]) for k in a)
    with pytest.raises(ConfigError, match="backend"):
        generate(cfg, tmp_path / "bad", backend="cluster")


def test_labels_on_the_rod_engine_are_the_steps_own_time_and_wear():
    """A counterfactual label means what a step reports on the engine the labels are made on: its time and ∫C dt."""
    import gymnasium as gym
    from dresspack.training.counterfactuals import counterfactual_rows

    env = gym.make("dresspack_gym/StudWelding-v0", **{**TINY_ENV, "physics_profile": "training"}).unwrapped
    assert env.sim.engine == "fast"
    obs, _ = env.reset(seed=3)
    masks = env.action_masks()
    snap = env.snapshot()
    rows, _ = counterfactual_rows(env, obs, masks)
    assert [r["action"] for r in rows] == np.flatnonzero(masks).tolist()
    for r in rows[:4]:
        env.restore(snap)
        info = env.step(r["action"])[4]
        assert (r["time"], r["wear"]) == (info["step_time"], info["integral_cost"])
    assert len({round(r["time"] + r["wear"], 9) for r in rows}) > 1
