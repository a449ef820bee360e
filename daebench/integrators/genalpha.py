"""Generalized-α for index-3 constrained mechanical systems (a Newmark-family member)."""

from __future__ import annotations

from typing import ClassVar

from daebench.integrators.base import ADAPTIVE_SETTINGS, STEP_SETTINGS, Capabilities, Setting
from daebench.integrators.family import NEWTON_SETTINGS, Coefficients, NewmarkFamily, chung_hulbert


class GeneralizedAlpha(NewmarkFamily):
    r"""Generalized-α (Chung & Hulbert 1993) in the index-3 form of Arnold & Brüls (2007).

    Convention (the literature has several): the equations of motion hold at t_{n+1}
    with the true acceleration q̈_{n+1}, and an acceleration-like variable a carries
    the averaging,

        (1 − α_m) a_{n+1} + α_m a_n = (1 − α_f) q̈_{n+1} + α_f q̈_n,     a_0 = q̈_0,
        q_{n+1} = q_n + h v_n + h² [(½ − β) a_n + β a_{n+1}],
        v_{n+1} = v_n + h [(1 − γ) a_n + γ a_{n+1}],
        M(q_{n+1}) q̈_{n+1} + C_qᵀ λ_{n+1} = Q_{n+1},     C(q_{n+1}) = 0,

    with the Chung–Hulbert coefficients from the spectral radius ρ∞ at h ω → ∞:
    α_m = (2ρ∞ − 1)/(ρ∞ + 1), α_f = ρ∞/(ρ∞ + 1), γ = ½ − α_m + α_f,
    β = ¼ (1 − α_m + α_f)². (Chung and Hulbert write α_f, α_m for the weights of the
    *old* values, as here; some texts use 1 − α.) The history after a restart starts
    from a_0 = q̈_0 (no O(h) start correction). Solved by the scaled Newton iteration of
    :mod:`daebench.stepping.newmark`; ``ggl = true`` enforces C_q v = 0 as well
    (stabilized index 2).

    Settings
    --------
    rho_inf : float in [0, 1], default 0.74 (the ρ∞ of HHT α = −0.15)
    ggl : bool, default False (plain index 3, as Arnold & Brüls)
    h, h_contact, adaptive, rtol, atol, newton_tol, newton_maxiter, reuse_jacobian
        As for :class:`~daebench.integrators.hht.HHT`.

    Notes
    -----
    Second order in q and v for every ρ∞ (γ = ½ − α_m + α_f); unconditionally stable
    for linear undamped systems (α_m ≤ α_f ≤ ½); numerical dissipation of the high
    frequencies down to ρ∞, minimal at low frequencies. On index-3 problems q, v
    converge with order 2; λ and q̈ may show an O(h) start-up transient (Arnold & Brüls
    2007) that the a_0 = q̈_0 start does not remove.

    References
    ----------
    Chung & Hulbert (1993), J. Appl. Mech. 60, 371–375.
    Arnold & Brüls (2007), Multibody Syst. Dyn. 18, 185–202.
    """

    name: ClassVar[str] = "genalpha"
    description: ClassVar[str] = "generalized-α (Chung–Hulbert ρ∞, Arnold–Brüls index-3 form), scaled Newton"
    capabilities: ClassVar[Capabilities] = Capabilities(
        order=2, fixed_step=True, adaptive=True, constraints=True, index=3,
        friction=True)  # Coulomb friction by the driver: stick/slip phases, Newton–Coulomb impacts
    settings_spec: ClassVar[tuple[Setting, ...]] = (
        *STEP_SETTINGS,
        *ADAPTIVE_SETTINGS,
        Setting("rho_inf", float, 0.74, "spectral radius at h ω → ∞ (1: no dissipation, 0: most)",
                low=0.0, high=1.0),
        Setting("ggl", bool, False, "GGL stabilization: enforce the velocity constraint C_q v = 0 as well"),
        *NEWTON_SETTINGS,
    )

    def coefficients(self) -> Coefficients:
        return chung_hulbert(float(self.settings["rho_inf"]))._replace(ggl=bool(self.settings["ggl"]))
