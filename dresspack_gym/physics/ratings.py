"""Cable makers' rated fatigue tests simulated with the rod engine and the fatigue model, and the strain radii
calibrated so that each test's simulated life is its rated life.

A rated bending test bends the cable from straight to a bend radius of ``bend_factor`` x its outer diameter and back;
a rated torsion test twists it, clamped, through +-``twist_deg_per_m`` degrees per metre and back. Both are simulated
as the rating describes them: a short weightless cable (the rig prescribes its shape) clamped at both ends, the clamps
moved through one cycle in ``SAMPLES`` rest solves, each rest state read as the station's simulators read theirs
(:func:`rod.segments.segment_state`), the cycle's fatigue life counted by :func:`fatigue.fatigue_life`. Every figure
in :data:`RATED_TESTS` is a published one, with the page it is read from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..cable.config import DresspackConfig, FatigueConfig
from ..errors import ConfigError
from ..rod.model import RodModel
from ..rod.rod import Rod
from ..rod.segments import segment_state
from .fatigue import fatigue_life
from .segment_state import SegmentState

SAMPLES = 8  # rest states per test cycle (straight, bent or twisted both ways, back): its rainflow count is exact
TEST_SEGMENTS = 24  # edges of the test cable
TORSION_LENGTH = 1.0  # [m] twisted length of the torsion test (its rating is per metre)
KINDS = ("bending", "torsion")


@dataclass(frozen=True)
class RatedTest:
    """One published rating: ``kind`` bending (at ``bend_factor`` x OD) or torsion (at +-``twist_deg_per_m``)."""

    name: str
    kind: str
    rated_cycles: float
    source: str  # the page the figures are read from
    bend_factor: float = 0.0  # bend radius / outer diameter
    twist_deg_per_m: float = 0.0

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ConfigError("rated_test.kind", f"must be one of {', '.join(KINDS)}, got {self.kind!r}")


# The published ratings the shipped calibration reproduces (docs/wear.md "Calibrated life"): a robot cable's bending
# rating and a torsion cable's torsion rating, both of fine-stranded (IEC 60228 class 5/6) copper conductors.
RATED_TESTS = (
    RatedTest("RST-OR robot cable, bending at 4 x OD", "bending", 5.0e6,
              "https://www.rstlkable.com/product/pur-robot-cable-for-robotics-and-automation-with-oil-and-abrasion-"
              "resistant-high-flex-design/", bend_factor=4.0),
    RatedTest("HELUKABEL WK loop cable, torsion at +-150 deg/m", "torsion", 1.8e4,
              "https://www.ke-next.de/automation/elektrotechnik/was-muss-ein-windenergie-kabel-aushalten-291.html"
              "?page=4", twist_deg_per_m=150.0),
)


def _straight(length: float, n: int) -> np.ndarray:
    pts = np.zeros((n + 1, 3))
    pts[:, 0] = np.linspace(0.0, length, n + 1)
    return pts


def _arc(radius: float, h: float, n: int) -> np.ndarray:
    """n + 1 vertices h apart (chords) on a circle of ``radius`` in the xz plane, starting at the origin along +x
    and bending towards +z; a straight line for an infinite radius."""
    if not math.isfinite(radius):
        return _straight(n * h, n)
    turn = 2.0 * math.asin(min(h / (2.0 * radius), 1.0))
    phi = turn * np.arange(n + 1) - 0.5 * turn  # edge i's chord is centred on angle (i + 1/2) turn - turn/2
    return np.stack([radius * (np.sin(phi) + math.sin(0.5 * turn)), 0.0 * phi,
                     radius * (1.0 - np.cos(phi)) - radius * (1.0 - math.cos(0.5 * turn))], axis=1)


def _model(dp: DresspackConfig, length: float, spans=()) -> RodModel:
    n = TEST_SEGMENTS
    return RodModel(length, n, dp.linear_density, dp.tensile_stiffness, dp.bending_stiffness,
                    dp.torsional_stiffness, held=(0, 1, n - 1, n), spans=spans, gravity=(0.0, 0.0, 0.0))


def bending_cycle(dp: DresspackConfig, bend_factor: float) -> list[SegmentState]:
    """The rest states of one bending cycle: the cable (a half circle's length at the test radius R = bend_factor x
    its outer diameter) clamped at both ends, the clamps turned from straight to R and back."""
    radius = bend_factor * 2.0 * dp.radius
    n = TEST_SEGMENTS
    model = _model(dp, math.pi * radius)
    h = model.segment_length
    rod = Rod(model, _straight(model.length, n))
    states = []
    for s in np.sin(np.pi * np.arange(SAMPLES) / SAMPLES):  # 0 -> 1 -> 0: straight, bent to R, straight
        pts = _arc(radius / s if s > 1e-12 else math.inf, h, n)
        result = rod.solve_rest(held_pos=pts[list(model.held)], tolerance=1e-8)
        if not result.converged:
            raise RuntimeError(f"bending test: the rest solve at 1/R = {s / radius:.3g} 1/m did not converge")
        states.append(segment_state(rod, None, None))
    return states


def torsion_cycle(dp: DresspackConfig, twist_deg_per_m: float) -> list[SegmentState]:
    """The rest states of one torsion cycle: a straight cable clamped at both ends, the far clamp turned so that the
    span between the clamps twists 0 -> +rate -> 0 -> -rate -> 0 (``twist_deg_per_m``)."""
    n = TEST_SEGMENTS
    span = (0, n - 1)
    model = _model(dp, TORSION_LENGTH, spans=(span,))
    twist_length = model.span_lengths[0]
    near = np.array([0.0, 1.0, 0.0])
    rod = Rod(model, _straight(model.length, n), frames=np.tile(near, (n, 1)),
              clamp_directors=np.array([[near, near]]))
    rate = math.radians(twist_deg_per_m)
    states = []
    for s in np.sin(2.0 * np.pi * np.arange(SAMPLES) / SAMPLES):  # 0, +, 0, -: one full torsion cycle
        angle = s * rate * twist_length
        far = np.array([0.0, math.cos(angle), math.sin(angle)])
        result = rod.solve_rest(clamp_directors=np.array([[near, far]]), tolerance=1e-8)
        if not result.converged:
            raise RuntimeError(f"torsion test: the rest solve at {math.degrees(angle):.1f} deg did not converge")
        states.append(segment_state(rod, None, None))
    return states


def rating_cycle(test: RatedTest, dp: DresspackConfig) -> list[SegmentState]:
    """The simulated rest states of one cycle of ``test`` on ``dp``'s cable."""
    if test.kind == "bending":
        return bending_cycle(dp, test.bend_factor)
    return torsion_cycle(dp, test.twist_deg_per_m)


