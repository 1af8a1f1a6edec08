"""Fatigue life of every cable segment over one station cycle: conductor strain histories, rainflow cycle
counting (ASTM E1049, the ``rainflow`` package), a Coffin-Manson-Basquin strain-life curve and Miner's rule.

Strains (dresspack YAML ``fatigue:``, see config.FatigueConfig): at N_FIBRES points around a conductor of radius
r (``strain_radius``) the normal strain is r (kappa_1 sin phi - kappa_2 cos phi) + axial strain, with (kappa_1,
kappa_2) the curvature in the material frame, so a fibre keeps its identity while the cable bends and twists; the
shear strain r_t * twist rate (r_t: ``torsion_radius``, default r) is counted as its von Mises equivalent. Per
segment, the damage per cycle is the worst fibre's normal-strain damage plus the shear damage (Miner), and the life
is its inverse. A model: the curve and the radii are calibrated on rated tests (ratings.py) or assumed (see the
docs); the cycle counting and Miner's sum are exact for the strains given.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import rainflow

from ..cable.config import FatigueConfig
from .segment_state import SegmentState

N_FIBRES = 16  # points around the conductor: the worst lies within 11 deg of the bending plane (cos = 0.98)
MAX_LIFE = 1e15  # [cycles] a strain amplitude this small is reported as this life (no endurance limit assumed)


def strain_amplitude(cycles, config: FatigueConfig):
    """eps_a(N) = s' (2N)^b + e' (2N)^c: the strain amplitude that fails after N cycles."""
    two_n = 2.0 * np.asarray(cycles, dtype=float)
    return config.sigma_f_over_e * two_n ** config.b + config.eps_f * two_n ** config.c


def cycles_to_failure(amplitude, config: FatigueConfig) -> np.ndarray:
    """N_f for each strain amplitude: the inverse of :func:`strain_amplitude` (bisection on log N, to 1e-9 in
    log10), MAX_LIFE where the amplitude is below the curve at MAX_LIFE, 0.5 above its value at N = 1/2."""
    a = np.atleast_1d(np.asarray(amplitude, dtype=float))
    lo = np.full(a.shape, np.log10(0.5))
    hi = np.full(a.shape, np.log10(MAX_LIFE))
    for _ in range(60):  # eps_a decreases with N: keep eps_a(lo) >= a >= eps_a(hi)
        mid = 0.5 * (lo + hi)
        above = strain_amplitude(10.0 ** mid, config) > a
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    n = 10.0 ** (0.5 * (lo + hi))
    n = np.where(a <= strain_amplitude(MAX_LIFE, config), MAX_LIFE, n)
    return np.where(a >= strain_amplitude(0.5, config), 0.5, n)


def count_cycles(history) -> list[tuple[float, float]]:
    """(amplitude, count) of the cycles in one period of a repeating strain history (rainflow, ASTM E1049).

    The history is started at its largest absolute value and closed there, so a repeated station cycle has only
    full cycles (no residual half cycles that a one-off count would leave)."""
    x = np.asarray(history, dtype=float)
    if len(x) < 2 or np.ptp(x) == 0.0:
        return []
    k = int(np.argmax(np.abs(x - x.mean())))
    x = np.concatenate([x[k:], x[:k], x[k:k + 1]])
    return [(rng / 2.0, count) for rng, _, count, _, _ in rainflow.extract_cycles(x)]


def miner_damage(history, config: FatigueConfig) -> float:
    """Damage per period of a strain history: the sum of count / N_f(amplitude) over its rainflow cycles."""
    cycles = count_cycles(history)
    if not cycles:
        return 0.0
    amp, count = np.array(cycles).T
    return float(np.sum(count / cycles_to_failure(amp, config)))


@dataclass(frozen=True)
class FatigueLife:
    """Damage per station cycle and cycles to failure, per segment (vertex)."""

    arc: np.ndarray  # [m]
    damage_per_cycle: np.ndarray  # Miner sum per station cycle, normal + shear
    normal: np.ndarray  # of which from normal strain (worst fibre)
    shear: np.ndarray  # of which from torsional shear
    max_strain_amplitude: np.ndarray  # largest normal-strain cycle amplitude seen by the segment
    weakest_cause: str = ""  # what fails the weakest segment: "bending", "stretch" or "twist" ("" if nothing does)
    weakest_amplitude: float = 0.0  # the largest strain amplitude of that cause there (shear as gamma / sqrt 3)

    @property
    def life_cycles(self) -> np.ndarray:
        with np.errstate(divide="ignore"):
            return np.minimum(np.where(self.damage_per_cycle > 0, 1.0 / self.damage_per_cycle, MAX_LIFE), MAX_LIFE)

    @property
    def weakest_segment(self) -> int:
        return int(np.argmax(self.damage_per_cycle))

    def summary(self) -> dict:
        i = self.weakest_segment
        return {"life_cycles": float(self.life_cycles[i]), "weakest_segment_m": float(self.arc[i]),
                "max_strain_amplitude": float(self.max_strain_amplitude.max(initial=0.0)),
                "weakest_cause": self.weakest_cause, "weakest_strain_amplitude": self.weakest_amplitude}


def fibre_strains(states: list[SegmentState], config: FatigueConfig, axial_scale: float = 1.0) -> np.ndarray:
    """(T, n, N_FIBRES) normal strain at the fibres of every segment over time; the cable's axial strain is scaled
    by ``axial_scale`` (the bundle's EA over the conductors' axial stiffness)."""
    phi = 2.0 * np.pi * np.arange(N_FIBRES) / N_FIBRES
    bend = np.array([s.bend for s in states])  # (T, n, 2)
    axial = axial_scale * np.array([s.strain for s in states])  # (T, n)
    r = config.strain_radius
    return r * (bend[..., 0:1] * np.sin(phi) - bend[..., 1:2] * np.cos(phi)) + axial[..., None]


@lru_cache(maxsize=16)
def _curve_table(config: FatigueConfig) -> tuple[np.ndarray, np.ndarray]:
    """(log10 amplitude, log10 N) of the strain-life curve on 4,000 lives from N = 1/2 to MAX_LIFE, amplitudes
    increasing: :func:`cycles_to_failure` interpolated (log N is smooth in log amplitude: within 1e-6 relative),
    for the excursion damage every measured state needs, where the bisection cost more than the state's measures."""
    log_n = np.linspace(np.log10(0.5), np.log10(MAX_LIFE), 4000)
    log_a = np.log10(strain_amplitude(10.0 ** log_n, config))
    return log_a[::-1].copy(), log_n[::-1].copy()


