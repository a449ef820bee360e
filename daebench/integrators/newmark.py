"""Newmark-β for ODE models and index-3 constraints."""

from __future__ import annotations

from typing import ClassVar

from daebench.integrators.base import (ADAPTIVE_SETTINGS, STEP_SETTINGS, Capabilities, IntegratorError,
                                       Setting)
from daebench.integrators.family import NEWTON_SETTINGS, Coefficients, NewmarkFamily


NEWTON_FAILURES = (1, 2, 3)   # stepping.newmark.FAIL_MESSAGES: non-finite residual / iterate, no convergence


class Newmark(NewmarkFamily):
    r"""Newmark-β: the trapezoidal rule (β = ¼, γ = ½) by default.

        q_{n+1} = q_n + h v_n + h² [(½ − β) a_n + β a_{n+1}],
        v_{n+1} = v_n + h [(1 − γ) a_n + γ a_{n+1}],
        M(q_{n+1}) a_{n+1} + C_qᵀ λ_{n+1} = Q(t_{n+1}, q_{n+1}, v_{n+1}),   C(t_{n+1}, q_{n+1}) = 0.

    For m = 0 (e.g. a Hertz or penalty contact law) it is the classical implicit
    Newmark scheme; with constraints the position constraint is enforced by the
    multiplier at t_{n+1} (index 3, no velocity stabilization: C_q v drifts at
    O(h²)). It is the family member α_m = α_f = 0 without GGL and shares its
    code (:mod:`daebench.stepping.newmark`), including the scaled Newton
    iteration and the optional adaptive step control.

    Settings
    --------
    beta : float in (0, ½], default ¼
        β = 0 (explicit central differences) cannot enforce position constraints
        and is refused.
    gamma : float in [½, 1], default ½
    h, h_contact, adaptive, rtol, atol, newton_tol, newton_maxiter, reuse_jacobian
        As for :class:`~daebench.integrators.hht.HHT`.

    Notes
    -----
    Order 2 if γ = ½, else order 1 (the declared order, 2, assumes γ = ½).
    Linear stability: unconditionally stable for 2β ≥ γ ≥ ½; γ = ½ is
    non-dissipative (ρ∞ = 1 for β = ¼, the average-acceleration / trapezoidal
    rule, which conserves the energy of linear systems exactly); γ > ½ adds
    first-order numerical damping. For 2β < γ it is only conditionally stable,
    hω ≤ 1/√(γ/2 − β).

    On the index-3 form the trapezoidal choice γ = ½ does not damp the spurious
    oscillation of the multiplier (and of the algorithmic acceleration): it grows
    from step to step (Cardona & Géradin 1989). On the pendulum at h = 0.01 the
    multiplier error grows from 2e-2 (t ≤ 1 s) to 8 (t ≈ 4 s) until Newton fails
    near t ≈ 7 s, while positions stay accurate for a while. Use γ > ½ (with
    β = (γ + ½)²/4), or HHT-α with GGL, for long constrained runs.

    References
    ----------
    Newmark (1959), "A method of computation for structural dynamics",
    J. Eng. Mech. Div. ASCE 85, 67–94.
    Cardona & Géradin (1989), "Time integration of the equations of motion in
    mechanism analysis", Comput. Struct. 33, 801–820.
    Géradin & Cardona (2001), Flexible Multibody Dynamics: A Finite Element
    Approach, Wiley, ch. 12.
    """

    name: ClassVar[str] = "newmark"
    description: ClassVar[str] = "Newmark-β (default trapezoidal) for ODE models and index-3 constraints"
    capabilities: ClassVar[Capabilities] = Capabilities(
        order=2, fixed_step=True, adaptive=True, constraints=True, index=3,
        friction=True)  # Coulomb friction by the driver: stick/slip phases, Newton–Coulomb impacts
    settings_spec: ClassVar[tuple[Setting, ...]] = (
        *STEP_SETTINGS,
        *ADAPTIVE_SETTINGS,
        Setting("beta", float, 0.25, "Newmark β (position weight of a_{n+1}); > 0", low=0.0, high=0.5),
        Setting("gamma", float, 0.5, "Newmark γ (velocity weight of a_{n+1}); 1/2: 2nd order, no damping",
                low=0.5, high=1.0),
        *NEWTON_SETTINGS,
    )

    def _check_settings(self) -> None:
        if self.settings["beta"] <= 0.0:
            raise IntegratorError(
                "integrator 'newmark' setting 'beta' = 0 is the explicit central-difference scheme, which "
                "cannot enforce position constraints; use beta > 0 (0.25 = trapezoidal rule)")

    def coefficients(self) -> Coefficients:
        return Coefficients(0.0, 0.0, float(self.settings["beta"]), float(self.settings["gamma"]), False, False)

    def _message(self, status: int) -> str:
        """The stepper's failure text; a Newton failure of undamped Newmark (γ = ½) on
        constraints also names its known cause and the fix (see the class docstring)."""
        text = super()._message(status)
        constrained = self.problem is not None and getattr(self.problem, "m", 0) > 0
        if int(status) in NEWTON_FAILURES and constrained and self.settings["gamma"] <= 0.5:
            text += (" — the known weak instability of undamped trapezoidal Newmark (γ = ½) on index-3 "
                     "constraints: the multiplier's spurious oscillation grows from step to step until Newton "
                     "fails (Cardona & Géradin 1989); use hht or genalpha, or damp it with --opt gamma=0.6 "
                     "--opt beta=0.3025 (β = (γ + ½)²/4)")
        return text
