"""Complementarity contact with a time-averaged gap: one LCP per step for the contact impulse.

Method
------
The smooth part is the trapezoidal rule (Newmark β = ¼, γ = ½ in velocity form);
the contact impulse P ≥ 0 of each contact over the step enters the momentum balance
and is found from a linear complementarity problem on the gap *averaged over the
step*::

    q₁ = q₀ + (h/2)(v₀ + v₁)
    M (v₁ − v₀) = (h/2) [Q(t₀, q₀, v₀) + Q(t₁, q₁, v₁)] + g_qᵀ P
    0 ≤ P  ⟂  ḡ = (1 − θ) g(q₀) + θ g(q₁) ≥ 0          (θ = ½: the time-averaged gap)

The contact force is never negative by construction (P ≥ 0), and an open contact
(ḡ > 0) carries none. For a linear system with linear gaps (the spring–mass chain)
v₁ is affine in P, so ḡ = b + A P with A = (θh/2) g_q S⁻¹ g_qᵀ, S = M − (h/2)(∂Q/∂v
+ (h/2) ∂Q/∂q), and the step is one exact LCP solve. For nonlinear forces or gaps
the step is a Newton iteration whose every linearization is solved as an LCP
(Newton–LCP); M is taken at the step midpoint and g_q at the midpoint iterate.

The LCP is solved exactly by the compiled solver of :mod:`daebench.core.lcp` (the one
the compiled steppers use): one contact in closed form, P = max(0, −b/A); several by
Murty's least-index principal pivoting (finite for P-matrices; A is symmetric
positive definite when M, −∂Q/∂q, −∂Q/∂v are symmetric and the gap Jacobians are
independent).

Energy
------
For linear forces Q = −Kq (and any linear gap) the scheme's energy balance per step
is exact algebra::

    E₁ − E₀ = ½ (v₀ + v₁)ᵀ g_qᵀ P = P · (g₁ − g₀) / h.

With θ = 1 (gap at the end of the step, the classic "no penetration at step ends")
a positive P gives g₁ = 0 and E₁ − E₀ = −P g₀/h ≤ 0: dissipative, an effective
restitution below 1 that depends on where the step ends fall. With θ = ½ a positive
P gives g₁ = −g₀, so the gap zig-zags about zero (|g| = O(h |ġ⁻|), not O(h²)) and
E₁ − E₀ = −2 P g₀ / h changes sign from step to step, and need not sum to zero: on
chain-impact at h = 1e-4 s the run ends with E 59 % above E0, and the driver fails it for
energy made across contacts (:mod:`daebench.core.impact_checks`, rule 7; θ = 1 dissipates
and completes; tests/models/test_chain.py). The rigid contact has no restitution
parameter; its effective restitution follows from the scheme.

Output
------
``State.lam`` holds the mean contact force of the step, P/h, one entry per contact
(the driver sets no continuous law for this model, so the force appears nowhere
else); ``State.a`` = (v₁ − v₀)/h. :meth:`dense` interpolates the scheme's own
piecewise-quadratic position / linear velocity. Each contact episode (first to last
step with P > 0) is reported to the driver (:meth:`report_contact`) and reaches the run
record as an impact: ġ⁻ at the start of the first step, ġ⁺ at the end of the last one,
the energy change of the episode, its total impulse and its smallest gap.

Capabilities: order 2 on smooth (contact-free) motion; at a contact switch the
local error is O(h) (non-smooth). Fixed step only. It treats the system's contacts
itself, so it refuses a system without contacts and one that also carries a
continuous contact law (the contact would be counted twice). Linear stability of
the smooth part: the trapezoidal rule, A-stable, no numerical damping.

References
----------
N. M. Newmark, "A method of computation for structural dynamics", J. Eng. Mech. Div.
ASCE 85 (1959) 67–94.
N. J. Carpenter, R. L. Taylor, M. G. Katona, "Lagrange constraints for transient
finite element surface contact", Int. J. Numer. Meth. Eng. 32 (1991) 103–128.
D. E. Stewart, J. C. Trinkle, "An implicit time-stepping scheme for rigid body
dynamics with inelastic collisions and Coulomb friction", Int. J. Numer. Meth. Eng.
39 (1996) 2673–2691.
V. Acary, "Energy conservation and dissipation properties of time-integration methods
for nonsmooth elastodynamics with contact", ZAMM 96 (2016) 585–603.
K. G. Murty, "Note on a Bard-type scheme for solving the complementarity problem",
Opsearch 11 (1974) 123–130 (least-index principal pivoting).
This is the trapezoidal variant written before the source paper's formulation was read;
the paper's own scheme (the force-level LCP on the gap averaged over a window, inside
an adaptive explicit Runge–Kutta) is :class:`daebench.integrators.lcp_avg.LcpAvg`.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from daebench.core.contact import Impact
from daebench.core.lcp import LCP_FAILURES, lcp
from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator, IntegratorError, Setting, \
    StepFailure
from daebench.core.system import State

def solve_contact_lcp(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The contact impulses z ≥ 0 with w = A z + b ≥ 0, zᵀw = 0: the compiled Murty solver
    (:func:`daebench.core.lcp.lcp`); a StepFailure when a contact cannot push (A_ii ≤ 0)
    or the solver finds no solution."""
    diag = np.diagonal(A)
    if np.any(diag <= 0.0):
        raise StepFailure(f"LCP matrix not positive ({float(np.min(diag)):g}): the contact cannot push")
    z, status = lcp(A, b)
    if status < 0:
        raise StepFailure(f"LCP: {LCP_FAILURES[status]}")
    return z


