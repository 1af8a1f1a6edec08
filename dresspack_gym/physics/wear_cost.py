"""The cable wear cost of thesis eq. (4.10) term by term, its normalised variant (thesis §5.3), the named variants."""

from __future__ import annotations

from dataclasses import dataclass

from ..fields import check_choice
from ..stations.config import WearCostConfig
from .measures import WearMeasures


@dataclass(frozen=True)
class WearCost:
    """C = C_kappa + C_F + C_d (+ the optional twist term C_t) for one configuration; the damage and life variants'
    C is their ``damage`` term alone."""

    curvature: float
    tension: float
    distance: float
    twist: float = 0.0
    damage: float = 0.0

    @property
    def total(self) -> float:
        return self.curvature + self.tension + self.distance + self.twist + self.damage

    def terms(self) -> dict[str, float]:
        return {"curvature": self.curvature, "tension": self.tension, "distance": self.distance, "twist": self.twist,
                "damage": self.damage}


def wear_cost(m: WearMeasures, cfg: WearCostConfig) -> WearCost:
    """Eq. (4.10): w_k max(0, k - k0)^2 + w_F F^2 + w_d min(0, d - c)^2, plus w_t max(0, tau - tau0)^2."""
    return WearCost(
        curvature=cfg.w_curvature * max(0.0, m.max_curvature - cfg.curvature_threshold) ** 2,
        tension=cfg.w_tension * m.max_tension ** 2,
        distance=cfg.w_distance * min(0.0, m.min_clearance - cfg.clearance) ** 2,
        twist=cfg.w_twist * max(0.0, m.max_twist_rate - cfg.twist_threshold) ** 2,
    )


def normalized_wear_cost(m: WearMeasures, cfg: WearCostConfig) -> WearCost:
    """Eq. (4.10) on dimensionless measures: each excess is divided by its reference scale.

    With equal weights each term is 1 when its measure is one scale past its threshold (e.g. curvature
    kappa0 + 8 1/m, tension 100 N, clearance 0.1 m inside c), so the three causes weigh about equally
    under the default ``normalized_weights`` (1, 1, 1).
    """
    wk, wf, wd = cfg.normalized_weights
    return WearCost(
        curvature=wk * (max(0.0, m.max_curvature - cfg.curvature_threshold) / cfg.curvature_scale) ** 2,
        tension=wf * (m.max_tension / cfg.tension_scale) ** 2,
        distance=wd * (min(0.0, m.min_clearance - cfg.clearance) / cfg.clearance_scale) ** 2,
        twist=cfg.normalized_twist_weight * (max(0.0, m.max_twist_rate - cfg.twist_threshold) / cfg.twist_scale) ** 2,
    )


def damage_cost(m: WearMeasures, cfg: WearCostConfig) -> WearCost:
    """The damage variant: C = the worst segment's damage rate (dresspack ``damage:`` weights), so that the
    integral of C over a motion is the damage the worst segment accrues (value terms; see damage.damage_rate)."""
    return WearCost(0.0, 0.0, 0.0, 0.0, damage=m.max_damage_rate)


def life_cost(m: WearMeasures, cfg: WearCostConfig) -> WearCost:
    """The life variant: C = w_life x the worst segment's fatigue damage of one excursion to this state (the
    dresspack's calibrated strain-life model, fatigue.excursion_damage), so that ∫C dt charges how much cable life
    the motion's states use and for how long, traded against cycle time like the other variants."""
    return WearCost(0.0, 0.0, 0.0, 0.0, damage=cfg.w_life * m.excursion_damage)


# The named wear-cost variants (eq. 4.10, its normalised form, per-segment damage, fatigue life), chosen by name in
# one place.
COST_VARIANTS = {"thesis": wear_cost, "normalized": normalized_wear_cost, "damage": damage_cost, "life": life_cost}


def cost_function(variant: str, field: str = "cost_variant"):
    """``(measures, WearCostConfig) -> WearCost`` of the variant; a ConfigError names the field otherwise."""
    return COST_VARIANTS[check_choice(field, variant, COST_VARIANTS)]
