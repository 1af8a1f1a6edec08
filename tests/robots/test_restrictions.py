"""Joint restrictions against brute-force geometry from the robot's own kinematics (thesis §4.1)."""

import math

import numpy as np
import pytest

from dresspack_gym import ConfigError
from dresspack_gym.io.loading import load_robot
from dresspack_gym.robots.kinematics import RobotKinematics
from dresspack_gym.robots.restrictions import RestrictionSet, SupportClearance, TwistSum, restriction_from_dict

KIN = RobotKinematics(load_robot("abb_irb6700_200_260"))
R, M, L, C, W = 0.13, 0.25, 0.30, 0.05, 0.105  # link-4 radius, support offset, support length, clearance, half width
J5 = np.radians(np.arange(-130, 130.5, 1.0))
J6 = np.radians(np.arange(-180, 180.5, 1.0))


def grid(base=(0.3, -0.2, 0.4, 0.7)):
    j5, j6 = np.meshgrid(J5, J6, indexing="ij")
    q = np.zeros((j5.size, 6))
    q[:, :4] = base
    q[:, 4], q[:, 5] = j5.ravel(), j6.ravel()
    return q


def brute_force_forbidden(q, p, shape):
    """Tip of the support from the full FK chain, expressed in link 4's frame at the wrist centre."""
    support = np.array([M, -L * math.sin(p), L * math.cos(p), 1.0])
    out = np.zeros(len(q), dtype=bool)
    for i, qi in enumerate(q):
        frames = KIN.link_frames(qi)
        tip_world = frames[6] @ support
        local = np.linalg.solve(frames[4], tip_world)[:3] - np.array([KIN.k.d4, 0.0, 0.0])
        behind = local[0] < 0
        if shape == "cylinder":
            out[i] = behind and math.hypot(local[1], local[2]) < R + C
        else:
            out[i] = behind and abs(local[1]) < W + C and abs(local[2]) < R + C
    return out


def distance_to_boundary_deg(rule, q):
    centre, half = rule.forbidden_interval(q[:, 5])
    off = np.abs((q[:, 4] - centre + np.pi) % (2 * np.pi) - np.pi)
    return np.degrees(np.abs(off - half))


@pytest.mark.parametrize("shape", ["cylinder", "cuboid"])
@pytest.mark.parametrize("p_deg", [-45, 0, 30, 90, 180])
def test_exact_support_rule_matches_brute_force(shape, p_deg):
    p = math.radians(p_deg)
    q = grid()[::3]  # every third grid point keeps the FK loop quick (~31k points per case)
    rule = SupportClearance(R, M, L, C, p, shape, W if shape == "cuboid" else math.inf, "exact")
    analytic = ~rule.allowed(q)
    brute = brute_force_forbidden(q, p, shape)
    agree = np.mean(analytic == brute)
    assert agree >= 0.99
    assert brute.any() or p_deg in (90,)  # the rule does restrict something for most mountings
    disagree = analytic != brute
    if disagree.any():
        assert distance_to_boundary_deg(rule, q[disagree]).max() < 1e-6  # only exactly on the boundary


@pytest.mark.parametrize("p_deg", [-45, 0, 30])
def test_thesis_closed_forms_agree_at_zero_twist_and_mostly_elsewhere(p_deg):
    """(4.3)/(4.4) with phi = j6 + p equal the exact rule where the support lies in the j5 plane."""
    p = math.radians(p_deg)
    exact = SupportClearance(R, M, L, C, p, "cylinder", math.inf, "exact")
    thesis = SupportClearance(R, M, L, C, p, "cylinder", math.inf, "thesis")
    in_plane = np.array([-p, math.pi - p])
    for j6 in in_plane:
        ce, he = exact.forbidden_interval(np.array([j6]))
        ct, ht = thesis.forbidden_interval(np.array([j6]))
        np.testing.assert_allclose([ce[0], he[0]], [ct[0], ht[0]], atol=1e-12)
    q = grid()
    assert np.mean(exact.allowed(q) == thesis.allowed(q)) > 0.95


def test_zones_give_lower_bound_in_a_and_upper_bound_in_b():
    rule = SupportClearance(R, M, L, C, math.radians(-45), "cylinder")
    j6_a = np.array([math.radians(45.0)])  # cos(j6 + p) = 1: zone A
    j6_b = np.array([math.radians(225.0 - 360.0)])  # cos = -1: zone B
    lo_a, hi_a = rule.j5_bounds(j6_a)
    lo_b, hi_b = rule.j5_bounds(j6_b)
    # zone A: only a lower bound matters inside the joint range, zone B: only an upper bound
    assert -math.radians(130) < lo_a[0] < 0 and hi_a[0] > math.radians(130) or hi_a[0] < lo_a[0]
    assert 0 < hi_b[0] < math.radians(130)
    h = math.hypot(M, L)
    thesis_fa = -math.acos(L / h) - math.acos((R + C) / h)  # eq. (4.3) at cos(j6 + p) = 1
    assert lo_a[0] == pytest.approx(thesis_fa, abs=1e-12)
    assert hi_b[0] == pytest.approx(-thesis_fa, abs=1e-12)  # eq. (4.4), symmetric


def test_twist_sum_rules():
    q = np.zeros((3, 6))
    q[:, 3] = np.radians([100, 200, -200])
    q[:, 5] = np.radians([100, 100, -100])
    assert TwistSum(-math.radians(270), math.radians(270)).allowed(q).tolist() == [True, False, False]
    assert TwistSum(lower=math.radians(90)).allowed(q).tolist() == [True, True, False]


def test_restriction_set_composes_and_reports():
    rules = RestrictionSet.from_list([
        {"type": "twist_sum", "lower_deg": 90},
        {"type": "support_cylinder", "r": R, "m": M, "l": L, "c": C, "p_deg": -45},
    ])
    q = np.zeros((2, 6))
    q[0, [3, 5]] = math.radians(180)
    q[1, [3, 5]] = math.radians(180)
    q[1, 4] = rules.rules[1].j5_bounds(np.array([q[1, 5]]))[0][0] - 0.01  # just inside the forbidden zone
    ok = rules.allowed(q)
    single = rules.rules[0].allowed(q) & rules.rules[1].allowed(q)
    assert ok.tolist() == single.tolist()
    assert any("support" in d for d in rules.violated_by(q[1])) or ok[1]


def test_bad_restriction_configs_name_the_field():
    with pytest.raises(ConfigError) as e:
        restriction_from_dict({"type": "twist"}, "robots[0].restrictions[0]")
    assert e.value.field == "robots[0].restrictions[0].type"
    with pytest.raises(ConfigError) as e:
        restriction_from_dict({"type": "support_cylinder", "r": 0.1, "m": 0.2, "l": 0.3, "p_deg": 0, "q": 1}, "x")
    assert e.value.field == "x.q"
    with pytest.raises(ConfigError):
        restriction_from_dict({"type": "twist_sum"}, "x")


def test_vectorised_rule_is_cheap():
    """Not a timing test: the rule is pure numpy over the batch (no per-configuration Python)."""
    q = np.random.default_rng(0).uniform(-3, 3, size=(100_000, 6))
    rules = RestrictionSet.from_list([{"type": "twist_sum", "abs_max_deg": 270},
                                      {"type": "support_cuboid", "r": R, "half_width": W, "m": M, "l": L,
                                       "p_deg": 30}])
    assert rules.allowed(q).shape == (100_000,)
