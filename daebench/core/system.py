"""The model protocol: what a model provides, in Python.

:class:`MechanicalSystem` is a model (hub–beam, pendulum, Andrews, chain, …): its mass
matrix, its generalized forces, its permanent (bilateral) constraints, its unilateral
contact points (gap functions), its energy and the power of its non-conservative
effects. Integrators never see it directly: they see one smooth phase of it, a
:class:`daebench.core.problem.Problem`.

A model gives its physics either

* as compiled kernels (:mod:`daebench.core.kernels`) — subclass :class:`KernelSystem`,
  return the kernel data from :meth:`kernel_data`, and the Python methods below are
  derived from the kernels (the physics exists once); or
* as plain Python methods — subclass :class:`MechanicalSystem` and override them; the
  compiled integrators then call these methods back (:class:`daebench.core.kernels.PyModel`).

Every array is a float64 NumPy array. ``q`` and ``v`` have length ``n``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from daebench.core import handles, kernels
from daebench.core.kernels import fd_step
from daebench.core.phase import gap_table as gap_table_kernel, model_gaps

if TYPE_CHECKING:  # pragma: no cover
    from daebench.core.contact import ContactLaw


def central_difference(fun, x: np.ndarray, m: int) -> np.ndarray:
    """Jacobian ∂fun/∂x (m × len(x)) by central differences (step :func:`daebench.core.kernels.fd_step`)."""
    x = np.asarray(x, dtype=float)
    jac = np.empty((m, x.size))
    for j in range(x.size):
        dx = fd_step(float(x[j]))
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

    A continuous contact law (Hertz, penalty) is not the model's business: the phase
    adds its force ``g_qᵀ F`` (:mod:`daebench.core.phase`). With the ``constraint`` law the
    contact is a constraint handled by the driver.
    """

    n: int = 0
    n_bilateral: int = 0
    n_contacts: int = 0
    coordinate_names: tuple[str, ...] = ()
    contact_law: "ContactLaw | None" = None
    #: Newton coefficient of restitution e the scene gives its contacts (the law's, also when
    #: the contacts are left to an integrator, ``complementarity``; NaN: the model declares none)
    contact_restitution: float = math.nan

    # -- dynamics ---------------------------------------------------------
    def mass(self, q: np.ndarray) -> np.ndarray:
        """Mass matrix M(q), symmetric positive definite, shape (n, n)."""
        raise NotImplementedError

    def applied_force(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Generalized force without continuous contact: inertia (quadratic velocity),
        elastic, gravity, drive, damping. Shape (n,)."""
        raise NotImplementedError

    def force_jacobian(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(∂Q/∂q, ∂Q/∂v) of the applied force. Default: central differences."""
        n = self.n
        Kq = central_difference(lambda x: self.applied_force(t, x, v), q, n)
        Kv = central_difference(lambda x: self.applied_force(t, q, x), v, n)
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
        """Power *into* the system of each of the model's own non-conservative effects
        (``torque`` > 0 when driving, ``damping`` ≤ 0). The dissipation of a continuous
        contact law is the phase's (:meth:`daebench.core.problem.Problem.contact_power`).
        Default: none."""
        return {}

    def contact_potential(self, q: np.ndarray) -> float:
        """Energy stored in continuous contact springs (0 for constraints)."""
        return float(self.contact_potential_rows(np.reshape(q, (1, -1)))[0])

    def contact_potential_rows(self, Q: np.ndarray) -> np.ndarray:
        """:meth:`contact_potential` at each row of Q."""
        law = self.contact_law
        if law is None or not law.continuous or not self.n_contacts:
            return np.zeros(np.shape(Q)[0])
        return law.potential(self.gap_rows_of(Q))

    def gap_rows_of(self, Q: np.ndarray) -> np.ndarray:
        """:meth:`gap` at each row of Q: rows × contacts."""
        return np.array([self.gap(q) for q in Q], dtype=float).reshape(np.shape(Q)[0], self.n_contacts)

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        """Named scalar outputs written to the history and scored by metrics."""
        return {}

    #: optional: ``output_rows(t, q, v) -> (observables, energy terms)``, each {name: column}, of
    #: the states q[r], v[r] at t[r] in one call (the driver's rows of many output times; the
    #: model's :meth:`observables` and :meth:`energy` must be one row of it)
    output_rows: Any = None

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

    #: the length scale when the start says nothing of one (every coordinate and gap zero); a model
    #: with a smaller or larger geometry overrides :meth:`length_scale`
    DEFAULT_LENGTH_SCALE = 1.0

    def length_scale(self) -> float:
        """The scene's length scale [m] (positive, finite): what a penetration of a rigid
        obstacle is measured against (:func:`daebench.driver.history.penetration`: a
        capturing run whose gap falls below −PENETRATION × this has diverged). Default: the
        size of the start configuration — the largest of its gaps, of its coordinates and of
        their spread (a mesh's extent; a rod 1 µm from a wall is still a metre long) —, or
        :data:`DEFAULT_LENGTH_SCALE` when all are zero."""
        q = np.asarray(self.initial_state()[0], float)
        sizes = [np.abs(np.asarray(self.gap(q), float)) if self.n_contacts else np.zeros(0), np.abs(q),
                 np.ptp(q, keepdims=True) if q.size else np.zeros(0)]
        x = np.concatenate([a.ravel() for a in sizes])
        x = x[np.isfinite(x)]
        return float(x.max()) if x.size and x.max() > 0 else self.DEFAULT_LENGTH_SCALE

    def total_energy(self, q: np.ndarray, v: np.ndarray) -> float:
        return float(sum(self.energy(q, v).values()))

    def kernel_data(self) -> Any:
        """The data compiled integrators dispatch on (:mod:`daebench.core.kernels`). Here: a
        handle through which they call this model's Python methods."""
        return kernels.python_handle(self)

    def kernel_handle(self) -> Any:
        """What compiled code is handed: :func:`daebench.core.handles.handle` of
        :meth:`kernel_data` (one type for every compiled model)."""
        return handles.handle(self.kernel_data())


class KernelSystem(MechanicalSystem):
    """A model whose physics is its compiled kernels (:mod:`daebench.core.kernels`).

    Subclasses set ``self.data`` to their registered kernel data (and n, n_bilateral,
    n_contacts) and implement the bookkeeping methods (energy, observables,
    initial_state, power); mass, forces, Jacobians, constraints and gaps are derived
    from the kernels here.
    """

    data: Any = None

    def kernel_data(self) -> Any:
        return self.data

    def kernel_handle(self) -> Any:
        """The handle of ``self.data``, made once per data value (the Python protocol below
        calls the kernels through it too, so they compile once, for one signature)."""
        made = self.__dict__.get("_handle_of")
        if made is None or made[0] is not self.data:
            made = self.__dict__["_handle_of"] = (self.data, handles.handle(self.data))
        return made[1]

    def mass_force(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(M(q), Q(t, q, v)) in one kernel call (the name :class:`daebench.core.problem.Problem` uses)."""
        M = np.empty((self.n, self.n))
        Q = np.empty(self.n)
        kernels.mass_force(self.kernel_handle(), float(t), _f(q), _f(v), M, Q)
        return M, Q

    def mass(self, q: np.ndarray) -> np.ndarray:
        return self.mass_force(0.0, q, np.zeros(self.n))[0]

    def applied_force(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.mass_force(t, q, v)[1]

    def force_jacobian(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        Kq = np.empty((self.n, self.n))
        Kv = np.empty((self.n, self.n))
        kernels.force_jacobian(self.kernel_handle(), float(t), _f(q), _f(v), Kq, Kv)
        return Kq, Kv

    def mass_jacobian_product(self, q: np.ndarray, a: np.ndarray) -> np.ndarray:
        K = np.empty((self.n, self.n))
        kernels.mass_jacobian_product(self.kernel_handle(), _f(q), _f(a), K)
        return K

    def _constraint_rows(self, t: float, q: np.ndarray, v: np.ndarray | None = None):
        nb, n = self.n_bilateral, self.n
        C, Cq, Ct, gam = np.zeros(nb), np.zeros((nb, n)), np.zeros(nb), np.zeros(nb)
        if nb:
            kernels.constraints(self.kernel_handle(), float(t), _f(q), np.zeros(n) if v is None else _f(v), C, Cq, Ct, gam)
        return C, Cq, Ct, gam

    def constraint(self, t: float, q: np.ndarray) -> np.ndarray:
        return self._constraint_rows(t, q)[0]

    def constraint_jacobian(self, t: float, q: np.ndarray) -> np.ndarray:
        return self._constraint_rows(t, q)[1]

    def constraint_t(self, t: float, q: np.ndarray) -> np.ndarray:
        return self._constraint_rows(t, q)[2]

    def constraint_gamma(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._constraint_rows(t, q, v)[3]

    def _gap_rows(self, q: np.ndarray, v: np.ndarray | None = None):
        k, n = self.n_contacts, self.n
        g, G, gam = np.zeros(k), np.zeros((k, n)), np.zeros(k)
        if k:
            model_gaps(self.kernel_handle(), _f(q), np.zeros(n) if v is None else _f(v), g, G, gam)
        return g, G, gam

    def gap(self, q: np.ndarray) -> np.ndarray:
        return self._gap_rows(q)[0]

    def gap_rows_of(self, Q: np.ndarray) -> np.ndarray:
        return gap_table(self.kernel_handle(), self.n_contacts, Q)[0]

    def gap_jacobian(self, q: np.ndarray) -> np.ndarray:
        return self._gap_rows(q)[1]

    def gap_gamma(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._gap_rows(q, v)[2]


def gap_table(md: Any, k: int, Q: np.ndarray, V: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(g, ġ) of the ``k`` contact points (columns) of the model with kernel data ``md`` at
    each row of the states (Q, V) (V = 0 by default), one compiled call
    (:func:`daebench.core.phase.gap_table`)."""
    Q = np.ascontiguousarray(Q, dtype=np.float64)
    V = np.zeros_like(Q) if V is None else np.ascontiguousarray(V, dtype=np.float64)
    g, gd = np.empty((Q.shape[0], k)), np.empty((Q.shape[0], k))
    if k:
        gap_table_kernel(md, Q, V, g, gd, np.empty(Q.shape[1]))
    return g, gd


def _f(x: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64)


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
