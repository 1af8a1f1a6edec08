"""The peak-tension term of the global wear-aware planners' leg objective: its default and its range check."""

from __future__ import annotations

from dresspack_gym.errors import ConfigError

# [s] a leg's highest tension term charged as if it lasted this long (see LegCost). Measured on thesis_tension's
# cuboid moved -10 cm, the four seeds whose routes peaked at 64-85 N under (4.10) alone: 0.1 s left two of them
# above 60 N, 0.25 s brought all four under 43 N, 0.5 s and 1 s lowered some of those peaks by 2-10 N more at
# no shorter cycle times (README "Finding the low route every time").
TENSION_PEAK_TIME = 0.25
MAX_TENSION_PEAK_TIME = 60.0  # [s] a peak charged as if it lasted a minute outweighs any leg's motion time


def check_tension_peak_time(value) -> float:
    """``tension_peak_time`` as a float, or a ConfigError naming the field and the allowed range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= MAX_TENSION_PEAK_TIME:
        raise ConfigError("tension_peak_time",
                          f"must be a number of seconds in [0, {MAX_TENSION_PEAK_TIME:g}], got {value!r}")
    return float(value)
