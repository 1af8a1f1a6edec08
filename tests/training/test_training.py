"""Training pipeline end to end (a few hundred steps), resume, config errors, and the masked policy's safety."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

pytest.importorskip("sb3_contrib")

from dresspack.training.config import load_train_config, train_config_from_dict  # noqa: E402
from dresspack.training.train import latest_checkpoint, train  # noqa: E402

from dresspack_gym.cli.main import main  # noqa: E402
from dresspack_gym.errors import ConfigError  # noqa: E402

SMOKE = {
    "name": "smoke",
    "env_kwargs": {"goal_action": True, "wear_integral": True, "wear_weight": 0.1, "settle_time": 0.0,
                   "sim_timestep": 0.004, "collision_margin": 0.005, "start_noise_deg": 5.0, "max_steps": 40,
                   "tasks": [["sill_front"], ["roof_rail_top"]]},
    "n_envs": 2, "vec_env": "dummy", "total_timesteps": 256, "seed": 3,
    "net_arch": [16, 16], "ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 2},
    "checkpoint_every": 128, "eval_every": 128, "eval_episodes": 1,
}


@pytest.mark.slow  # two PPO sessions with evaluations (~50 s)
def test_train_smoke_writes_run_folder_reloads_and_resumes(tmp_path):
    from sb3_contrib import MaskablePPO

    run = tmp_path / "run"
    summary = train(train_config_from_dict(SMOKE), run, progress=False, command="pytest smoke")
    for name in ("config.yaml", "command.txt", "versions.json", "final_model.zip", "summary.json"):
        assert (run / name).is_file(), name
    assert (run / "best" / "best_model.zip").is_file()
    assert list((run / "tb").rglob("events.out.tfevents*"))
    assert summary["timesteps"] == 256 and summary["last_session"]["steps_per_s"] > 0
    saved = yaml.safe_load((run / "config.yaml").read_text())
    assert saved["env_kwargs"]["tasks"] == SMOKE["env_kwargs"]["tasks"] and saved["ppo"]["n_steps"] == 64
    versions = json.loads((run / "versions.json").read_text())
    assert "torch" in versions and versions["git_dirty"] in (True, False, None)
    assert (versions["git_dirty"] is None) == (versions["git_commit"] is None)
    ckpt = latest_checkpoint(run)
    assert ckpt is not None and ckpt.name == "ckpt_256_steps.zip"

    model = MaskablePPO.load(run / "final_model.zip", device="cpu")
    assert model.num_timesteps == 256 and model.action_space.n == 14

    # resume: continues from the newest checkpoint to the new total, in the same run folder
    cfg = train_config_from_dict({**SMOKE, "total_timesteps": 512})
    summary = train(cfg, run, resume=True, progress=False, command="pytest resume")
    assert summary["timesteps"] == 512 and summary["last_session"]["steps"] == 256
    assert (run / "command.txt").read_text().splitlines() == ["pytest smoke", "pytest resume"]
    assert latest_checkpoint(run).name == "ckpt_512_steps.zip"
    # the evaluations of both sessions are kept (the stock callback overwrote the first session's on resume)
    assert summary["evaluations"]["timesteps"] == [128, 256, 384, 512]
    assert summary["best"]["timesteps"] in (128, 256, 384, 512) and summary["best"]["best_by"] == "reward"


def test_a_run_folder_is_never_overwritten_silently(tmp_path):
    run = tmp_path / "run"
    (run / "checkpoints").mkdir(parents=True)
    (run / "checkpoints" / "ckpt_10_steps.zip").write_bytes(b"")
    with pytest.raises(ConfigError, match="--resume"):
        train(train_config_from_dict(SMOKE), run, progress=False)


@pytest.mark.parametrize("data, field", [
    ({"n_envs": 0}, "n_envs"),
    ({"vec_env": "threads"}, "vec_env"),
    ({"env_id": "CartPole-v9"}, "env_id"),
    ({"ppo": {"gamma": 2}}, "ppo.gamma"),
    ({"ppo": {"lr": 0.1}}, "ppo.lr"),
    ({"net_arch": [64, -1]}, "net_arch"),
    ({"activation": "gelu"}, "activation"),
    ({"timesteps": 5}, "timesteps"),
    ({"best_by": "loss"}, "best_by"),
])
def test_bad_training_config_names_the_field(data, field):
    with pytest.raises(ConfigError) as err:
        train_config_from_dict(data)
    assert err.value.field == field


def test_cli_reports_bad_env_kwargs_and_unknown_config(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump({**SMOKE, "env_kwargs": {"cost_variant": "fancy"}}))
    assert main(["train", str(path), "--run-dir", str(tmp_path / "r")]) == 2
    assert "env_kwargs.cost_variant" in capsys.readouterr().err
    assert main(["train", "no_such_config"]) == 2
    assert "stud_welding" in capsys.readouterr().err  # lists the shipped configs


def test_shipped_training_config_loads_and_holds_out_its_evaluation_tasks():
    cfg = load_train_config("stud_welding")
    tasks = cfg.env_kwargs["tasks"]
    assert ["sill_rear", "roof_rail_top"] not in tasks and ["b_pillar_outer", "sill_front"] not in tasks
    assert cfg.eval_seed != cfg.seed


@pytest.mark.slow  # a PPO run, then three masked episodes (~35 s)
def test_masked_policy_never_enters_a_forbidden_configuration(tmp_path):
    """Even an untrained network, acting with masks, only visits valid configurations (asserted from info["q"])."""
    from dresspack.agents.learned.policy import PolicyAgent

    from dresspack_gym.env.dresspack_env import DresspackEnv

    run = tmp_path / "run"
    train(train_config_from_dict({**SMOKE, "eval_every": 0}), run, progress=False)
    agent = PolicyAgent(run / "final_model.zip")
    env = DresspackEnv(**{k: v for k, v in SMOKE["env_kwargs"].items() if k != "tasks"})
    limits = env.limits
    for seed in range(3):
        obs, info = env.reset(seed=seed, options={"welds": ["sill_front"]})
        done = False
        while not done:
            masks = env.action_masks()
            action = agent.predict(obs, masks, deterministic=False)
            assert masks[action]
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
            q = info["q"]
            assert not info["invalid_action"]
            assert np.all(q >= limits[:, 0] - 1e-9) and np.all(q <= limits[:, 1] + 1e-9)
            assert env.restrictions.allowed(q)[0]
            assert env.checker.min_distance(q) >= env.checker.margin


@pytest.mark.slow  # two PPO sessions (~35 s)
def test_resuming_a_finished_run_continues_from_its_final_model(tmp_path):
    """A finished run whose last rollout fell between checkpoints continues from the final model's steps."""
    from dresspack.training.train import resume_point

    run = tmp_path / "run"
    train(train_config_from_dict({**SMOKE, "checkpoint_every": 10**6, "eval_every": 0}), run, progress=False)
    assert latest_checkpoint(run) is None and resume_point(run) == run / "final_model.zip"
    summary = train(train_config_from_dict({**SMOKE, "checkpoint_every": 10**6, "eval_every": 0,
                                            "total_timesteps": 384}), run, resume=True, progress=False)
    assert summary["timesteps"] == 384 and summary["last_session"]["steps"] == 128