def excursion_damage(state: SegmentState, config: FatigueConfig, tensile_stiffness: float | None = None) -> float:
    """The worst segment's fatigue damage (Miner) of one excursion from unstrained to ``state`` and back: its
    outermost fibre's normal strain cycle of amplitude (r kappa + axial strain) / 2 plus its shear cycle of amplitude
    r_t |twist rate| / (2 sqrt 3). A state's own measure of how much life being there uses (the life cost variant);
    the life of a whole cycle is :func:`fatigue_life`'s rainflow count."""
    scale = 1.0
    if config.axial_stiffness is not None and tensile_stiffness is not None:
        scale = tensile_stiffness / config.axial_stiffness
    normal = 0.5 * (config.strain_radius * state.curvature + scale * np.abs(state.strain))
    shear = 0.5 * config.shear_radius * np.abs(state.twist_rate) / np.sqrt(3.0)
    n = len(normal)
    log_a, log_n = _curve_table(config)
    amp = np.concatenate([normal, shear])
    with np.errstate(divide="ignore"):  # an unstrained segment: log 0 = -inf, below the table: MAX_LIFE
        life = 10.0 ** np.interp(np.log10(amp), log_a, log_n)
    damage = np.where(life < MAX_LIFE, 1.0 / life, 0.0)
    return float(np.max(damage[:n] + damage[n:], initial=0.0))


