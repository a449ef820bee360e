"""Moreau–Jean time stepping with Newton's impact law; optional position projection."""

from __future__ import annotations

from typing import ClassVar

from daebench.core.kernels import friction_coefficients
from daebench.stepping import moreau as _mj
from daebench.integrators.base import Capabilities, Setting
from daebench.integrators.capturing import CAPTURE_STEP_SETTINGS, CapturingIntegrator


class MoreauJean(CapturingIntegrator):
    r"""Moreau–Jean: θ-method on the smooth part, contact impulses from an LCP at velocity
    level with Newton's impact law, unilateral constraint activated by the gap predicted
    over the step (event-capturing; the driver locates no impact).

    One step (formulation and solver: :mod:`daebench.stepping.moreau`)::

        v_{k+1} − v_k = h [(1−θ) a_k + θ a_{k+1}] + M⁻¹ g_qᵀ P,   a = M(q)⁻¹ Q(t, q, v)
        q_{k+1} = q_k + h [(1−θ) v_k + θ v_{k+1}]
        g_i(q_k) + γ h ġ_i ≤ 0:   0 ≤ g_q,i v_{k+1} + e g_q,i v_k  ⟂  P_i ≥ 0,   else P_i = 0

    Conventions (the literature has several): θ weights the end of the step in both the
    acceleration and the position update (Jean 1999; Siconos' MoreauJeanOSI, whose γ is the
    activation weight here too); Moreau's own midpoint scheme is θ = γ = ½ with the force
    at the midpoint. The θ-method acts on a = M⁻¹Q at each end (with a configuration-
    dependent M, weighing Q_k with M(q_{k+1})⁻¹ would be an O(h²) local error);
    M and g_q of the impulse are taken at q_{k+1}. e is the restitution of the scene's
    ``constraint`` law; without a law (``complementarity``) e = 0.

    Settings
    --------
    h : float
        Fixed step [s]. ``h_contact`` is accepted for the paper's protocol and unused (no
        phase is ever "in contact" for the driver).
    theta : float in [½, 1], default ½
        ½: the trapezoidal smooth part, second order and energy-conserving on linear
        systems; 1: backward Euler, first order, damping ≈ ω²h/2 per unit time.
    gamma : float in [0, 1], default ½
        Activation weight of the predicted gap g + γhġ ≤ 0 (Siconos' default ½).
    projection : bool, default False
        After each step, project positions with g < 0 onto g ≥ 0 along the mass metric
        (Siconos' MoreauJeanCombinedProjectionOSI, Acary 2012); velocities unchanged.
    newton_tol, newton_maxiter, reuse_jacobian :
        Newton–LCP iteration (linear systems converge in one correction).

    Notes
    -----
    Order: θ = ½ is second order on smooth motion; with impacts every fixed-step
    time-stepping scheme is first order (the impact falls anywhere inside a step: impact
    times are within h, the post-impact trajectory O(h)). Unconditionally stable on the
    smooth part for θ ≥ ½ (A-stable; θ > ½ L-damped).

    Energy: on a linear system with linear gaps and θ = ½ the balance of a step is exact
    algebra, E_{k+1} − E_k = ½ Σ_i (U_i + U_i⁻) P_i with U = g_q v_{k+1}, U⁻ = g_q v_k: zero
    without impulse, zero at an impact with e = 1 (U = −U⁻), and −½(1−e)|U⁻|P < 0 for
    e < 1 — the impact loss of the Newton law at the scheme's own velocities. θ = 1 loses
    O(h) energy in the smooth part.

    Penetration: with a linear gap and free flight under gravity g the step that ends
    before the first impulse ends at a gap > −(1−γ) h |ġ| − θ h² g, and the impulse step
    changes the gap by −h (1−θ−θe)|ġ⁻|. So θ = γ = 1 keeps every gap above −h² g (no
    drift at rest: U = 0); the default θ = γ = ½ penetrates O(h |ġ⁻|) at each impact, and
    the penetration stays (velocity-level constraint: no position feedback). With
    ``projection`` the gap is ≥ −tol·max(1,|q|) after every step.

    Friction: Coulomb's law at each contact with μ > 0 (scene key ``contact.friction``),
    the planar cone solved exactly with the normal impulses in one LCP per Newton
    iteration (:mod:`daebench.stepping.friction`): slide, stop and stick are captured
    inside the steps, first order like the impacts (the stop falls anywhere in a step).
    A frictional LCP without solution ends the run with a named status, never a loop.

    Contact episodes are reported to the run record (impact time = start of the first
    step with a positive impulse): :class:`~daebench.integrators.capturing.CapturingIntegrator`.

    References
    ----------
    J. J. Moreau, "Unilateral contact and dry friction in finite freedom dynamics", in
    Nonsmooth Mechanics and Applications, CISM 302 (1988) 1–82.
    M. Jean, "The non-smooth contact dynamics method", Comput. Methods Appl. Mech. Eng. 177
    (1999) 235–257.
    V. Acary, B. Brogliato, Numerical Methods for Nonsmooth Dynamical Systems (2008), §10.
    V. Acary, "Projected event-capturing time-stepping schemes for nonsmooth mechanical
    systems with unilateral contact and Coulomb's friction", Comput. Methods Appl. Mech.
    Eng. 256 (2013) 224–250.
    V. Acary, "Energy conservation and dissipation properties of time-integration methods
    for nonsmooth elastodynamics with contact", ZAMM 96 (2016) 585–603.
    Siconos, MoreauJeanOSI and MoreauJeanCombinedProjectionOSI (kernel/src/simulationTools).
    """

    name: ClassVar[str] = "moreau"
    description: ClassVar[str] = ("Moreau–Jean time stepping (θ-method, Newton impact law, LCP), optional "
                                  "position projection; resolves contacts itself")
    capabilities: ClassVar[Capabilities] = Capabilities(order=1, fixed_step=True, adaptive=False, constraints=False,
                                                        contacts=True, friction=True)
    settings_spec: ClassVar[tuple[Setting, ...]] = (
        *CAPTURE_STEP_SETTINGS,
        Setting("theta", float, 0.5, "θ of the smooth part (½ trapezoidal, 1 backward Euler)", low=0.5, high=1.0),
        Setting("gamma", float, 0.5, "activation weight: a contact enters the step's LCP when g + γhġ ≤ 0",
                low=0.0, high=1.0),
        Setting("projection", bool, False, "project positions onto g ≥ 0 after each step (CombinedProjection)"),
        Setting("newton_tol", float, 1e-12, "Newton–LCP tolerance on the scaled displacement increment",
                low=1e-15, high=1e-3),
        Setting("newton_maxiter", int, 20, "Newton–LCP iterations per step", low=1, high=200),
        Setting("reuse_jacobian", bool, True, "keep the factorized iteration matrix across iterations and steps "
                "while the contraction is good"),
    )

    fail_messages = _mj.FAIL_MESSAGES

    def method(self) -> _mj.MoreauMethod:
        s = self.settings
        p, st = self.problem, self.state
        mu = friction_coefficients(p.kernel.model, p.n_contacts, st.q, st.v)
        return _mj.MoreauMethod(float(s["theta"]), float(s["gamma"]), self.restitution(), bool(s["projection"]),
                                float(s["newton_tol"]), int(s["newton_maxiter"]), bool(s["reuse_jacobian"]),
                                bool((mu > 0.0).any()))

    def capture_workspace(self, n: int, m: int, nc: int, steps_per_call: int) -> _mj.MoreauWork:
        return _mj.workspace(n, nc, steps_per_call)