@pytest.mark.slow  # a PPO run on drawn welds with evaluations (~60 s)
def test_goal_conditioned_training_runs_and_evaluates_on_its_own_draws(tmp_path):
    cfg = load_train_config("goal_conditioned")
    assert cfg.env_kwargs["part_welds"] >= 1 and cfg.eval_seed != cfg.seed
    smoke = {**SMOKE, "name": "goal_smoke",
             "env_kwargs": {k: v for k, v in cfg.env_kwargs.items() if k != "max_steps"} | {"max_steps": 20}}
    summary = train(train_config_from_dict(smoke), tmp_path / "run", progress=False, command="pytest goal smoke")
    assert summary["timesteps"] == 256
    assert (tmp_path / "run" / "best" / "best_model.zip").is_file()  # the held-out evaluation ran


def _callback(tmp_path, best_by, eval_seed=None, env=None):
    import gymnasium as gym
    from dresspack.training.eval_callback import HeldOutEvalCallback

    return HeldOutEvalCallback(env if env is not None else gym.make("CartPole-v1"), best_by=best_by,
                               eval_seed=eval_seed, log_path=str(tmp_path), best_model_save_path=str(tmp_path / "b"),
                               verbose=0)


@pytest.mark.parametrize("best_by, resumed_at, best", [
    ("reward", 30, (5.0, 0.0)),    # step 20: the highest mean reward, though it finished fewer episodes
    ("success", 30, (1.0, 2.0)),   # step 30: all episodes finished; of the full-success ones, the higher reward
    ("success", 20, (1.0, -1.0)),  # resumed at 20: step 30 belonged to an abandoned continuation
    ("reward", 0, None),           # a fresh run ignores whatever file is there
])
def test_eval_callback_restores_history_and_ranks_the_best_by_its_rule(tmp_path, best_by, resumed_at, best):
    np.savez(tmp_path / "evaluations.npz", timesteps=[10, 20, 30], results=[[-1.0, -1.0], [5.0, 5.0], [2.0, 2.0]],
             ep_lengths=[[3, 3], [3, 3], [3, 3]], successes=[[1.0, 1.0], [0.0, 1.0], [1.0, 1.0]])
    cb = _callback(tmp_path, best_by)
    cb._restore_history(resumed_at)
    assert cb._best_score == best
    assert cb.evaluations_timesteps == [t for t in (10, 20, 30) if t <= resumed_at] if resumed_at else True