class ComplementarityLCP(Integrator):
    """Trapezoidal rule with contact impulses from an LCP on the time-averaged gap.

    Settings
    --------
    h : float
        Fixed step [s] (``h_contact`` is accepted for the protocol but unused: the
        driver sees no contact for this model).
    gap_weight : float in [½, 1], default ½
        θ of the complementarity gap ḡ = (1 − θ) g₀ + θ g₁; ½ is the time-averaged
        gap, 1 the end-of-step gap.
    newton_tol, newton_maxiter :
        Newton–LCP iteration for nonlinear forces (linear systems converge in one).

    Notes
    -----
    Order 2 on contact-free motion (trapezoidal rule), O(h) at contact switches;
    A-stable, non-dissipative smooth part; contact impulse P ≥ 0 always. See the
    module docstring for the formulation, energy balance and references.
    """

    name: ClassVar[str] = "lcp"
    description: ClassVar[str] = ("complementarity contact: trapezoidal rule + one LCP per step on the "
                                  "time-averaged gap (contact.law = complementarity)")
    capabilities: ClassVar[Capabilities] = Capabilities(order=2, fixed_step=True, constraints=False, contacts=True)
    contact_laws: ClassVar[tuple[str, ...]] = ("complementarity",)  # no impact law of its own
    settings_spec: ClassVar[tuple[Setting, ...]] = STEP_SETTINGS + (
        Setting("gap_weight", float, 0.5, "θ in ḡ = (1−θ) g_n + θ g_{n+1}; 0.5 = time-averaged gap",
                low=0.5, high=1.0),
        Setting("newton_tol", float, 1e-12, "Newton–LCP tolerance on the scaled velocity increment",
                low=1e-15, high=1e-3),
        Setting("newton_maxiter", int, 20, "Newton–LCP iterations per step", low=1, high=200),
    )

    def __init__(self, **settings) -> None:
        super().__init__(**settings)
        self._open: dict[int, tuple[float, float, float, float, float]] = {}  # contact → (t, ġ⁻, E, ΣP, min g)
        self.min_force = math.inf     # smallest contact force of any step (≥ 0 by construction)
        self.min_gap = math.inf       # smallest gap at any step end

    # -- lifecycle ---------------------------------------------------------------
    def _start(self) -> None:
        p = self.problem
        if p.n_contacts == 0:
            raise IntegratorError(
                "integrator 'lcp' treats the contacts of the system itself, but this system has none; "
                "switch `--set effects.contact=true` (with `--set contact.law=complementarity`) or use "
                "another integrator.")
        law = p.contact_law
        if law is not None:
            raise IntegratorError(
                f"integrator 'lcp' has no impact law of its own (no restitution): it runs only systems whose "
                f"contacts are left to it (`--set contact.law=complementarity`, e.g. chain-impact); this one has "
                f"the contact law '{law.name}'. Use moreau or nsgenalpha for event-capturing runs with the "
                f"constraint law's restitution.")
        if self.problem.m:
            raise IntegratorError("integrator 'lcp' integrates ODE models only (no bilateral constraints)")
        st = self.state
        nc = p.n_contacts
        if st.lam.size != nc:
            self.state = State(st.t, st.q, st.v, st.a, np.zeros(nc))

    # -- one step ------------------------------------------------------------------------
    def _step_impl(self, t_stop: float) -> State:
        p, s = self.problem, self.state
        h = min(self.h, t_stop - s.t)
        t0, q0, v0 = s.t, s.q, s.v
        t1 = t0 + h
        th = float(self.settings["gap_weight"])
        tol = float(self.settings["newton_tol"])
        Q0 = p.force(t0, q0, v0)
        g0 = p.gap(q0)
        dv = np.zeros_like(v0)
        P = np.zeros(p.n_contacts)
        vscale = max(1.0, float(np.max(np.abs(v0))))
        for it in range(int(self.settings["newton_maxiter"])):
            v1 = v0 + dv
            q1 = q0 + 0.5 * h * (v0 + v1)
            qm = 0.5 * (q0 + q1)
            M = p.mass(qm)
            W = p.gap_jacobian(qm).T
            Q1 = p.force(t1, q1, v1)
            r = M @ dv - 0.5 * h * (Q0 + Q1) - W @ P
            Kq, Kv = p.force_jacobian(t1, q1, v1)
            S = M - 0.5 * h * (Kv + 0.5 * h * Kq)
            try:
                Sinv_r = np.linalg.solve(S, r)
                Sinv_W = np.linalg.solve(S, W)
            except np.linalg.LinAlgError as exc:
                raise StepFailure(f"singular iteration matrix at t = {t0:.9g}: {exc}") from None
            self.counters.lu_factorizations += 1
            self.counters.newton_iterations += 1
            # linearized: dv_new(P') = free + S⁻¹ W P'
            free = dv - Sinv_r - Sinv_W @ P
            G1 = p.gap_jacobian(q1)
            g1 = p.gap(q1)
            # ḡ(P') = (1−θ) g0 + θ [g1 + G1 (h/2)(dv_new − dv)]
            b = (1.0 - th) * g0 + th * (g1 + 0.5 * h * G1 @ (free - dv))
            A = th * 0.5 * h * G1 @ Sinv_W
            P_new = solve_contact_lcp(A, b)
            dv_new = free + Sinv_W @ P_new
            step = float(np.max(np.abs(dv_new - dv))) / vscale
            dv, P = dv_new, P_new
            if step <= tol:
                break
        else:
            raise StepFailure(f"Newton–LCP did not converge at t = {t0:.9g} (last increment {step:.3g})")
        v1 = v0 + dv
        q1 = q0 + 0.5 * h * (v0 + v1)
        lam = P / h
        self._book(t0, t1, q0, v0, q1, v1, P, lam)
        return State(t1, q1, v1, dv / h, lam)

    def _book(self, t0, t1, q0, v0, q1, v1, P, lam) -> None:
        """Contact episodes (first to last step with P > 0), reported to the driver."""
        p = self.problem
        self.min_force = min(self.min_force, float(np.min(lam)))
        g1 = p.gap(q1)
        self.min_gap = min(self.min_gap, float(np.min(g1)))
        G0 = p.gap_jacobian(q0)
        for i in range(P.size):
            if P[i] > 0.0 and i not in self._open:
                self._open[i] = (t0, float(G0[i] @ v0), p.energy(q0, v0), float(P[i]), float(g1[i]))
            elif P[i] > 0.0:
                ts, vn, E0, imp, gmin = self._open[i]
                self._open[i] = (ts, vn, E0, imp + float(P[i]), min(gmin, float(g1[i])))
            elif P[i] == 0.0 and i in self._open:
                ts, vn, E0, imp, gmin = self._open.pop(i)
                # the episode ended with the previous step: ġ⁺ and E at t0
                self.report_contact(Impact(ts, i, vn, float(G0[i] @ v0), E0 - p.energy(q0, v0), impulse=imp,
                                           t_end=t0, min_gap=gmin))

    def dense(self, t: float) -> State:
        """The scheme's own interpolant: v linear, q quadratic (q(t₁) = q₁ exactly)."""
        s0, s1 = self.prev, self.state
        if s0 is None or s1.t <= s0.t:
            return s1.copy()
        h = s1.t - s0.t
        tau = float(t) - s0.t
        dv = s1.v - s0.v
        q = s0.q + tau * s0.v + 0.5 * tau * tau / h * dv
        v = s0.v + (tau / h) * dv
        return State(float(t), q, v, s1.a.copy(), s1.lam.copy())