def cycle_life(states: list[SegmentState], dp: DresspackConfig, fatigue: FatigueConfig) -> float:
    """Cycles to failure of the weakest segment over the repeated test cycle ``states``."""
    arc = np.arange(len(states[0].curvature)) * (TORSION_LENGTH / TEST_SEGMENTS)
    return fatigue_life(states, fatigue, arc, dp.tensile_stiffness).summary()["life_cycles"]


def simulated_life(test: RatedTest, dp: DresspackConfig) -> float:
    """The life ``dp``'s cable and fatigue model give the rated test."""
    return cycle_life(rating_cycle(test, dp), dp, dp.fatigue)


def _radius_for_life(states, dp: DresspackConfig, field: str, rated: float) -> float:
    """The value of radius ``field`` of the fatigue config at which the cycle's life is ``rated`` (bisection on log
    r: the strains grow with r, the life falls)."""
    lo, hi = math.log(1e-7), math.log(0.2)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        life = cycle_life(states, dp, replace(dp.fatigue, **{field: math.exp(mid)}))
        lo, hi = (mid, hi) if life > rated else (lo, mid)
    return math.exp(0.5 * (lo + hi))


def calibrate(dp: DresspackConfig, tests=RATED_TESTS) -> FatigueConfig:
    """``dp``'s fatigue config with ``strain_radius`` fitted to the bending rating and ``torsion_radius`` to the
    torsion rating (one test of each kind; the bending cycle has no twist, the torsion cycle no bend, so each radius
    is fitted on its own test). The strain-life curve itself is kept."""
    fitted = dp.fatigue
    for kind, field in (("bending", "strain_radius"), ("torsion", "torsion_radius")):
        chosen = [t for t in tests if t.kind == kind]
        if len(chosen) != 1:
            raise ConfigError("rated_tests", f"calibration needs exactly one {kind} test, got {len(chosen)}")
        states = rating_cycle(chosen[0], dp)
        fitted = replace(fitted, **{field: _radius_for_life(states, replace(dp, fatigue=fitted), field,
                                                            chosen[0].rated_cycles)})
    return fitted


def calibration_table(dp: DresspackConfig, tests=RATED_TESTS) -> list[dict]:
    """Per rated test: its name, kind, rated and simulated life on ``dp`` (with ``dp``'s own fatigue config), their
    ratio and the source."""
    rows = []
    for t in tests:
        life = simulated_life(t, dp)
        rows.append({"test": t.name, "kind": t.kind, "rated_cycles": t.rated_cycles, "simulated_cycles": life,
                     "ratio": life / t.rated_cycles, "source": t.source})
    return rows