def peak_excursion_damage(curvature: float, twist_rate: float, tension: float, dresspack) -> float:
    """:func:`excursion_damage` of a cable known by its peak measures only (a wear map's prediction): the peaks
    taken at one segment, which bounds the damage of the segments where they lie apart."""
    one = np.array([0.0])
    state = SegmentState(np.array([curvature]), np.zeros((1, 2)), np.array([twist_rate]),
                         np.array([tension / dresspack.tensile_stiffness]), one, one, one)
    return excursion_damage(state, dresspack.fatigue, dresspack.tensile_stiffness)


def fatigue_life(states: list[SegmentState], config: FatigueConfig, arc: np.ndarray,
                 tensile_stiffness: float | None = None) -> FatigueLife:
    """Per-segment fatigue life of the station cycle sampled by ``states`` (one period of the repeated cycle);
    ``tensile_stiffness`` is the dresspack's EA the states' strains were computed with."""
    scale = 1.0
    if config.axial_stiffness is not None and tensile_stiffness is not None:
        scale = tensile_stiffness / config.axial_stiffness
    eps = fibre_strains(states, config, scale)
    shear = config.shear_radius * np.array([s.twist_rate for s in states]) / np.sqrt(3.0)  # (T, n)
    n = eps.shape[1]
    # every fibre's and every segment's rainflow cycles first, then all their lives in one batched inversion (the
    # bisection is elementwise; per fibre it was most of an episode end's time)
    fibre = [[count_cycles(eps[:, i, f]) for f in range(N_FIBRES)] for i in range(n)]
    twist = [count_cycles(shear[:, i]) for i in range(n)]
    cycles = [c for per_segment in fibre for per_fibre in per_segment for c in per_fibre] + \
        [c for per_segment in twist for c in per_segment]
    if not cycles:
        return FatigueLife(np.asarray(arc, dtype=float), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n))
    a, c = np.array(cycles).T
    damage = c / cycles_to_failure(a, config)
    normal, tors, amp = np.zeros(n), np.zeros(n), np.zeros(n)
    k = 0
    for i in range(n):
        for per_fibre in fibre[i]:
            if per_fibre:
                normal[i] = max(normal[i], float(np.sum(damage[k:k + len(per_fibre)])))
                amp[i] = max(amp[i], float(a[k:k + len(per_fibre)].max()))
                k += len(per_fibre)
    for i in range(n):
        tors[i] = float(np.sum(damage[k:k + len(twist[i])]))
        k += len(twist[i])
    cause, amplitude = _cause(states, config, scale, int(np.argmax(normal + tors)), shear)
    return FatigueLife(np.asarray(arc, dtype=float), normal + tors, normal, tors, amp, cause, amplitude)


def _cause(states: list[SegmentState], config: FatigueConfig, axial_scale: float, i: int,
           shear: np.ndarray) -> tuple[str, float]:
    """(cause, strain amplitude) of segment ``i``'s fatigue: of its bending alone (worst fibre, no axial strain), its
    axial strain alone and its shear, the one whose Miner damage is largest, and the largest cycle amplitude of it."""
    phi = 2.0 * np.pi * np.arange(N_FIBRES) / N_FIBRES
    bend = np.array([s.bend[i] for s in states])  # (T, 2)
    fibres = config.strain_radius * (bend[:, 0:1] * np.sin(phi) - bend[:, 1:2] * np.cos(phi))
    histories = {"bending": [fibres[:, f] for f in range(N_FIBRES)],
                 "stretch": [axial_scale * np.array([s.strain[i] for s in states])], "twist": [shear[:, i]]}
    best, best_damage, best_amp = "", 0.0, 0.0
    for name, hs in histories.items():
        damages = [miner_damage(h, config) for h in hs]
        j = int(np.argmax(damages))
        if damages[j] > best_damage:
            cycles = count_cycles(hs[j])
            best, best_damage, best_amp = name, damages[j], max(a for a, _ in cycles)
    return best, float(best_amp)
