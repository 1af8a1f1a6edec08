"""Shapes the rod engine's contact tests share: every primitive kind, a size for each, random rotations."""

from __future__ import annotations

import numpy as np

from dresspack_gym.rod.contact.primitives import BOX, CAPSULE, CYLINDER, PLANE, SPHERE

KINDS = [PLANE, SPHERE, CAPSULE, BOX, CYLINDER]
SIZES = {PLANE: (0.0, 0.0, 0.0), SPHERE: (0.3, 0.0, 0.0), CAPSULE: (0.2, 0.5, 0.0), BOX: (0.4, 0.1, 0.25),
         CYLINDER: (0.3, 0.4, 0.0)}


def rotation(rng):
    """A uniformly random proper rotation (QR of a Gaussian matrix, signs fixed)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return np.ascontiguousarray(q if np.linalg.det(q) > 0 else -q)
