"""The env's settings: one frozen, validated EnvConfig instead of a long list of keyword arguments."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..fields import check_choice, check_integer, check_number, check_vector
from ..physics.profiles import PROFILES
from ..physics.wear_cost import COST_VARIANTS
from ..stations.rendering import check_frame_size
from .action_sets import ACTION_SETS, VIA_ANCHORS

# Ranges of the numeric settings: (low, high, integer). Everything a trainer passes through from its YAML is checked
# here, once, so a bad value fails at construction naming the setting, not as NaN logits later.
NUMBER_RANGES = {
    "robot": (0, 64, True),
    "n_welds": (1, 10_000, True),
    "joint_step_deg": (0.1, 90.0, False),
    "max_steps": (1, 1_000_000, True),
    "time_weight": (0.0, 1e6, False),
    "wear_weight": (0.0, 1e6, False),
    "goal_reward": (0.0, 1e6, False),
    "progress_weight": (0.0, 1e6, False),
    "invalid_penalty": (0.0, 1e6, False),
    "settle_time": (0.0, 10.0, False),
    "cable_samples": (2, 1000, True),
    "collision_margin": (0.0, 1.0, False),
    "mask_resolution_deg": (0.01, 90.0, False),
    "start_noise_deg": (0.0, 180.0, False),
    "sim_timestep": (1e-4, 0.01, False),
    "part_welds": (0, 100, True),
    "weld_tilt_deg": (0.0, 80.0, False),
    "wear_reward_cap": (1e-6, 1e12, False),
    "approach_vias": (0, 16, True),
    "approach_range_deg": (1.0, 180.0, False),
}
OPTIONAL_NUMBERS = ("n_welds", "sim_timestep", "wear_reward_cap")  # None: not used
BOOL_SETTINGS = ("shuffle_welds", "goal_action", "wear_integral")
VIA_OFFSET_RANGE_DEG = (1.0, 180.0)


@dataclass(frozen=True)
class EnvConfig:
    """Every setting of a :class:`~dresspack_gym.env.dresspack_env.DresspackEnv` but its station and render mode.

    Task: ``robot`` (index in the station), ``welds`` (default all, in order), ``n_welds`` of them per episode
    (optionally ``shuffle_welds``), or one of ``tasks`` (weld lists), or ``part_welds`` drawn on the station's parts
    each episode (the gun within ``weld_tilt_deg`` of the panel normal); ``start_noise_deg`` around Home.
    Reward (see :class:`~dresspack_gym.env.weld_cycle.WeldCycleTask`): ``time_weight``, ``wear_weight`` (of
    ``cost_variant``, integrated along the motion with ``wear_integral``, a step's at most ``wear_reward_cap``),
    ``progress_weight``, ``goal_reward``, ``invalid_penalty`` (with ``invalid_action="penalize"``; ``"raise"``
    raises instead). Physics: ``physics_profile``, ``sim_timestep``, ``settle_time`` after each ordinary step.
    Actions: ``action_set`` (``joint_steps`` of ``joint_step_deg``, with ``goal_action`` a step toward the goal; or
    ``primitives``: ``via_offsets_deg`` x ``via_anchors`` vias, ``fallback_anchors``, ``via_postures_deg``,
    ``approach_vias`` within ``approach_range_deg``), masked by ``collision_margin`` [m] and checked every
    ``mask_resolution_deg``. Episode: ``max_steps``; observation: ``cable_samples``; frames: ``render_size``.
    """

    robot: int = 0
    welds: tuple[str, ...] | None = None
    n_welds: int | None = None
    shuffle_welds: bool = False
    joint_step_deg: float = 10.0
    max_steps: int = 200
    time_weight: float = 1.0
    wear_weight: float = 1.0
    cost_variant: str = "thesis"
    goal_reward: float = 10.0
    progress_weight: float = 1.0
    invalid_action: str = "penalize"
    invalid_penalty: float = 1.0
    settle_time: float = 0.3
    cable_samples: int = 8
    collision_margin: float = 0.0
    mask_resolution_deg: float = 2.0
    goal_action: bool = False
    wear_integral: bool = False
    tasks: tuple[tuple[str, ...], ...] | None = None
    start_noise_deg: float = 0.0
    sim_timestep: float | None = None
    physics_profile: str = "accurate"
    part_welds: int = 0
    weld_tilt_deg: float = 20.0
    action_set: str = "joint_steps"
    via_offsets_deg: tuple[float, ...] = (30.0, 60.0)
    via_anchors: tuple[str, ...] = ("midpoint",)
    fallback_anchors: tuple[str, ...] = ()
    via_postures_deg: tuple[tuple[float, ...], ...] = ()
    approach_vias: int = 0
    approach_range_deg: float = 45.0
    wear_reward_cap: float | None = None
    render_size: tuple[int, int] = (480, 360)

    def __post_init__(self):
        _validate(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> EnvConfig:
        """A config from a mapping (a YAML's ``env_kwargs``, keyword arguments): an unknown key is refused naming
        it and the allowed ones; every value is typed and ranged (see :data:`NUMBER_RANGES`)."""
        if not isinstance(data, dict):
            raise ConfigError("env_kwargs", f"expected a mapping of env settings, got {data!r}")
        allowed = [f.name for f in fields(cls)]
        unknown = [k for k in data if k not in allowed]
        if unknown:
            raise ConfigError(str(unknown[0]), f"unknown env setting {unknown[0]!r}; allowed settings are {allowed}")
        return cls(**data)

    def as_dict(self) -> dict[str, Any]:
        """The settings as keyword arguments (``EnvConfig.from_dict(c.as_dict()) == c``)."""
        return asdict(self)


def _as_list(value: Any, name: str, expected: str, *, non_empty: bool = False) -> tuple:
    """Setting ``name`` as a tuple: it must be a list or tuple (``expected`` says of what), not a string."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)) or (non_empty and not value):
        raise ConfigError(name, f"expected {expected}, got {value!r}")
    return tuple(value)


def _primitives_only(c: EnvConfig, name: str) -> None:
    if getattr(c, name) and c.action_set != "primitives":
        raise ConfigError(name, "applies to action_set primitives only (joint steps have no vias)")


def _validate(c: EnvConfig) -> None:
    """Every setting typed, finite and in range, or a ConfigError naming it and what it allows; list settings are
    stored as tuples (the config is frozen and hashable)."""
    _check_numbers(c)
    _check_welds(c)
    check_choice("cost_variant", c.cost_variant, COST_VARIANTS)
    check_choice("physics_profile", c.physics_profile, list(PROFILES))
    check_choice("invalid_action", c.invalid_action, ("penalize", "raise"))
    check_choice("action_set", c.action_set, ACTION_SETS)
    _check_vias(c)
    if c.goal_action and c.action_set == "primitives":
        raise ConfigError("goal_action", "applies to action_set joint_steps only (primitives always go to the goal "
                                         "with action 0)")
    size = c.render_size
    if not isinstance(size, (list, tuple)) or len(size) != 2:
        raise ConfigError("render_size", f"expected (width, height) in pixels, got {size!r}")
    check_frame_size(size[0], size[1])
    _put(c, "render_size", tuple(size))


def _put(c: EnvConfig, name: str, value: Any) -> None:
    """Store a checked setting in its normal form (a frozen instance, while it is being validated)."""
    object.__setattr__(c, name, value)


def _check_numbers(c: EnvConfig) -> None:
    for name, (lo, hi, integer) in NUMBER_RANGES.items():
        value = getattr(c, name)
        if value is None and name in OPTIONAL_NUMBERS:
            continue
        if integer:
            check_integer(value, name, lo=lo, hi=hi)
        else:
            check_number(value, name, lo=lo, hi=hi, unit="deg" if name.endswith("_deg") else "")
    if c.mask_resolution_deg > c.joint_step_deg:
        raise ConfigError("mask_resolution_deg", f"{c.mask_resolution_deg} must not exceed joint_step_deg "
                                                 f"({c.joint_step_deg}): a step is checked at this resolution")
    for name in BOOL_SETTINGS:
        if not isinstance(getattr(c, name), (bool, np.bool_)):
            raise ConfigError(name, f"expected true or false, got {getattr(c, name)!r}")


def _check_welds(c: EnvConfig) -> None:
    """``welds`` and each of ``tasks``: lists of weld-point names (a single name is refused whole, not spelled out
    letter by letter as a list of names)."""
    if c.welds is not None:
        welds = _as_list(c.welds, "welds", "a list of weld-point names")
        if not all(isinstance(w, str) for w in welds):
            raise ConfigError("welds", f"expected a list of weld-point names, got {c.welds!r}")
        _put(c, "welds", welds)
    if c.tasks is not None:
        tasks = _as_list(c.tasks, "tasks", "a non-empty list of non-empty weld-name lists", non_empty=True)
        for i, task in enumerate(tasks):
            task = _as_list(task, f"tasks[{i}]", "a non-empty list of weld-point names", non_empty=True)
            if not all(isinstance(w, str) for w in task):
                raise ConfigError(f"tasks[{i}]", f"expected a non-empty list of weld-point names, got {list(task)!r}")
        _put(c, "tasks", tuple(tuple(t) for t in tasks))


def _check_vias(c: EnvConfig) -> None:
    """The primitives' vias: offsets, anchors, fallback anchors, travel postures, approach vias."""
    offsets = _as_list(c.via_offsets_deg, "via_offsets_deg", "a non-empty list of angles [deg]", non_empty=True)
    for i, v in enumerate(offsets):
        check_number(v, f"via_offsets_deg[{i}]", lo=VIA_OFFSET_RANGE_DEG[0], hi=VIA_OFFSET_RANGE_DEG[1], unit="deg")
    _put(c, "via_offsets_deg", tuple(float(v) for v in offsets))
    anchors = _as_list(c.via_anchors, "via_anchors", f"a non-empty list from {list(VIA_ANCHORS)}", non_empty=True)
    for i, anchor in enumerate(anchors):
        check_choice(f"via_anchors[{i}]", anchor, list(VIA_ANCHORS))
    if len(set(anchors)) != len(anchors):
        raise ConfigError("via_anchors", f"each anchor at most once, got {list(anchors)}")
    _put(c, "via_anchors", anchors)
    fallback = _as_list(c.fallback_anchors, "fallback_anchors", f"a list of anchors from via_anchors {list(anchors)}")
    _primitives_only(c, "fallback_anchors")
    for i, anchor in enumerate(fallback):
        check_choice(f"fallback_anchors[{i}]", anchor, list(anchors))
    if len(set(fallback)) != len(fallback) or len(fallback) >= len(anchors):
        raise ConfigError("fallback_anchors", f"each anchor at most once, and at least one of via_anchors "
                                              f"{list(anchors)} not a fallback, got {list(fallback)}")
    _put(c, "fallback_anchors", fallback)
    postures = _as_list(c.via_postures_deg, "via_postures_deg", "a list of joint configurations (6 angles each) [deg]")
    _primitives_only(c, "via_postures_deg")
    _put(c, "via_postures_deg", tuple(check_vector(p, f"via_postures_deg[{i}]", 6, unit="deg")
                                      for i, p in enumerate(postures)))
    _primitives_only(c, "approach_vias")
