"""The named wear-cost variants (thesis eq. 4.10, its normalised form, and per-segment damage), chosen by name in
one place."""

from __future__ import annotations

from .validation import check_choice
from .wear_cost import damage_cost, normalized_wear_cost, wear_cost

COST_VARIANTS = {"thesis": wear_cost, "normalized": normalized_wear_cost, "damage": damage_cost}


def cost_function(variant: str, field: str = "cost_variant"):
    """``(measures, WearCostConfig) -> WearCost`` of the variant; a ConfigError names the field otherwise."""
    return COST_VARIANTS[check_choice(field, variant, COST_VARIANTS)]
