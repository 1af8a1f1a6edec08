"""The time weight of the wear-aware planners' leg objective (seconds against ∫C dt): its range check."""

from __future__ import annotations

from dresspack_gym.errors import ConfigError

# Largest cost of one second of cycle time against one unit of ∫C dt: a second then outweighs a leg's whole
# wear integral (tens to hundreds), so the wear term no longer ranks routes (the README measures the trade-off).
MAX_TIME_WEIGHT = 1000.0


def check_time_weight(value) -> float:
    """``time_weight`` as a float, or a ConfigError naming the field and the allowed range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= MAX_TIME_WEIGHT:
        raise ConfigError("time_weight", f"must be a number in [0, {MAX_TIME_WEIGHT:g}] (cost of one second of "
                                         f"cycle time against one unit of ∫C dt; 0: wear alone), got {value!r}")
    return float(value)