def test_eval_callback_judges_every_evaluation_on_the_same_episodes(tmp_path):
    """Reseeded before each evaluation, the same model scores the same twice; the stock callback's continuing
    random stream draws other welds the second time (so the test can fail)."""
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.logger import configure

    from dresspack_gym.env.dresspack_env import DresspackEnv

    cfg = load_train_config("goal_conditioned")
    kwargs = {k: v for k, v in cfg.env_kwargs.items() if k != "max_steps"} | {"max_steps": 4}
    rewards = {}
    for eval_seed in (None, 7):
        env = make_vec_env(DresspackEnv, n_envs=1, seed=0, env_kwargs=kwargs)
        model = MaskablePPO("MlpPolicy", env, seed=0, device="cpu", policy_kwargs={"net_arch": [8]})
        model.set_logger(configure(None, []))
        eval_env = make_vec_env(DresspackEnv, n_envs=1, seed=7, env_kwargs=kwargs)  # as train.py makes it
        cb = _callback(tmp_path / str(eval_seed), "success", eval_seed, eval_env)
        cb.n_eval_episodes, cb.eval_freq = 2, 1
        cb.init_callback(model)
        runs = []
        for _ in range(2):
            cb.on_step()
            runs.append(cb.evaluations_results[-1])
        rewards[eval_seed] = runs
        env.close()
        eval_env.close()
    assert rewards[7][0] == rewards[7][1]
    assert rewards[None][0] != rewards[None][1]
    assert rewards[None][0] == rewards[7][0]  # the first evaluation is the one the stock callback ran


