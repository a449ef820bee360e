"""Nonsmooth generalized-α (Capobianco, Harsch, Eugster & Leine 2021), frictionless contact."""

from __future__ import annotations

from typing import ClassVar

from daebench.core.kernels import friction_coefficients
from daebench.stepping import nsgenalpha as _ns
from daebench.integrators.base import Capabilities, Setting
from daebench.integrators.capturing import CAPTURE_STEP_SETTINGS, CapturingIntegrator
from daebench.integrators.family import chung_hulbert


class NonsmoothGeneralizedAlpha(CapturingIntegrator):
    r"""Nonsmooth generalized-α: generalized-α on the smooth motion, a velocity jump for the
    impacts and a position correction for the gaps, with contact unknowns at three levels
    (position-level percussion κ, impulse Λ, force λ) — event-capturing, no penetration.

    Formulation, solver and the paper's equation numbers: :mod:`daebench.stepping.nsgenalpha`.
    Coefficients: the Newmark family's Chung–Hulbert set for ρ∞
    (:func:`daebench.integrators.family.chung_hulbert`), in the acceleration-averaging
    convention of Arnold & Brüls (2007) that the paper uses: the equations of motion hold at
    t_{n+1} with the true acceleration a_{n+1}, ā carries the averaging. (The paper, eq. (72),
    writes β = ¼(½ + γ)², the same number as ¼(1 − α_m + α_f)².) e is the restitution of
    the scene's ``constraint`` law (no law, ``complementarity``: e = 0).

    Settings
    --------
    h : float
        Fixed step [s]; ``h_contact`` accepted for the protocol, unused.
    rho_inf : float in [0, 1], default 0.9 (the paper's and cardillo's default)
        Spectral radius at hω → ∞; 1: no numerical dissipation (trapezoidal smooth part).
    newton_tol, newton_maxiter, reuse_jacobian :
        Semismooth Newton iteration.

    Notes
    -----
    Order: second order on smooth motion (generalized-α, γ = ½ − α_m + α_f); first order
    with impacts (impact times within h, like every fixed-step event-capturing scheme).
    Unconditionally stable on linear smooth motion, high-frequency dissipation down to ρ∞.

    Gaps: g(q_{n+1}) ≥ 0 up to the Newton tolerance at every step (the position correction
    Q = M⁻¹g_qᵀκ keeps closed contacts on g = 0), so no penetration drift, unlike Moreau–Jean.
    The velocity jump U satisfies Newton's law g_q u_{n+1} = −e g_q(q_n) u_n for a contact
    in B; the contact force λ keeps g̈ = 0 for a persistent contact (set C).

    Energy: the smooth part dissipates like generalized-α (none for ρ∞ = 1 on linear
    systems); at an impact with e = 1 the jump conserves the kinetic energy of the
    velocity-level law to round-off, the position correction changes the potential
    energy by O(h²)-small amounts.

    References
    ----------
    G. Capobianco, J. Harsch, S. R. Eugster, R. I. Leine, Int. J. Numer. Meth. Eng. 122 (2021)
    6497–6526, doi 10.1002/nme.6801 (the scheme; planar Coulomb friction as its §5,
    :mod:`daebench.stepping.nsga_friction`, at contacts with μ > 0).
    Chung & Hulbert (1993), J. Appl. Mech. 60, 371–375; Arnold & Brüls (2007), Multibody
    Syst. Dyn. 18, 185–202.
    cardillo (github.com/cardilloproject/cardillo), solver/nonsmooth_generalized_alpha.py:
    the authors' implementation, read for the index sets and the prox parameter.
    """

    name: ClassVar[str] = "nsgenalpha"
    description: ClassVar[str] = ("nonsmooth generalized-α (Capobianco et al. 2021): contact at position, "
                                  "velocity and acceleration level, no penetration; resolves contacts itself")
    capabilities: ClassVar[Capabilities] = Capabilities(order=1, fixed_step=True, adaptive=False, constraints=False,
                                                        contacts=True, friction=True)
    settings_spec: ClassVar[tuple[Setting, ...]] = (
        *CAPTURE_STEP_SETTINGS,
        Setting("rho_inf", float, 0.9, "spectral radius at h ω → ∞ (1: no dissipation, 0: most)", low=0.0,
                high=1.0),
        Setting("newton_tol", float, 1e-12, "semismooth Newton tolerance on the scaled increment of q and h·u",
                low=1e-15, high=1e-3),
        Setting("newton_maxiter", int, 30, "semismooth Newton iterations per step", low=1, high=200),
        Setting("reuse_jacobian", bool, True, "keep the factorized Jacobian across iterations and steps while "
                "the index sets are unchanged and the contraction is good"),
    )

    fail_messages = _ns.FAIL_MESSAGES

    def method(self) -> _ns.NsgaMethod:
        s = self.settings
        c = chung_hulbert(float(s["rho_inf"]))
        p, st = self.problem, self.state
        mu = friction_coefficients(p.kernel.model, p.n_contacts, st.q, st.v)
        return _ns.NsgaMethod(float(c.alpha_m), float(c.alpha_f), float(c.beta), float(c.gamma), self.restitution(),
                              float(s["newton_tol"]), int(s["newton_maxiter"]), bool(s["reuse_jacobian"]),
                              bool((mu > 0.0).any()))

    def capture_workspace(self, n: int, m: int, nc: int, steps_per_call: int) -> _ns.NsgaWork:
        return _ns.workspace(n, nc, steps_per_call, self._meth.friction)
