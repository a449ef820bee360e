"""The problem protocol: what a model provides and what an integrator may use.

Two layers:

* :class:`MechanicalSystem` — a model (hub–beam, pendulum, Andrews, chain, …).
  It knows its mass matrix, its generalized forces, its permanent (bilateral)
  constraints, its unilateral contact points (gap functions), its energy and
  the power of its non-conservative effects.
* :class:`Problem` — one *smooth phase* of a system: the bilateral constraints
  plus the contact constraints that are currently closed (a fixed active set).
  This is all an integrator ever sees::

      M(q) q̈ + C_q(t, q)ᵀ λ = Q(t, q, v),     C(t, q) = 0,
      C_q q̈ = γ(t, q, v)        (acceleration level, γ = −(C_q q̇)_q q̇ − …)

  The driver (:mod:`daebench.simulate`) changes the active set between phases
  and restarts the integrator; integrators never see a switch.

Every array is a float64 NumPy array. ``q`` and ``v`` have length ``n``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from daebench.contact import ContactLaw

FD_REL_STEP = 1e-7  # relative step of the central differences used as default Jacobians


def central_difference(fun, x: np.ndarray, m: int) -> np.ndarray:
    """Jacobian ∂fun/∂x (m × len(x)) by central differences."""
    x = np.asarray(x, dtype=float)
    jac = np.empty((m, x.size))
    for j in range(x.size):
        dx = FD_REL_STEP * max(1.0, abs(x[j]))
        xp = x.copy()
        xm = x.copy()
        xp[j] += dx
        xm[j] -= dx
        jac[:, j] = (np.asarray(fun(xp)) - np.asarray(fun(xm))) / (2.0 * dx)
    return jac


class MechanicalSystem:
    """Base class of every model.

    Subclasses set ``n`` (number of coordinates), ``n_bilateral`` (permanent
    constraints) and ``n_contacts`` (unilateral contact points), and implement
    :meth:`mass`, :meth:`applied_force`, :meth:`energy`; constrained models
    implement the ``constraint*`` methods, models with contact the ``gap*``
    methods. Optional analytic Jacobians override :meth:`force_jacobian`.

    Continuous contact laws (Hertz, penalty) are added to the applied force here,
    once for every model, from the gap functions: ``Q = Q_applied + g_qᵀ F``.
    With the ``constraint`` law the contact is instead a constraint handled by
    the driver, and no force is added.
    """

    n: int = 0
    n_bilateral: int = 0
    n_contacts: int = 0
    coordinate_names: tuple[str, ...] = ()
    contact_law: "ContactLaw | None" = None

    # -- dynamics ---------------------------------------------------------
    def mass(self, q: np.ndarray) -> np.ndarray:
        """Mass matrix M(q), symmetric positive definite, shape (n, n)."""
        raise NotImplementedError

    def applied_force(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Generalized force without continuous contact: inertia (quadratic velocity),
        elastic, gravity, drive, damping. Shape (n,)."""
        raise NotImplementedError

    def force(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Total generalized force Q(t, q, v) seen by the integrator."""
        Q = self.applied_force(t, q, v)
        law = self.contact_law
        if law is not None and law.continuous and self.n_contacts:
            g = self.gap(q)
            if np.any(g < 0.0):
                Gq = self.gap_jacobian(q)
                F = law.force(g, Gq @ v)
                Q = Q + Gq.T @ F
        return Q

    def force_jacobian(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(∂Q/∂q, ∂Q/∂v). Default: central differences of :meth:`force`."""
        n = self.n
        Kq = central_difference(lambda x: self.force(t, x, v), q, n)
        Kv = central_difference(lambda x: self.force(t, q, x), v, n)
        return Kq, Kv

    def mass_jacobian_product(self, q: np.ndarray, a: np.ndarray) -> np.ndarray:
        """∂(M(q) a)/∂q at fixed a (n × n). Default: central differences."""
        return central_difference(lambda x: self.mass(x) @ a, q, self.n)

    # -- permanent (bilateral) constraints ---------------------------------
    def constraint(self, t: float, q: np.ndarray) -> np.ndarray:
        return np.zeros(0)

    def constraint_jacobian(self, t: float, q: np.ndarray) -> np.ndarray:
        return np.zeros((0, self.n))

    def constraint_t(self, t: float, q: np.ndarray) -> np.ndarray:
        """∂C/∂t (zero for scleronomic constraints)."""
        return np.zeros(self.n_bilateral)

    def constraint_gamma(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """γ with C_q q̈ = γ: the acceleration right-hand side."""
        return np.zeros(0)

    # -- unilateral contact points -------------------------------------------
    def gap(self, q: np.ndarray) -> np.ndarray:
        """Normal gaps g(q) ≥ 0 of the contact points, shape (n_contacts,)."""
        return np.zeros(0)

    def gap_jacobian(self, q: np.ndarray) -> np.ndarray:
        """∂g/∂q, shape (n_contacts, n)."""
        return np.zeros((0, self.n))

    def gap_gamma(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """γ_g with g̈ = g_q q̈ − γ_g, i.e. γ_g = −(g_q v)_q v."""
        return np.zeros(0)

    # -- bookkeeping ---------------------------------------------------------
    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        """Energy terms (``kinetic``, ``elastic``, ``gravity``, ``contact`` …);
        their sum is the mechanical energy E."""
        raise NotImplementedError

    def power(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        """Power *into* the system of each non-conservative effect
        (``torque`` > 0 when driving, ``damping`` ≤ 0, ``contact`` ≤ 0).
        Default: the continuous contact law's dissipation only."""
        law = self.contact_law
        if law is not None and law.continuous and self.n_contacts:
            g = self.gap(q)
            if np.any(g < 0.0):
                gdot = self.gap_jacobian(q) @ v
                return {"contact": float(law.dissipation_power(g, gdot))}
        return {}

    def contact_potential(self, q: np.ndarray) -> float:
        """Energy stored in continuous contact springs (0 for constraints)."""
        law = self.contact_law
        if law is not None and law.continuous and self.n_contacts:
            return float(law.potential(self.gap(q)))
        return 0.0

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        """Named scalar outputs written to the history and scored by metrics."""
        return {}

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        """(q0, v0) at t = 0, consistent with the bilateral constraints."""
        raise NotImplementedError

    @property
    def power_free(self) -> bool:
        """Whether the model has no non-conservative effect of its own (:meth:`power` is
        empty whenever no continuous contact penetrates). Declared, not inferred from a
        zero power at one instant: compiled phase runners skip the work bookkeeping only
        when this is true. Default False (safe)."""
        return False

    @property
    def contacts_by_integrator(self) -> bool:
        """Contact points with no law for the driver: an integrator must resolve them."""
        return self.n_contacts > 0 and self.contact_law is None

    def total_energy(self, q: np.ndarray, v: np.ndarray) -> float:
        return float(sum(self.energy(q, v).values()))


@dataclass
class EvalCounters:
    """Evaluations made through a :class:`Problem` (read by the integrator base)."""

    residual_evals: int = 0
    jacobian_evals: int = 0


class Problem:
    """One smooth phase: a system with a fixed set of active constraints.

    Active constraints are the system's bilateral constraints followed by the
    closed contacts listed in ``active`` (indices into the system's gaps), so
    ``m = n_bilateral + len(active)``. A closed contact i is the constraint
    C = −g_i(q) = 0. With  M q̈ + C_qᵀ λ = Q  this sign makes λ_i the normal
    contact force, λ_i ≥ 0 compressive (admissible), λ_i < 0 tensile (the
    contact must open).
    """

    def __init__(self, system: MechanicalSystem, active: tuple[int, ...] = ()):
        self.system = system
        self.active = tuple(int(i) for i in active)
        self.n = system.n
        self.m = system.n_bilateral + len(self.active)
        self.counters = EvalCounters()

    # -- dynamics ---------------------------------------------------------
    def mass(self, q: np.ndarray) -> np.ndarray:
        return self.system.mass(q)

    def force(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        self.counters.residual_evals += 1
        return self.system.force(t, q, v)

    def force_jacobian(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.counters.jacobian_evals += 1
        return self.system.force_jacobian(t, q, v)

    def mass_jacobian_product(self, q: np.ndarray, a: np.ndarray) -> np.ndarray:
        return self.system.mass_jacobian_product(q, a)

    # -- active constraints ----------------------------------------------------
    def constraint(self, t: float, q: np.ndarray) -> np.ndarray:
        parts = [self.system.constraint(t, q)]
        if self.active:
            parts.append(-self.system.gap(q)[list(self.active)])
        return np.concatenate(parts)

    def constraint_jacobian(self, t: float, q: np.ndarray) -> np.ndarray:
        parts = [self.system.constraint_jacobian(t, q).reshape(-1, self.n)]
        if self.active:
            parts.append(-self.system.gap_jacobian(q)[list(self.active)])
        return np.vstack(parts)

    def constraint_t(self, t: float, q: np.ndarray) -> np.ndarray:
        return np.concatenate([self.system.constraint_t(t, q), np.zeros(len(self.active))])

    def constraint_gamma(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        parts = [self.system.constraint_gamma(t, q, v)]
        if self.active:
            parts.append(-self.system.gap_gamma(q, v)[list(self.active)])
        return np.concatenate(parts)

    def constraint_force_jacobian(self, t: float, q: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """∂(C_qᵀ λ)/∂q at fixed λ, by central differences (n × n)."""
        if self.m == 0:
            return np.zeros((self.n, self.n))
        return central_difference(lambda x: self.constraint_jacobian(t, x).T @ lam, q, self.n)

    # -- helpers every integrator needs ----------------------------------------
    def acceleration(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Consistent (q̈, λ) from the augmented system
        [[M, C_qᵀ], [C_q, 0]] [q̈; λ] = [Q; γ]."""
        M = self.mass(q)
        Q = self.force(t, q, v)
        if self.m == 0:
            return np.linalg.solve(M, Q), np.zeros(0)
        Cq = self.constraint_jacobian(t, q)
        gam = self.constraint_gamma(t, q, v)
        n, m = self.n, self.m
        A = np.zeros((n + m, n + m))
        A[:n, :n] = M
        A[:n, n:] = Cq.T
        A[n:, :n] = Cq
        sol = np.linalg.solve(A, np.concatenate([Q, gam]))
        return sol[:n], sol[n:]

    def energy(self, q: np.ndarray, v: np.ndarray) -> float:
        return self.system.total_energy(q, v)


@dataclass
class State:
    """A point of a trajectory: time, coordinates, velocities, accelerations and
    the multipliers of the active constraints."""

    t: float
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray = field(default_factory=lambda: np.zeros(0))
    lam: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def copy(self) -> "State":
        return State(self.t, self.q.copy(), self.v.copy(), self.a.copy(), self.lam.copy())
