"""HHT-α for index-3 constrained mechanical systems, with GGL stabilization."""

from __future__ import annotations

from typing import ClassVar

from daebench.integrators.base import ADAPTIVE_SETTINGS, STEP_SETTINGS, Capabilities, Setting
from daebench.integrators.family import NEWTON_SETTINGS, Coefficients, NewmarkFamily, hht_coefficients

ALPHA_DEFAULT = -0.15  # the middle value of the beam-impact paper's {0, −0.15, −1/3}; ρ∞ ≈ 0.74


class HHT(NewmarkFamily):
    r"""HHT-α (Hilber–Hughes–Taylor) with GGL stabilization, index-3 position and
    velocity constraints, scaled (modified) Newton.

    Newmark updates with β = (1 − α)²/4, γ = ½ − α and the α-averaged equations
    of motion of Negrut et al. (2007)

        M a_{n+1}/(1+α) + (C_qᵀλ − Q)_{n+1} − α/(1+α) (C_qᵀλ − Q)_n = 0,
        C(q_{n+1}) = 0,   C_q v_{n+1} + C_t = 0  (GGL: q_{n+1} += C_qᵀ μ),

    solved by Newton on the scaled unknowns (q_{n+1}, βh²λ, μ); see
    :mod:`daebench.stepping.newmark` for the formulation, the scaling and the
    convergence test. In the family's terms (:mod:`daebench.integrators.family`):
    α_m = 0, α_f = −α, force averaging.

    Settings
    --------
    h, h_contact : float
        Fixed step sizes (outside / in contact).
    adaptive, rtol, atol
        Step-size control with the Zienkiewicz–Xie estimate h²(β − ⅙)(a_{n+1} − a_n).
    alpha : float in [−1/3, 0], default −0.15
        Numerical damping; α = 0 is the trapezoidal rule (no dissipation).
    ggl : bool, default True
        Enforce the velocity constraint too (stabilized index 2). Off: plain index 3.
    newton_tol, newton_maxiter, reuse_jacobian
        Newton tolerance (scaled increment and normalized constraint residuals),
        iteration limit, modified Newton on/off.

    Notes
    -----
    Order 2 in positions and velocities for every α ∈ [−1/3, 0] (γ = ½ − α
    compensates the force averaging). Unconditionally stable (A-stable) on linear
    undamped structural problems; the spectral radius at h ω → ∞ is
    ρ∞ = (1 + α)/(1 − α): 1 at α = 0 (no damping), 0.5 at α = −1/3. Low
    frequencies are damped only O((hω)³), so the response of the slow modes is
    hardly changed while high (spurious, stiff) modes are removed. On the
    index-3 DAE the multipliers and accelerations are algorithmic quantities
    that converge with order 1 after an O(h) transient for α ≠ 0 (Arnold &
    Brüls 2007); positions and velocities keep order 2.

    References
    ----------
    Hilber, Hughes & Taylor (1977), Earthquake Eng. Struct. Dyn. 5, 283–292.
    Negrut, Rampalli, Ottarsson & Sajdak (2007), "On an implementation of the
    HHT method in the context of index 3 DAEs of multibody dynamics",
    J. Comput. Nonlinear Dyn. 2, 73–85.
    Arnold & Brüls (2007), "Convergence of the generalized-α scheme for
    constrained mechanical systems", Multibody Syst. Dyn. 18, 185–202.
    Gear, Leimkuhler & Gupta (1985), J. Comput. Appl. Math. 12–13, 77–90 (GGL).
    """

    name: ClassVar[str] = "hht"
    description: ClassVar[str] = "HHT-α with GGL stabilization (index-3 positions + velocities), scaled Newton"
    capabilities: ClassVar[Capabilities] = Capabilities(
        order=2, fixed_step=True, adaptive=True, constraints=True, index=3,
        friction=True)  # Coulomb friction by the driver: stick/slip phases, Newton–Coulomb impacts
    settings_spec: ClassVar[tuple[Setting, ...]] = (
        *STEP_SETTINGS,
        *ADAPTIVE_SETTINGS,
        Setting("alpha", float, ALPHA_DEFAULT, "HHT numerical damping α (0: none, −1/3: most); "
                "β = (1−α)²/4, γ = 1/2 − α", low=-1.0 / 3.0, high=0.0),
        Setting("ggl", bool, True, "GGL stabilization: enforce the velocity constraint C_q v = 0 as well"),
        *NEWTON_SETTINGS,
    )

    def coefficients(self) -> Coefficients:
        return hht_coefficients(float(self.settings["alpha"]), bool(self.settings["ggl"]))