@pytest.mark.slow  # a PPO run, then its three models validated (~35 s)
def test_select_model_validates_every_saved_model_on_the_same_episodes_and_resumes(tmp_path, capsys):
    from dresspack.training.select import select_model

    from dresspack_gym.cli.main import main as cli_main

    run = tmp_path / "run"
    short = {**SMOKE, "eval_every": 0, "env_kwargs": {**SMOKE["env_kwargs"], "max_steps": 10}}  # short rollouts
    train(train_config_from_dict(short), run, progress=False, command="pytest select")
    result = select_model(run, episodes=2, first_seed=5, attempts=2, jobs=2, progress=lambda *_: None)
    rows = result["models"]
    assert [(r["steps"], r["model"]) for r in rows] == [(128, "ckpt_128_steps.zip"), (256, "ckpt_256_steps.zip"),
                                                        (256, "final_model.zip")]
    # (the 256-step checkpoint is saved while its rollout is collected, before the update the final model has)

    def key(r):
        return r["success_rate"], r["mean_return"]

    assert key(result["best"]) == max(map(key, rows))
    assert result["best"] == next(r for r in rows if key(r) == max(map(key, rows)))  # ties: the earlier model
    log = run / "select_5_2_2.jsonl"
    assert len(log.read_text().splitlines()) == 3
    # resumed: nothing runs again; one worker gives the rows the two workers gave
    assert select_model(run, episodes=2, first_seed=5, attempts=2, progress=lambda *_: None) == result
    assert len(log.read_text().splitlines()) == 3
    log.unlink()
    again = select_model(run, episodes=2, first_seed=5, attempts=2, from_steps=256, progress=lambda *_: None)
    assert again["models"] == rows[1:]
    assert json.loads((run / "select_5_2_2.json").read_text())["best"] == again["best"]
    assert all(r["argmax_success_rate"] <= r["success_rate"] for r in rows)
    with pytest.raises(ConfigError, match="^from_steps"):
        select_model(run, episodes=2, from_steps=10_000)
    assert cli_main(["select-model", str(tmp_path), "--episodes", "2"]) == 2
    assert "is not a training run folder" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli_main(["select-model", str(run), "--episodes", "0"])


@pytest.mark.slow  # rollouts of the shipped policy, refit three times (~35 s)
def test_self_imitation_keeps_each_episodes_best_rollout_fits_the_actor_alone_and_resumes(tmp_path, capsys):
    import torch
    from dresspack.agents.learned.policy import resolve_policy
    from dresspack.training.self_imitation import self_imitate
    from sb3_contrib import MaskablePPO

    from dresspack_gym.cli.main import main as cli_main

    run, out = "goal_conditioned", tmp_path / "si"  # the shipped policy: it finishes most episodes
    shipped = resolve_policy(run)[0]
    summary = self_imitate(run, out, episodes=2, samples=3, first_seed=11, epochs=3, learning_rate=1e-3, jobs=2,
                           progress=lambda *_: None)
    rows = [json.loads(line) for line in (out / "rollouts.jsonl").read_text().splitlines()]
    assert sorted(r["seed"] for r in rows) == [11, 12] and all(len(r["rollouts"]) == 3 for r in rows)
    for r in rows:  # the best is the finishing rollout with the highest return
        finished = [k for k, x in enumerate(r["rollouts"]) if x["success"]]
        assert r["best"] == (max(finished, key=lambda k: r["rollouts"][k]["return"]) if finished else None)
    kept = [r for r in rows if r["best"] is not None]
    assert kept, "the shipped policy finished no episode: the test needs one"
    assert summary["fit"]["samples"] == sum(r["rollouts"][r["best"]]["steps"] for r in kept)
    assert summary["best_mean_return"] >= summary["argmax_mean_return"]
    losses = summary["fit"]["loss_by_epoch"]
    assert len(losses) == 4 and losses[-1] < losses[0]  # the actor moved toward its best rollouts
    before, after = (MaskablePPO.load(p, device="cpu").policy.state_dict() for p in (shipped, out / "model.zip"))
    value = [k for k in before if "value_net" in k]
    assert value and all(torch.equal(before[k], after[k]) for k in value)  # the critic is untouched
    assert any(not torch.equal(before[k], after[k]) for k in before if "policy_net" in k or "action_net" in k)
    assert resolve_policy(out) == (out / "model.zip", resolve_policy(run)[1])  # a policy folder, the base's env
    # the first rollout is the most probable actions: the same as a fresh deterministic rollout
    import gymnasium as gym

    import dresspack_gym  # noqa: F401

    cfg = yaml.safe_load((shipped.parent / "config.yaml").read_text())
    env = gym.make(cfg["env_id"], **cfg["env_kwargs"]).unwrapped
    model = MaskablePPO.load(shipped, device="cpu")
    obs, _ = env.reset(seed=11)
    total, done = 0.0, False
    while not done:
        action, _ = model.predict(obs, action_masks=env.action_masks(), deterministic=True)
        obs, reward, terminated, truncated, _ = env.step(int(action))
        total, done = total + reward, terminated or truncated
    env.close()
    assert total == rows[[r["seed"] for r in rows].index(11)]["rollouts"][0]["return"]
    # resumed: nothing rolls out again, and one worker refits the same model
    again = self_imitate(run, out, episodes=2, samples=3, first_seed=11, epochs=3, learning_rate=1e-3,
                         progress=lambda *_: None)
    assert len((out / "rollouts.jsonl").read_text().splitlines()) == 2 and again == summary
    # interrupted while writing the second episode's row: that episode alone rolls out again, to the same row
    lines = (out / "rollouts.jsonl").read_text().splitlines()
    (out / "rollouts.jsonl").write_text(lines[0] + "\n" + lines[1][:40])
    assert self_imitate(run, out, episodes=2, samples=3, first_seed=11, epochs=3, learning_rate=1e-3,
                        progress=lambda *_: None) == summary
    assert (out / "rollouts.jsonl").read_text().splitlines() == lines
    with pytest.raises(ConfigError, match="^samples"):
        self_imitate(run, out, episodes=2, samples=4, first_seed=11)
    spec = json.loads((out / "spec.json").read_text())
    (out / "spec.json").write_text(json.dumps(spec | {"code": "0" * 12}))  # rolled out by other code
    with pytest.raises(ConfigError, match="^code.*000000000000"):
        self_imitate(run, out, episodes=2, samples=3, first_seed=11)
    with pytest.raises(SystemExit):
        cli_main(["self-imitate", run, "--out", str(out), "--samples", "1"])
    assert "--samples" in capsys.readouterr().err


