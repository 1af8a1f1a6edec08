"""What the cable exerts on each of its holders: the force and the torque about the node point."""

from __future__ import annotations

import numpy as np

from .rod import Rod


def holder_loads(rod: Rod, members: np.ndarray, anchors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(forces, torques), each (holders, 3) in the world frame: the static force on the vertices each holder holds
    (their weight included), its moment about the holder's node point ``anchors`` (a vertex index each), and for a
    clamp the twist's torque GJ tau / L about its edge (the near clamp of a span is turned along +tau, the far one
    against it). ``members``: (holders, vertices) 0/1, the vertices each holder holds."""
    forces_v = rod.static_forces()
    forces = members @ forces_v
    arms = rod.x[None, :, :] - rod.x[anchors][:, None, :]
    torques = (members[:, :, None] * np.cross(arms, forces_v[None, :, :])).sum(axis=1)
    if len(rod.model.spans):
        t = np.diff(rod.x, axis=0)
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        moments = rod.model.torsional_stiffness * rod.twists() / rod.model.span_lengths
        for (near, far), moment in zip(rod.model.spans, moments):
            for edge, sign in ((near, 1.0), (far, -1.0)):
                holder = np.flatnonzero(members[:, edge] * members[:, edge + 1])
                torques[holder] += sign * moment * t[edge]
    return forces, torques
