"""A rod's constant description for the engine: rest lengths, masses, stiffnesses, held vertices and twist spans."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError


@dataclass(frozen=True)
class RodModel:
    """One cable as the engine sees it (SI units).

    ``held``: vertex indices a node holds (their positions are prescribed); ``spans``: pairs of edges whose material
    frames clamps hold, in cable order (the twist between them is uniform); ``segments`` edges of rest length
    ``length / segments``; masses lumped rho*h per vertex (half at the two ends).
    """

    length: float
    segments: int
    linear_density: float
    tensile_stiffness: float  # EA [N]
    bending_stiffness: float  # EI [N m^2]
    torsional_stiffness: float  # GJ [N m^2]
    held: tuple[int, ...] = ()
    spans: tuple[tuple[int, int], ...] = ()
    damping: float = 5.0  # viscous drag rate [1/s] on every vertex
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)

    def __post_init__(self):
        n = self.segments
        checks = [("length", self.length > 0), ("segments", n >= 2), ("linear_density", self.linear_density > 0),
                  ("tensile_stiffness", self.tensile_stiffness > 0), ("bending_stiffness", self.bending_stiffness >= 0),
                  ("torsional_stiffness", self.torsional_stiffness >= 0), ("damping", self.damping >= 0)]
        for name, ok in checks:
            if not ok:
                raise ConfigError(f"rod.{name}", f"must be positive (segments >= 2), got {getattr(self, name)}")
        if any(not 0 <= v <= n for v in self.held) or len(set(self.held)) != len(self.held):
            raise ConfigError("rod.held", f"held vertices must be distinct indices in 0..{n}, got {self.held}")
        for a, b in self.spans:
            if not 0 <= a < b < n:
                raise ConfigError("rod.spans", f"a twist span is a pair of edges 0 <= a < b < {n}, got {(a, b)}")

    @property
    def segment_length(self) -> float:
        return self.length / self.segments

    @property
    def rest_lengths(self) -> np.ndarray:
        return np.full(self.segments, self.segment_length)

    @property
    def voronoi_lengths(self) -> np.ndarray:
        """Rest length each vertex stands for (bend and twist are integrated over it)."""
        out = np.full(self.segments + 1, self.segment_length)
        out[[0, -1]] *= 0.5
        return out

    @property
    def masses(self) -> np.ndarray:
        m = self.voronoi_lengths * self.linear_density
        return m

    @property
    def span_edges(self) -> np.ndarray:
        return np.array(self.spans, dtype=np.int64).reshape(-1, 2)

    @property
    def span_lengths(self) -> np.ndarray:
        """Rest length over which each span's twist is spread: from one clamp edge's midpoint to the other's."""
        return (self.span_edges[:, 1] - self.span_edges[:, 0]).astype(float) * self.segment_length

    @property
    def held_array(self) -> np.ndarray:
        return np.array(self.held, dtype=np.int64)
