"""A rod's state (positions, velocities, reference frames) advanced by implicit steps or solved for rest."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from .contact.friction import MAX_RELAGS, friction_lag, friction_relag, friction_settled
from .elastic import span_twists
from .frames import transport, unit_tangents
from .model import RodModel
from .newton import broad_phase, inside, newton_step, static_gradient
from .scene import ContactSettings, Primitives

# Newton iterations allowed per solve before it is reported unconverged (a warm-started step takes 2-5).
MAX_ITERATIONS = 100
# The recovery's penalty stiffness [N/m]: far above the stretch of one edge (EA/h ~ 4e4 N/m for the thesis's cable)
# so that the penalty wins against the held vertex that pulls the cable in.
RECOVERY_STIFFNESS = 1e7
# A motion step also ends when a full Newton step moves no vertex this far [m] (a tenth of a millimetre: below what
# the measures resolve, see simulator.STEP_TOLERANCE); rest solves end on their force residual alone.
SETTLED_STEP = 1e-4
# Residual scale: a vertex's weight at g, or at 1 m/s^2 when g is smaller (a weightless rod still needs a scale).
MIN_GRAVITY = 1.0


@dataclass(frozen=True)
class SolveResult:
    """How a solve ended: Newton ``iterations``, the largest net force on a free vertex over its weight
    (``residual``, including inertia and drag in a motion step) and whether it is below the tolerance."""

    iterations: int
    residual: float
    converged: bool
    recovered: bool = False  # the start lay inside a primitive and the recovery's penalty moved it out first


def initial_frames(points: np.ndarray, first_director: np.ndarray | None = None) -> np.ndarray:
    """Reference directors on every edge of ``points``: ``first_director`` (or any normal) on the first edge,
    transported in space along the cable, so the frames carry no twist of their own."""
    t, _ = unit_tangents(np.ascontiguousarray(points, dtype=float))
    d = np.cross(t[0], [0.0, 0.0, 1.0]) if first_director is None else np.asarray(first_director, dtype=float)
    if np.linalg.norm(d - (d @ t[0]) * t[0]) < 1e-9:
        d = np.cross(t[0], [0.0, 1.0, 0.0])
    d = d - (d @ t[0]) * t[0]
    frames = np.empty_like(t)
    frames[0] = d / np.linalg.norm(d)
    for e in range(1, len(t)):
        frames[e] = transport(frames[e - 1], t[e - 1], t[e])
    return frames


class Rod:
    """One rod: ``model`` plus its state; the held vertices follow what :meth:`step` / :meth:`solve_rest` are given."""

    def __init__(self, model: RodModel, points, *, frames: np.ndarray | None = None,
                 clamp_directors: np.ndarray | None = None, radius: float = 0.0,
                 contact: ContactSettings | None = None):
        x = np.ascontiguousarray(points, dtype=float)
        if x.shape != (model.segments + 1, 3) or not np.isfinite(x).all():
            raise ConfigError("points", f"expected finite positions of shape ({model.segments + 1}, 3), got {x.shape}")
        self.model = model
        self.x = x.copy()
        self.v = np.zeros_like(x)
        self.ref = initial_frames(x) if frames is None else np.ascontiguousarray(frames, dtype=float).copy()
        n_spans = len(model.spans)
        self.clamp_directors = (np.zeros((n_spans, 2, 3)) if clamp_directors is None
                                else np.ascontiguousarray(clamp_directors, dtype=float).copy())
        self._rest = model.rest_lengths
        self._voronoi = model.voronoi_lengths
        self._mass = model.masses
        g = np.asarray(model.gravity, dtype=float)
        self._gravity = g
        self._force_scale = self._mass * max(float(np.linalg.norm(g)), MIN_GRAVITY)
        self._held = model.held_array
        self._span_edges = model.span_edges
        self._span_len = model.span_lengths
        self.radius = float(radius)
        self.settled_step = SETTLED_STEP
        self.contact = ContactSettings() if contact is None else contact
        self.primitives = Primitives.none(model.segments)  # where the primitives were at the last solve
        self.previous_primitives = self.primitives  # ... and at the one before (sliding is relative to them)
        self._static_forces: np.ndarray | None = None  # of the last solve, at its final shape
        self._twists: np.ndarray | None = None  # the spans' twists at the last solve's final shape
        self.previous_x = self.x.copy()  # the shape before the last step (sliding speeds are read against it)

    @property
    def step_constants(self) -> tuple:
        """What a step's solve takes of the rod's constant description, in carried_step's order (held, rest, voronoi,
        mass, EA, EI, GJ, gravity, damping, span edges, span lengths, force scale)."""
        m = self.model
        return (self._held, self._rest, self._voronoi, self._mass, m.tensile_stiffness, m.bending_stiffness,
                m.torsional_stiffness, self._gravity, m.damping, self._span_edges, self._span_len, self._force_scale)

    # ------------------------------------------------------------------ solves
    def step(self, held_pos, h: float, *, clamp_directors=None, tolerance: float = 1e-3,
             primitives: Primitives | None = None, start: np.ndarray | None = None,
             start_outside: bool = False) -> SolveResult:
        """One implicit Euler step of ``h`` seconds with the held vertices moved to ``held_pos`` and the
        ``primitives`` (default: as at the last solve) at their new poses; Newton starts from ``start`` (default:
        the inertial prediction x + h v) where that lies outside every primitive, else from the current shape
        (``start_outside``: the caller has checked that it does)."""
        if not h > 0:
            raise ConfigError("h", f"the step must be positive seconds, got {h}")
        start = self.x + h * self.v if start is None else np.ascontiguousarray(start, dtype=float)
        x_new, ref, result = self._solve(start, held_pos, h, clamp_directors, tolerance, primitives, start_outside)
        self._advance_to(x_new, ref, h)
        return result

    def take_step(self, x_new, ref, h: float, *, static, twists, primitives: Primitives,
                  clamp_directors) -> None:
        """Take a step of ``h`` seconds solved elsewhere (advance.carried_step): its shape ``x_new`` and frames, the
        net static gradient and span twists at that shape, the primitives and clamp directors it was solved with."""
        self.clamp_directors = clamp_directors
        self.previous_primitives = self.primitives
        self.primitives = primitives
        self._static_forces = -static
        self._twists = twists
        self._advance_to(x_new, ref, h)

    def _advance_to(self, x_new, ref, h: float) -> None:
        self.previous_x = self.x
        self.v = (x_new - self.x) / h
        self.x, self.ref = x_new, ref

    def solve_rest(self, held_pos=None, *, clamp_directors=None, tolerance: float = 1e-4,
                   primitives: Primitives | None = None) -> SolveResult:
        """Static equilibrium from the current shape with the held vertices at ``held_pos`` (default: where they
        are): the rod at rest, velocities zeroed."""
        held_pos = self.x[self._held] if held_pos is None else held_pos
        x_new, ref, result = self._solve(self.x, held_pos, math.inf, clamp_directors, tolerance, primitives)
        self.x, self.ref = x_new, ref
        self.v[:] = 0.0
        return result

    def _contact(self, primitives: Primitives | None, previous: Primitives) -> tuple:
        """The contact argument of newton_step: primitives now, and friction lagged from the rod's current shape
        against where the primitives were (``previous``)."""
        p = previous if primitives is None else primitives
        c = self.contact
        if len(p) and len(previous) == len(p):
            # only the pairs within the barrier's reach at the last shape can be lagged
            near = broad_phase(self.x, (self.radius, p.kind, previous.pos, previous.rot, p.size, p.mask), c.activation)
            lag = friction_lag(self.x, self.radius, p.kind, previous.pos, previous.rot, p.size, p.pos, p.rot, near[5],
                               c.activation, c.stiffness)
        else:  # nothing touched before: no friction to lag
            lag = (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)))
        return (self.radius, p.kind, p.pos, p.rot, p.size, p.mask, c.activation, c.stiffness, *lag,
                c.friction, c.slip, False)

    def _solve(self, start, held_pos, h, clamp_directors, tolerance, primitives=None, start_outside=False):
        held_pos = np.ascontiguousarray(held_pos, dtype=float).reshape(len(self._held), 3)
        if clamp_directors is not None:
            self.clamp_directors = np.ascontiguousarray(clamp_directors, dtype=float).reshape(-1, 2, 3)
        m = self.model
        start = np.ascontiguousarray(start)
        contact = self._contact(primitives, self.primitives)
        self.previous_primitives = self.primitives
        if primitives is not None:
            self.primitives = primitives
        if len(self.primitives) and math.isinf(h):  # rest: no motion to lag friction from
            contact = contact[:8] + self._contact(None, Primitives.none(m.segments))[8:]
        recovered = False
        if (len(self.primitives) and not start_outside and self._inside(start, held_pos, contact)
                and self._inside(self.x, held_pos, contact)):
            start = self._recover(held_pos, h, contact)
            recovered = True
        solved = self._newton(start, held_pos, h, tolerance, contact)
        if len(self.primitives) and not math.isinf(h):
            solved = self._relagged(solved, held_pos, h, tolerance, contact)
        x, ref, iterations, residual, converged, tau, static = solved
        self._static_forces = -static
        self._twists = tau
        return x, ref, SolveResult(int(iterations), float(residual), bool(converged), recovered)

    def _relagged(self, solved: tuple, held_pos, h, tolerance, contact) -> tuple:
        """``solved`` (newton_step's answer) solved again with its friction lagged again at its solution (see
        advance.carried_step), until that changes no friction bound by the solve's tolerance or the solution moves
        less than a settled step; iterations summed."""
        p, before, c = self.primitives, self.previous_primitives, self.contact
        if len(before) != len(p):
            before = p
        iterations = solved[2]
        for _ in range(MAX_RELAGS):
            x = solved[0]
            near = broad_phase(x, (self.radius, p.kind, p.pos, p.rot, p.size, p.mask), c.activation)
            lag = friction_relag(self.x, x, self.radius, p.kind, before.pos, before.rot, p.size, p.pos, p.rot, near[5],
                                 c.activation, c.stiffness)
            if friction_settled(len(x), contact[8], contact[9], contact[11], lag[0], lag[1], lag[3], c.friction,
                                self._force_scale, tolerance):
                break
            contact = contact[:8] + lag + contact[13:]
            solved = self._newton(x, held_pos, h, tolerance, contact)
            iterations += solved[2]
            if float(np.linalg.norm(solved[0] - x, axis=1).max()) <= max(self.settled_step, 1e-9):
                break
        return solved[:2] + (iterations,) + tuple(solved[3:])

    def _newton(self, start, held_pos, h, tolerance, contact):
        m = self.model
        return newton_step(
            start, self.ref, self.x, self.v, self._held, held_pos, self._rest, self._voronoi, self._mass,
            m.tensile_stiffness, m.bending_stiffness, m.torsional_stiffness, self._gravity, h, m.damping,
            self._span_edges, self.clamp_directors, self._span_len, self._force_scale, tolerance, MAX_ITERATIONS,
            contact, 0.0 if math.isinf(h) else self.settled_step)

    def forget_forces(self) -> None:
        """The state was set from outside: the last solve's static forces no longer belong to it."""
        self._static_forces = None
        self._twists = None
        self.previous_x = self.x.copy()
        self.previous_primitives = self.primitives

    def outside(self, x, held_pos, primitives: Primitives) -> bool:
        """Whether ``x`` with the held vertices at ``held_pos`` lies outside every one of ``primitives``."""
        return not self._inside(np.ascontiguousarray(x), np.asarray(held_pos, dtype=float),
                                self._contact(primitives, Primitives.none(self.model.segments)))

    def _inside(self, x, held_pos, contact) -> bool:
        """Whether ``x`` with the held vertices at ``held_pos`` lies inside some primitive (the barrier is infinite)."""
        placed = x.copy()
        placed[self._held] = held_pos
        return inside(placed, contact)

    def _recover(self, held_pos, h, contact) -> np.ndarray:
        """A start outside the primitives: the step solved with the recovery's penalty in place of the barrier."""
        penalty = contact[:6] + (self.contact.activation, RECOVERY_STIFFNESS) + contact[8:15] + (True,)
        x, *_ = self._newton(self.x, held_pos, h, 1e-2, penalty)
        return x

    # ------------------------------------------------------------------ queries
    def static_forces(self) -> np.ndarray:
        """Net static force on every vertex (elastic + gravity + contact), (n+1, 3) [N]: zero on a free vertex at
        rest; on a held vertex, minus the force its holder applies. The last solve's, which ended at this shape."""
        if self._static_forces is not None:
            return self._static_forces
        m = self.model
        grad = static_gradient(self.x, self.ref, self._rest, self._voronoi, self._mass, m.tensile_stiffness,
                               m.bending_stiffness, m.torsional_stiffness, self._gravity, self._span_edges,
                               self.clamp_directors, self._span_len,
                               self._contact(self.primitives, Primitives.none(m.segments)))
        return -grad

    def equilibrium_residual(self) -> float:
        """The largest net static force on a free vertex over its weight."""
        f = np.linalg.norm(self.static_forces(), axis=1) / self._force_scale
        f[self._held] = 0.0
        return float(f.max())

    def tensions(self) -> np.ndarray:
        """Axial force of every edge [N], EA times its strain (positive in tension)."""
        lengths = np.linalg.norm(np.diff(self.x, axis=0), axis=1)
        return self.model.tensile_stiffness * (lengths / self._rest - 1.0)

    def twists(self) -> np.ndarray:
        """Total twist [rad] of every clamped span (the last solve's, which ended at this shape)."""
        if self._twists is not None:
            return self._twists
        t, _ = unit_tangents(self.x)
        return span_twists(self.x, self.ref, t, self._span_edges, self.clamp_directors)

    def twist_rates(self) -> np.ndarray:
        """Twist per unit length [rad/m] of every clamped span (uniform along it)."""
        return self.twists() / self._span_len

    def kinetic_energy(self) -> float:
        return 0.5 * float(self._mass @ (self.v * self.v).sum(axis=1))
