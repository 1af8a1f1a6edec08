"""EnvConfig: the env's settings in one frozen, validated object, loadable from the training YAMLs."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from dresspack_gym import ConfigError
from dresspack_gym.env.config import NUMBER_RANGES, EnvConfig
from dresspack_gym.env.dresspack_env import DresspackEnv
from dresspack_gym.io.loading import read_yaml

ROOT = Path(__file__).resolve().parents[2]
# the PPO training configs (configs/training/ also holds the cost model's, which has no env of its own)
TRAINING_YAMLS = sorted(p for p in (ROOT / "configs" / "training").glob("*.yaml") if "env_kwargs" in read_yaml(p))


def test_defaults_are_the_envs_and_the_config_is_frozen():
    c = EnvConfig()
    assert c == EnvConfig.from_dict({}) == EnvConfig.from_dict(c.as_dict())
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.max_steps = 5
    assert DresspackEnv(station="default").config == c


def test_an_unknown_setting_is_refused_naming_it_and_the_allowed_ones():
    with pytest.raises(ConfigError) as err:
        EnvConfig.from_dict({"max_step": 10})
    assert err.value.field == "max_step"
    assert "max_steps" in str(err.value) and "via_postures_deg" in str(err.value)
    with pytest.raises(ConfigError) as err:
        DresspackEnv(station="default", joint_steps_deg=5.0)
    assert err.value.field == "joint_steps_deg"
    with pytest.raises(ConfigError) as err:
        DresspackEnv(station="default", config={"max_steps": 5})
    assert err.value.field == "config"


@pytest.mark.parametrize("name", list(NUMBER_RANGES))
def test_every_number_is_typed_and_ranged(name):
    lo, hi, integer = NUMBER_RANGES[name]
    for bad in (float("nan"), hi * 2 + 1, "fast"):
        with pytest.raises(ConfigError) as err:
            EnvConfig(**{name: bad})
        assert err.value.field == name


def _as_lists(value):
    return [_as_lists(v) for v in value] if isinstance(value, (list, tuple)) else value


@pytest.mark.parametrize("path", TRAINING_YAMLS, ids=lambda p: p.stem)
def test_the_training_yamls_env_kwargs_are_configs(path):
    kwargs = read_yaml(path)["env_kwargs"]
    c = EnvConfig.from_dict(kwargs)
    for k, v in kwargs.items():  # lists become tuples, values stay
        assert _as_lists(getattr(c, k)) == v, k
    hash(c)  # frozen all the way down: a config can key a cache


def test_a_config_and_keyword_settings_build_the_same_env():
    c = EnvConfig(max_steps=7, goal_action=True, settle_time=0.0)
    a = DresspackEnv(station="default", config=c)
    b = DresspackEnv(station="default", max_steps=7, goal_action=True, settle_time=0.0)
    over = DresspackEnv(station="default", config=c, max_steps=3)  # a setting replaces the config's
    assert a.config == b.config and over.config == dataclasses.replace(c, max_steps=3)
    oa, _ = a.reset(seed=4)
    ob, _ = b.reset(seed=4)
    np.testing.assert_array_equal(oa, ob)
    for action in (13, 13, 0):
        np.testing.assert_array_equal(a.step(action)[0], b.step(action)[0])
