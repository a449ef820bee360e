"""The problem an integrator sees: one smooth phase of a system, in Python.

:class:`Problem` is fixed for a phase: the system, the contacts closed as constraints
(``active``), the contacts whose continuous force acts (``engaged``) and each contact's
hysteresis factor χ. Integrators read it and never change it; the driver builds a new
one for the next phase. Its compiled form :attr:`Problem.kernel` (a
:class:`daebench.core.phase.PhaseData`) is what compiled integrators take; the Python
methods below evaluate the very same compiled functions, so a plugin written in
Python and a built-in see identical numbers::

    M(q) q̈ + C_q(t, q)ᵀ λ = Q(t, q, v),     C(t, q) = 0,
    C_q q̈ = γ(t, q, v)        (acceleration level)

Active constraints are the system's bilateral constraints followed by the closed
contacts, ``m = n_bilateral + len(active)``; a closed contact i is the constraint
C = −g_i(q) = 0, so λ_i ≥ 0 is its compressive normal force.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from daebench.core import coulomb, phase
from daebench.core.linalg import DiagonalMass
from daebench.core.system import MechanicalSystem, gap_table

@dataclass
class EvalCounters:
    """Evaluations made through a :class:`Problem` (read by the integrator base)."""

    residual_evals: int = 0
    jacobian_evals: int = 0


def law_parameters(system: MechanicalSystem) -> np.ndarray | None:
    """[kind, K, exponent, c, v_ε] of the system's continuous contact law; None without one
    (the phase's compiled functions then hold no contact-force code)."""
    law = system.contact_law
    return law.parameters() if law is not None and law.continuous else None


class Problem:
    """One smooth phase (see the module docstring).

    Parameters
    ----------
    system : MechanicalSystem
    active : contacts closed as constraints in this phase
    engaged : contacts whose continuous-law force acts in this phase (default: all, for
        use without the driver)
    chi : hysteresis factor per contact (default 0: no contact damping)
    friction : Coulomb friction at the closed contacts, {'groups': {kept stick contact: its
        parallel group}, 'anchors': {contact: q*}, 'slip': {contact: s}, 'mu': μ per contact}
        (:mod:`daebench.driver.stickslip` decides them): the stick rows follow the model's
        bilateral rows and count among ``n_bilateral``; the slip friction is part of the
        applied force (:mod:`daebench.core.coulomb`). None: no friction.
    """

    def __init__(self, system: MechanicalSystem, active: tuple[int, ...] = (),
                 engaged: np.ndarray | None = None, chi: np.ndarray | None = None,
                 friction: dict | None = None):
        self.system = system
        self.active = tuple(int(i) for i in active)
        self.n = system.n
        n_stick = len(friction["groups"]) if friction else 0
        self.n_bilateral = system.n_bilateral + n_stick
        self.m = self.n_bilateral + len(self.active)
        self.n_contacts = system.n_contacts
        nc = system.n_contacts
        self.engaged = np.ones(nc) if engaged is None else np.asarray(engaged, dtype=float).copy()
        self.chi = np.zeros(nc) if chi is None else np.asarray(chi, dtype=float).copy()
        self.counters = EvalCounters()
        n = self.n
        fr = coulomb.NONE if not friction else coulomb.friction_data(
            n, self.m, self.active, friction["groups"], friction["anchors"], friction["slip"], friction["mu"])
        self.kernel = phase.PhaseData(system.kernel_handle(), int(self.n_bilateral),
                                      np.array(self.active, dtype=np.int64), law_parameters(system),
                                      self.engaged, self.chi, np.zeros(n), np.zeros(5 * n), fr,
                                      _lumped(system))
        self._zeros = np.zeros(n)

    @property
    def contact_law(self):
        """The system's contact law (None: contacts are left to the integrator, or none)."""
        return self.system.contact_law

    # -- dynamics ---------------------------------------------------------
    def mass_force(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(M(q), Q(t, q, v)) in one evaluation."""
        self.counters.residual_evals += 1
        M = np.empty((self.n, self.n))
        Q = np.empty(self.n)
        phase.mass_force(self.kernel, float(t), _f(q), _f(v), M, Q)
        return M, Q

    def mass(self, q: np.ndarray) -> np.ndarray:
        M = np.empty((self.n, self.n))
        phase.mass_force(self.kernel, 0.0, _f(q), self._zeros, M, np.empty(self.n))
        return M

    def mass_operator(self, q: np.ndarray) -> "np.ndarray | DiagonalMass":
        """M(q) for products and solves: a lumped model's constant diagonal as a
        :class:`~daebench.core.linalg.DiagonalMass` (O(n), never the dense n × n matrix),
        else the dense matrix."""
        d = _lumped(self.system)
        return DiagonalMass(d) if d is not None else self.mass(q)

    def force(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.mass_force(t, q, v)[1]

    def force_jacobian(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(∂Q/∂q, ∂Q/∂v)."""
        self.counters.jacobian_evals += 1
        Kq = np.empty((self.n, self.n))
        Kv = np.empty((self.n, self.n))
        phase.force_jacobian(self.kernel, float(t), _f(q), _f(v), Kq, Kv)
        return Kq, Kv

    def mass_jacobian_product(self, q: np.ndarray, a: np.ndarray) -> np.ndarray:
        """∂(M(q) a)/∂q at fixed a."""
        K = np.empty((self.n, self.n))
        phase.mass_jacobian_product(self.kernel, _f(q), _f(a), K)
        return K

    # -- active constraints ----------------------------------------------------
    def constraint_rows(self, t: float, q: np.ndarray, v: np.ndarray | None = None
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(C, C_q, C_t, γ) of the active constraints in one evaluation."""
        m, n = self.m, self.n
        C, Cq, Ct, gam = np.empty(m), np.empty((m, n)), np.empty(m), np.empty(m)
        if m:
            phase.constraints(self.kernel, float(t), _f(q), self._zeros if v is None else _f(v), C, Cq, Ct, gam)
        return C, Cq, Ct, gam

    def constraint(self, t: float, q: np.ndarray) -> np.ndarray:
        return self.constraint_rows(t, q)[0]

    def constraint_jacobian(self, t: float, q: np.ndarray) -> np.ndarray:
        return self.constraint_rows(t, q)[1]

    def constraint_t(self, t: float, q: np.ndarray) -> np.ndarray:
        return self.constraint_rows(t, q)[2]

    def constraint_gamma(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.constraint_rows(t, q, v)[3]

    def constraint_force_jacobian(self, t: float, q: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """∂(C_qᵀ λ)/∂q at fixed λ (n × n)."""
        K = np.zeros((self.n, self.n))
        if self.m:
            phase.constraint_force_jacobian(self.kernel, float(t), _f(q), _f(lam), K)
        return K

    def velocity_constraint_jacobian(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """∂(C_q v + C_t)/∂q at fixed v (m × n)."""
        K = np.zeros((self.m, self.n))
        if self.m:
            phase.velocity_constraint_jacobian(self.kernel, float(t), _f(q), _f(v), K)
        return K

    def constraint_residuals(self, t: float, q: np.ndarray, v: np.ndarray, a: np.ndarray
                             ) -> tuple[float, float, float]:
        """(max|C|, max|Ċ|, max|C̈|) of the active constraints (C̈ NaN without ``a``)."""
        m, n = self.m, self.n
        if not m:
            return 0.0, 0.0, 0.0
        return phase.constraint_residuals(self.kernel, float(t), _f(q), _f(v), _f(a), np.empty(m),
                                          np.empty((m, n)), np.empty(m), np.empty(m))

    # -- contact points (all of them, open or closed) ------------------------------------------
    def gap_rows(self, q: np.ndarray, v: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(g, g_q, γ_g) of every contact point."""
        k = self.n_contacts
        g, G, gam = np.empty(k), np.empty((k, self.n)), np.empty(k)
        if k:
            phase.gaps(self.kernel, _f(q), self._zeros if v is None else _f(v), g, G, gam)
        return g, G, gam

    def gap(self, q: np.ndarray) -> np.ndarray:
        return self.gap_rows(q)[0]

    def gap_jacobian(self, q: np.ndarray) -> np.ndarray:
        return self.gap_rows(q)[1]

    def gap_gamma(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.gap_rows(q, v)[2]

    # -- continuous contact forces ------------------------------------------------------------
    def contact_forces(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Normal force of each contact's continuous law in this phase (0 when open)."""
        return self.contact_forces_rows(np.reshape(q, (1, -1)), np.reshape(v, (1, -1)))[0]

    def contact_forces_rows(self, Q: np.ndarray, V: np.ndarray) -> np.ndarray:
        """:meth:`contact_forces` at each row of the states (Q, V): rows × contacts."""
        law = self.system.contact_law
        if law is None or not law.continuous or not self.n_contacts:
            return np.zeros((np.shape(Q)[0], self.n_contacts))
        g, gd = gap_table(self.kernel.model, self.n_contacts, Q, V)
        return np.where(g < 0.0, law.force(g, gd, self.engaged != 0.0, self.chi), 0.0)

    def contact_power(self, q: np.ndarray, v: np.ndarray) -> float:
        """Power into the system of the continuous laws' dissipation (≤ 0): the normal
        law's, plus the regularised friction's (:func:`daebench.core.phase.friction_power`)."""
        law = self.system.contact_law
        if law is None or not law.continuous or not self.n_contacts:
            return 0.0
        g, G, _ = self.gap_rows(q)
        pen = g < 0.0
        if not pen.any():
            return 0.0
        return law.dissipation_power(g[pen], (G @ v)[pen], (self.engaged != 0.0)[pen], self.chi[pen]) \
            + float(phase.friction_power(self.kernel, _f(q), _f(v)))

    # -- Coulomb friction at closed contacts (daebench.core.coulomb) ----------------------------
    @property
    def slips(self) -> bool:
        """Whether a closed contact slips in this phase (its friction does work)."""
        return bool(self.kernel.friction.slip.shape[0])

    def slip_power(self, t: float, q: np.ndarray, v: np.ndarray) -> float:
        """Power of the slip friction at closed contacts, −Σ μ λ_N |t_q v| ≤ 0."""
        return float(phase.slip_power(self.kernel, float(t), _f(q), _f(v)))

    # -- helpers every integrator needs ----------------------------------------
    def acceleration(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Consistent (q̈, λ) from [[M, C_qᵀ], [C_q, 0]] [q̈; λ] = [Q; γ]."""
        self.counters.residual_evals += 1
        acc, lam = np.empty(self.n), np.empty(self.m)
        w = phase.augmented_work(self.n, self.m)
        if phase.solve_augmented(self.kernel, float(t), _f(q), _f(v), 0.0, 0.0, w, acc, lam):
            raise np.linalg.LinAlgError("singular augmented mass matrix (dependent constraints?)")
        return acc, lam

    def energy(self, q: np.ndarray, v: np.ndarray) -> float:
        return self.system.total_energy(q, v)


def _lumped(system: MechanicalSystem) -> np.ndarray | None:
    """The constant diagonal mass a lumped model declares (``lumped_mass``; its mass kernel
    accepts an M without rows), else None: the phase solves through it."""
    d = getattr(system, "lumped_mass", None)
    return None if d is None or len(d) != system.n else np.ascontiguousarray(d, dtype=np.float64)


def _f(x: np.ndarray) -> np.ndarray:
    """A contiguous float64 array (what the compiled functions are specialized on)."""
    return np.ascontiguousarray(x, dtype=np.float64)
