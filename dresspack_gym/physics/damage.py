"""Per-segment damage accumulated along a trajectory (the AGX CableDamage terms: bend, twist and stretch as
deformation, as moment/force and as rate of change, plus contact normal force and sliding friction).

Damage of term k on segment i = w_k * integral of x_k,i dt for the value terms (trapezoid over the samples) and
w_k * (total variation of x_k,i) for the rate terms (the integral of |dx/dt| dt, exact whatever the sampling, and
defined across a settle, where the cable moves while the robot's motion time stands still). A relative measure
whose weights come from the dresspack YAML (``damage:``); :mod:`fatigue` turns the strains into a life.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import reduce

import numpy as np

from ..cable.config import DAMAGE_TERMS, DamageWeights, DresspackConfig
from .fatigue import excursion_damage
from .segment_state import SegmentState


def term_values(states: list[SegmentState], dresspack: DresspackConfig) -> dict[str, np.ndarray]:
    """Every damage quantity, (T, n_vertices) each: value terms as they are, rate terms as the quantity whose
    change is counted."""
    return _terms(np.array([s.curvature for s in states]), np.array([s.twist_rate for s in states]),
                  np.array([s.strain for s in states]), np.array([s.normal_force for s in states]),
                  np.array([s.friction_power for s in states]), dresspack)


def _terms(kappa, twist_rate, strain, normal, friction_power, dresspack: DresspackConfig) -> dict[str, np.ndarray]:
    """:func:`term_values` of the stacked quantities (any shape: one state's too)."""
    twist = np.abs(twist_rate)
    return {
        "bend": kappa,
        "bend_moment": dresspack.bending_stiffness * kappa,
        "bend_rate": kappa,
        "twist": twist,
        "twist_torque": dresspack.torsional_stiffness * twist,
        "twist_rate": twist_rate,
        "stretch": np.abs(strain),
        "tension": dresspack.tensile_stiffness * np.abs(strain),
        "stretch_rate": strain,
        "contact_normal": normal,
        "friction": friction_power,
    }


RATE_TERMS = ("bend_rate", "twist_rate", "stretch_rate")
VALUE_TERMS = tuple(k for k in DAMAGE_TERMS if k not in RATE_TERMS)


def damage_rate(state: SegmentState, dresspack: DresspackConfig) -> np.ndarray:
    """(n,) damage per second each segment accrues in this state: the weighted value terms (the rate terms need
    a history and are left out). Its integral over a motion is the value-term part of :func:`accumulate`."""
    values = _terms(state.curvature, state.twist_rate, state.strain, state.normal_force, state.friction_power,
                    dresspack)
    w = dresspack.damage
    # summed term after term, as np.sum(..., axis=0) of the stacked terms does; a term of weight 0 adds +0 to
    # every segment (all terms are >= 0), so it is left out
    weighted = [getattr(w, k) * values[k] for k in VALUE_TERMS if getattr(w, k) != 0.0]
    return reduce(np.add, weighted) if weighted else np.zeros_like(state.curvature)


def worst_rates(state: SegmentState, dresspack: DresspackConfig) -> dict[str, float]:
    """The per-state damage fields of a cable's WearMeasures, as both engines fill them from their segment states:
    the worst segment's damage rate and where it is, and the worst segment's fatigue damage of one excursion."""
    rate = damage_rate(state, dresspack)
    k = int(np.argmax(rate))
    return {"max_damage_rate": float(rate[k]), "damage_at": k * dresspack.segment_length,
            "excursion_damage": excursion_damage(state, dresspack.fatigue, dresspack.tensile_stiffness)}


@dataclass(frozen=True)
class SegmentDamage:
    """Accumulated damage per term and segment, and its time course."""

    arc: np.ndarray  # (n,) arc length of each segment's vertex [m]
    times: np.ndarray  # (T,) sample times [s]
    terms: dict[str, np.ndarray]  # term -> (n,) weighted damage accumulated over the trajectory
    strip: np.ndarray  # (T - 1, n) damage added in each sample interval (all terms): the damage strip

    @property
    def total(self) -> np.ndarray:
        """(n,) damage per segment, all terms."""
        return np.sum(list(self.terms.values()), axis=0)

    @property
    def worst_segment(self) -> int:
        return int(np.argmax(self.total))

    def summary(self) -> dict:
        total = self.total
        i = self.worst_segment
        return {"damage": float(total[i]), "damage_at_m": float(self.arc[i]),
                "damage_terms": {k: float(v[i]) for k, v in self.terms.items()}}


def accumulate(times, states: list[SegmentState], dresspack: DresspackConfig,
               weights: DamageWeights | None = None) -> SegmentDamage:
    """Damage of the samples ``states`` taken at ``times`` (non-decreasing; equal times = a settle)."""
    times = np.asarray(times, dtype=float)
    if len(times) != len(states) or len(states) < 1:
        raise ValueError(f"need one state per time: {len(times)} times, {len(states)} states")
    if np.any(np.diff(times) < 0):
        raise ValueError("sample times must not decrease")
    w = dresspack.damage if weights is None else weights
    values = term_values(states, dresspack)
    dt = np.diff(times)[:, None]
    n = states[0].curvature.shape[0]
    strip = np.zeros((max(len(times) - 1, 0), n))
    terms = {}
    for k in DAMAGE_TERMS:
        x = values[k]
        added = np.abs(np.diff(x, axis=0)) if k in RATE_TERMS else 0.5 * (x[1:] + x[:-1]) * dt
        added = getattr(w, k) * added
        strip += added
        terms[k] = added.sum(axis=0) if len(added) else np.zeros(n)
    h = dresspack.segment_length
    return SegmentDamage(np.arange(n) * h, times, terms, strip)