def test_self_imitation_refuses_a_policy_whose_env_config_is_wrong_before_rolling_out(tmp_path):
    from dresspack.agents.learned.policy import resolve_policy
    from dresspack.training.self_imitation import self_imitate

    model, config = resolve_policy("goal_conditioned")
    bad = tmp_path / "policy"
    bad.mkdir()
    (bad / "model.zip").write_bytes(model.read_bytes())
    config = {**config, "env_kwargs": {**config["env_kwargs"], "physics_profile": "fast"}}
    (bad / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    with pytest.raises(ConfigError, match="^env_kwargs.physics_profile: 'fast' is not one of the allowed values"):
        self_imitate(bad, tmp_path / "si", episodes=1, samples=2)
    assert not (tmp_path / "si").exists()  # nothing was started


def test_physics_profile_flag_sets_the_envs_profile_for_a_new_run_only(tmp_path):
    import argparse

    from dresspack.training.train import resolve_run

    args = argparse.Namespace(config="goal_conditioned", run_dir=str(tmp_path / "r"), resume=None, force=False,
                              total_timesteps=None, n_envs=None, seed=None, physics_profile="training")
    cfg, _, resume = resolve_run(args)
    assert cfg.env_kwargs["physics_profile"] == "training" and not resume
    assert load_train_config("goal_conditioned").env_kwargs["physics_profile"] == "coarse_step"  # the shipped one
    with pytest.raises(ConfigError, match="--physics-profile"):
        resolve_run(argparse.Namespace(**{**vars(args), "resume": str(tmp_path / "r")}))
    with pytest.raises(SystemExit):
        main(["train", "goal_conditioned", "--physics-profile", "fast"])  # argparse names the allowed profiles
