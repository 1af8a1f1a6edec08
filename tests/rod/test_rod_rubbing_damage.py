"""The damage model's contact terms respond to rubbing: a cable whose tip rests on an arm link (a capsule) accrues
contact-normal damage where it touches, and friction damage there only while it slides, in proportion to how fast."""

from dataclasses import replace

import numpy as np
import pytest

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.damage import accumulate
from dresspack_gym.rod.model import RodModel
from dresspack_gym.rod.rod import Rod
from dresspack_gym.rod.scene import CAPSULE, ContactSettings, Primitives
from dresspack_gym.rod.segments import segment_state

N, LENGTH, SLOPE, LINK_RADIUS = 12, 0.5, np.radians(30), 0.05
H = 0.02  # [s] step


def resting_on_a_link():
    """A stiff cable clamped at its top end, pointing down at 30 deg onto a horizontal arm link (a capsule along y)
    that carries its tip; (rod, link)."""
    contact = ContactSettings()
    model = RodModel(LENGTH, N, 0.5, 1e4, 1.0, 1.0, held=(0, 1))
    way = np.array([np.cos(SLOPE), 0.0, -np.sin(SLOPE)])
    top = np.array([0.0, 0.0, 0.01 + 0.8 * contact.activation + LENGTH * np.sin(SLOPE)])
    rod = Rod(model, top + np.linspace(0, LENGTH, N + 1)[:, None] * way, radius=0.01, contact=contact)
    tip_x = LENGTH * np.cos(SLOPE)
    rot = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])  # local z (the link's axis) along world y
    link = Primitives(np.array([CAPSULE]), np.array([[tip_x, 0.0, -LINK_RADIUS]]), rot[None],
                      np.array([[LINK_RADIUS, 0.5, 0.0]]), np.ones((N, 1), bool))
    assert rod.solve_rest(primitives=link, tolerance=1e-6).converged
    return rod, link


def rub(speed: float, steps: int = 30):
    """The clamp drags the cable along the link's axis at ``speed`` [m/s]: the states of every step."""
    rod, link = resting_on_a_link()
    states = [segment_state(rod, None, None)]
    held = rod.x[list(rod.model.held)].copy()
    for _ in range(steps):
        previous = rod.x.copy()
        held = held + [0.0, speed * H, 0.0]
        assert rod.step(held, H, tolerance=1e-6, primitives=link).converged
        states.append(segment_state(rod, previous, H))
    return states


DRESSPACK = replace(load_station("default").robots[0].dresspack, segments=N, length=LENGTH)  # its damage weights


def damage(states):
    return accumulate(np.arange(len(states)) * H, states, DRESSPACK)


def test_rubbing_on_an_arm_link_adds_friction_damage_where_the_cable_touches_in_proportion_to_speed():
    still = damage(rub(0.0))
    slow, fast = rub(0.05), rub(0.1)
    touching = np.flatnonzero(slow[-1].normal_force > 0)
    assert touching.tolist() == [N]  # the tip rests on the link
    assert slow[-1].slip_speed[N] == pytest.approx(0.05, rel=0.05)
    d_slow, d_fast = damage(slow), damage(fast)
    for d in (still, d_slow, d_fast):
        assert d.terms["contact_normal"][N] > 0 and not d.terms["contact_normal"][:N].any()
    # pressing without rubbing wears nothing by friction; rubbing does, only at the tip, ∝ mu N v
    assert d_slow.terms["friction"][N] > 0 and not d_slow.terms["friction"][:N].any()
    assert still.terms["friction"].max() < 1e-12 * d_slow.terms["friction"][N]  # float dust of a still contact
    assert d_fast.terms["friction"][N] > d_slow.terms["friction"][N]
    # sliding steadily (after the tip first sticks and is dragged), twice the speed rubs at twice the power mu N v
    assert fast[-1].friction_power[N] == pytest.approx(2 * slow[-1].friction_power[N], rel=0.1)
    w = DRESSPACK.damage.friction
    power = [s.friction_force[N] * s.slip_speed[N] for s in slow]
    assert d_slow.terms["friction"][N] == pytest.approx(w * np.trapezoid(power, dx=H), rel=1e-9)
