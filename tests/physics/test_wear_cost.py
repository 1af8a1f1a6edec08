"""Wear cost (4.10) term by term and its normalised variant."""

import pytest

from dresspack_gym.physics.measures import WearMeasures
from dresspack_gym.physics.wear_cost import normalized_wear_cost, wear_cost
from dresspack_gym.stations.config import WearCostConfig

THESIS = WearCostConfig()  # w_k = 1, k0 = 8, w_F = 1e-5, w_d = 100, c = 1


def measures(k=0.0, f=0.0, d=5.0):
    return WearMeasures(max_curvature=k, max_tension=f, min_clearance=d, max_twist_rate=0.0)


def test_each_term_follows_equation_4_10():
    c = wear_cost(measures(k=10.0, f=450.0, d=0.4), THESIS)
    assert c.curvature == pytest.approx(1.0 * (10.0 - 8.0) ** 2)
    assert c.tension == pytest.approx(1e-5 * 450.0 ** 2)
    assert c.distance == pytest.approx(100.0 * (0.4 - 1.0) ** 2)
    assert c.total == pytest.approx(c.curvature + c.tension + c.distance)


def test_thresholds_give_zero_cost():
    c = wear_cost(measures(k=7.9, f=0.0, d=1.2), THESIS)
    assert c.total == 0.0


def test_distance_cost_is_bounded_by_w_d_c_squared():
    assert wear_cost(measures(d=0.0), THESIS).distance == pytest.approx(100.0)


def test_normalized_terms_are_one_at_one_scale_past_threshold():
    cfg = WearCostConfig()
    c = normalized_wear_cost(measures(k=8.0 + cfg.curvature_scale, f=cfg.tension_scale,
                                      d=cfg.clearance - cfg.clearance_scale), cfg)
    assert c.curvature == pytest.approx(1.0)
    assert c.tension == pytest.approx(1.0)
    assert c.distance == pytest.approx(1.0)


def test_worst_over_cables():
    a = WearMeasures(5.0, 10.0, 0.3, 1.0, nearest_obstacle="a")
    b = WearMeasures(9.0, 2.0, 0.6, 0.5, nearest_obstacle="b")
    w = WearMeasures.worst([a, b])
    assert (w.max_curvature, w.max_tension, w.min_clearance, w.max_twist_rate) == (9.0, 10.0, 0.3, 1.0)
    assert w.nearest_obstacle == "a"


def test_twist_term_is_optional_and_follows_its_threshold():
    tw = WearMeasures(max_curvature=0.0, max_tension=0.0, min_clearance=5.0, max_twist_rate=5.0)
    assert wear_cost(tw, THESIS).twist == 0.0  # off by default: the thesis cost has no twist
    cfg = WearCostConfig(w_twist=2.0, twist_threshold=3.0, normalized_twist_weight=1.0, twist_scale=1.0)
    c = wear_cost(tw, cfg)
    assert c.twist == pytest.approx(2.0 * (5.0 - 3.0) ** 2)
    assert c.total == pytest.approx(c.twist) and c.terms()["twist"] == c.twist
    assert normalized_wear_cost(tw, cfg).twist == pytest.approx(((5.0 - 3.0) / 1.0) ** 2)
    below = WearMeasures(max_curvature=0.0, max_tension=0.0, min_clearance=5.0, max_twist_rate=2.9)
    assert wear_cost(below, cfg).twist == 0.0


def test_worst_over_cables_takes_twist_and_node_loads():
    a = WearMeasures(5.0, 10.0, 0.3, 1.0, total_twist=2.0, max_compression=0.5, max_node_force=30.0,
                     max_node_torque=1.0)
    b = WearMeasures(9.0, 2.0, 0.6, 3.0, total_twist=1.0, max_compression=1.5, max_node_force=10.0,
                     max_node_torque=4.0)
    w = WearMeasures.worst([a, b])
    assert (w.max_twist_rate, w.total_twist, w.max_compression, w.max_node_force, w.max_node_torque) == \
        (3.0, 2.0, 1.5, 30.0, 4.0)
