"""What a rod may touch: the primitives' kinds, poses and sizes, and the barrier's settings."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .contact.primitives import BOX, CAPSULE, CYLINDER, PLANE, SPHERE  # noqa: F401 (the kinds, re-exported)


@dataclass(frozen=True)
class ContactSettings:
    """Barrier contact: it acts below ``activation`` [m] of gap with stiffness ``stiffness`` [J/m^2] (a resting
    cable's gap is a fraction of the activation); Coulomb friction ``friction`` smoothed below ``slip`` [m] of
    tangential displacement per step."""

    activation: float = 2e-3
    stiffness: float = 1e4
    friction: float = 0.5
    slip: float = 1e-4


@dataclass(frozen=True)
class Primitives:
    """Primitives at one instant: ``kind`` (k,), ``pos`` (k, 3), ``rot`` (k, 3, 3) world, ``size`` (k, 3), and which
    cable edges may touch which (``mask`` (n_edges, k))."""

    kind: np.ndarray
    pos: np.ndarray
    rot: np.ndarray
    size: np.ndarray
    mask: np.ndarray

    @staticmethod
    def none(n_edges: int) -> "Primitives":
        return Primitives(np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((0, 3)),
                          np.zeros((n_edges, 0), dtype=np.bool_))

    def __len__(self) -> int:
        return len(self.kind)
