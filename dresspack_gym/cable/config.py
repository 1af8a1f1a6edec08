"""Frozen configuration of a dresspack: cable properties, nodes, damage weights and fatigue.
Every ``from_dict`` validates strictly (unknown keys, types, units, ranges) and raises
:class:`~dresspack_gym.errors.ConfigError` naming the dotted field. Angles in YAML are degrees
(keys end in ``_deg``); internally they are radians. Lengths are metres, forces newtons.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..errors import ConfigError
from ..fields import Section, check_number, check_unique
from ..robots.config import (
    ROBOT_LINKS,
)

NODE_BODIES = ROBOT_LINKS + ("world",)


@dataclass(frozen=True)
class CableNode:
    """Where the dresspack is held: a point on a robot link (or the world) at an arc length.

    ``direction`` (unit vector in the body frame) makes the node a clamp that fixes the cable
    tangent; without it the node only fixes the position (a ring the cable can swivel in).
    ``arc_length`` is measured from the cable start; None means "start" (first node) or "end".
    """

    name: str
    body: str
    pos: tuple[float, float, float]
    direction: tuple[float, float, float] | None
    arc_length: float


# Largest wear-cost weight: the thesis's weights span 1e-5 (tension, N) to 100 (distance); far beyond this one
# term swamps the others to float64 rounding, which is a unit error rather than a choice.
WEIGHT_MAX = 1e9


DAMAGE_TERMS = ("bend", "bend_moment", "bend_rate", "twist", "twist_torque", "twist_rate", "stretch", "tension",
                "stretch_rate", "contact_normal", "friction")


@dataclass(frozen=True)
class DamageWeights:
    """Weights of the per-segment damage terms (the AGX CableDamage set): damage = sum over terms of weight x
    (the quantity integrated over time, or, for the ``*_rate`` terms, its total variation).

    Units of the integrated quantities: bend [1/m s], bend_moment [N m s], twist [rad/m s], twist_torque
    [N m s], stretch [s] (strain x s), tension [N s], bend_rate [1/m], twist_rate [rad/m], stretch_rate [-],
    contact_normal [N s], friction [J] (friction force x sliding speed). The defaults weigh deformation and
    sliding so that 1 /m of curvature, 1 rad/m of twist, 0.1 % strain, 100 N of contact pressure and 10 W of
    sliding friction each add about one unit per second; forces, moments and rates are off (set them to use).
    """

    bend: float = 1.0
    bend_moment: float = 0.0
    bend_rate: float = 0.0
    twist: float = 1.0
    twist_torque: float = 0.0
    twist_rate: float = 0.0
    stretch: float = 1000.0
    tension: float = 0.0
    stretch_rate: float = 0.0
    contact_normal: float = 0.01
    friction: float = 0.1

    @staticmethod
    def from_dict(data: Mapping[str, Any], path: str) -> "DamageWeights":
        s = Section(data, path)
        d = DamageWeights()
        out = DamageWeights(**{k: s.number(k, getattr(d, k), lo=0.0, hi=WEIGHT_MAX) for k in DAMAGE_TERMS})
        s.done()
        return out


# Strain-life defaults: Manson's universal slopes (Manson 1965, Exp. Mech. 5(7)), total strain range
# 3.5 (S_u/E) N^-0.12 + D^0.6 N^-0.6, written as Coffin-Manson-Basquin eps_a = s'(2N)^b + e'(2N)^c, with handbook
# properties of annealed copper: S_u = 220 MPa, E = 115 GPa, reduction of area 70 % (D = ln(1/0.3)). A model from
# tensile data, not a fatigue test of any dresspack conductor: replace it with test data where you have them.
_SU_OVER_E = 220e6 / 115e9
_DUCTILITY = math.log(1.0 / 0.3)


@dataclass(frozen=True)
class FatigueConfig:
    """Strain-life curve and the radius at which the conductors' strain is taken.

    ``strain_radius`` [m]: distance of the strained fibre from its bending axis. Robot cables use extra-flexible
    conductors (IEC 60228 class 6: strands of about 0.2 mm diameter) whose strands slide on each other, so each
    strand bends about its own axis: the default is a strand's radius, 0.1 mm (the long-life bound). Strands that
    stick together bend about the conductor's axis (a 16 mm^2 conductor: 2.26 mm, lives ~1,000x shorter). Bending
    strain = strain_radius x curvature, shear strain = strain_radius x twist rate (counted as the von Mises
    equivalent gamma / sqrt(3)), axial strain = tension / ``axial_stiffness`` (default: the dresspack's EA, the
    conductors stretching with the bundle; give the conductors' own E A where the bundle's EA is a lumped model
    value, as the thesis's 1400 N is: 38 N of pull is then a 2.7 % strain). ``torsion_radius`` [m]: the radius at
    which twist shears the conductors (default: ``strain_radius``); a core laid around the cable's axis is sheared
    at its distance from that axis, where a strand sliding in bending bends about its own (physics/ratings.py
    calibrates both on cable makers' rated bending and torsion tests).
    """

    strain_radius: float = 1.0e-4
    sigma_f_over_e: float = 1.75 * 2 ** 0.12 * _SU_OVER_E  # s' (elastic line at 2N = 1)
    b: float = -0.12  # Basquin exponent
    eps_f: float = 0.5 * 2 ** 0.6 * _DUCTILITY ** 0.6  # e' (plastic line at 2N = 1)
    c: float = -0.6  # Coffin-Manson exponent
    axial_stiffness: float | None = None  # [N] tension per unit conductor strain; None: the dresspack's EA
    # [m] radius of the torsional shear; None: strain_radius. Left out of the repr, which keys the wear maps
    # (maps/wear_map.map_key): the life model changes no settled shape, so a dresspack's maps stay its own.
    torsion_radius: float | None = field(default=None, repr=False)

    @property
    def shear_radius(self) -> float:
        """The radius the twist rate shears the conductors at: ``torsion_radius``, else ``strain_radius``."""
        return self.strain_radius if self.torsion_radius is None else self.torsion_radius

    @staticmethod
    def from_dict(data: Mapping[str, Any], path: str) -> "FatigueConfig":
        s = Section(data, path)
        d = FatigueConfig()
        out = FatigueConfig(
            strain_radius=s.number("strain_radius", d.strain_radius, lo=0.0, lo_open=True, hi=0.2, unit="m"),
            sigma_f_over_e=s.number("sigma_f_over_e", d.sigma_f_over_e, lo=0.0, lo_open=True, hi=1.0),
            b=s.number("b", d.b, lo=-1.0, hi=0.0, lo_open=True),
            eps_f=s.number("eps_f", d.eps_f, lo=0.0, lo_open=True, hi=10.0),
            c=s.number("c", d.c, lo=-2.0, hi=0.0, lo_open=True),
            axial_stiffness=(s.number("axial_stiffness", lo=0.0, lo_open=True, hi=1e10, unit="N")
                             if s.has("axial_stiffness") else None),
            torsion_radius=(s.number("torsion_radius", lo=0.0, lo_open=True, hi=0.2, unit="m")
                            if s.has("torsion_radius") else None))
        if out.c >= 0 or out.b >= 0:
            raise ConfigError(path, "the strain-life exponents b and c must be negative")
        s.done()
        return out


@dataclass(frozen=True)
class DresspackConfig:
    """Cable material (thesis Table 3.1 style), discretisation and attachment nodes."""

    name: str
    source: str
    length: float
    radius: float
    linear_density: float
    bending_stiffness: float  # EI, N m^2
    tensile_stiffness: float  # EA, N
    torsional_stiffness: float  # GJ, N m^2
    segments: int
    nodes: tuple[CableNode, ...]
    collide_with_robot: bool = True
    damage: DamageWeights = DamageWeights()
    fatigue: FatigueConfig = FatigueConfig()

    @property
    def second_moment(self) -> float:
        """Area moment of inertia I = pi r^4 / 4 of the circular cross-section [m^4]."""
        return math.pi * self.radius ** 4 / 4.0

    @property
    def polar_moment(self) -> float:
        """Torsion constant J = pi r^4 / 2 of the circular cross-section [m^4]."""
        return math.pi * self.radius ** 4 / 2.0

    @property
    def young_modulus(self) -> float:
        """MuJoCo ``young`` so that E*I equals the configured bending stiffness EI [Pa]."""
        return self.bending_stiffness / self.second_moment

    @property
    def shear_modulus(self) -> float:
        """MuJoCo ``shear`` so that G*J equals the configured torsional stiffness GJ [Pa]."""
        return self.torsional_stiffness / self.polar_moment

    @property
    def segment_length(self) -> float:
        return self.length / self.segments

    def vertex_of(self, node: CableNode) -> int:
        """The cable vertex a node sits on (its arc length rounded to the discretisation)."""
        return int(round(node.arc_length / self.segment_length))

    def is_end_node(self, node: CableNode) -> bool:
        """True for a node on the cable's last vertex (its clamp then holds the last edge, pointing back)."""
        return self.vertex_of(node) == self.segments

    @property
    def free_end(self) -> bool:
        """The cable's far end hangs free (no node on its last vertex)."""
        return not self.is_end_node(self.nodes[-1])

    @staticmethod
    def from_dict(data: Mapping[str, Any], path: str = "dresspack") -> "DresspackConfig":
        s = Section(data, path)
        name = s.string("name")
        source = s.string("source", "")
        length = s.number("length", lo=0.05, hi=20.0, unit="m", hint="cable length is in metres")
        radius = s.number("radius", lo=0.001, hi=0.2, unit="m", hint="cable radius is in metres")
        rho = s.number("linear_density", lo=0.0, lo_open=True, hi=50.0, unit="kg/m")
        ei = s.number("bending_stiffness", lo=0.0, lo_open=True, hi=1e4, unit="N m^2")
        ea = s.number("tensile_stiffness", lo=0.0, lo_open=True, hi=1e9, unit="N")
        gj = s.number("torsional_stiffness", lo=0.0, lo_open=True, hi=1e4, unit="N m^2")
        segments = s.integer("segments", 24, lo=3, hi=400)
        collide = s.boolean("collide_with_robot", True)
        damage = DamageWeights.from_dict(s.raw("damage", {}), f"{path}.damage")
        fatigue = FatigueConfig.from_dict(s.raw("fatigue", {}), f"{path}.fatigue")
        node_sections = s.sections("nodes")
        s.done()
        if not node_sections:
            raise ConfigError(f"{path}.nodes", "at least one attachment node is required")
        nodes = []
        for i, n in enumerate(node_sections):
            nname = n.string("name", f"node{i}")
            body = n.string("body", choices=NODE_BODIES)
            pos = n.vector("pos", 3, lo=-50, hi=50, unit="m")
            direction = None
            if n.has("direction"):
                d = np.asarray(n.vector("direction", 3, lo=-1e3, hi=1e3))
                if np.linalg.norm(d) < 1e-9:
                    raise ConfigError(n.field("direction"), "must be a non-zero vector")
                direction = tuple(d / np.linalg.norm(d))
            at = n.raw("at", "start" if i == 0 else "end")
            if at == "start":
                arc = 0.0
            elif at == "end":
                arc = length
            else:
                arc = check_number(at, n.field("at"), lo=0.0, hi=length, unit="m",
                                   hint="'start', 'end' or an arc length along the cable")
            n.done()
            nodes.append(CableNode(nname, body, pos, direction, arc))
        check_unique([nd.name for nd in nodes], f"{path}.nodes", "node")
        if nodes[0].arc_length != 0.0:
            raise ConfigError(f"{path}.nodes[0].at", "the first node must be at the cable start ('start' or 0)")
        arcs = [n.arc_length for n in nodes]
        if any(b <= a for a, b in zip(arcs, arcs[1:])):
            raise ConfigError(f"{path}.nodes", f"node arc lengths must increase along the cable, got {arcs}")
        h = length / segments
        vidx = [round(a / h) for a in arcs]
        for i in range(1, len(vidx)):
            gap = 2 if (nodes[i].direction is not None or nodes[i - 1].direction is not None) else 1
            if vidx[i] - vidx[i - 1] < gap + 1:
                raise ConfigError(f"{path}.nodes[{i}].at",
                                  f"nodes are closer than the cable discretisation allows ({segments} segments "
                                  f"of {h:.3f} m); increase 'segments' or separate the nodes")
        return DresspackConfig(name, source, length, radius, rho, ei, ea, gj, segments, tuple(nodes), collide, damage,
                               fatigue)
