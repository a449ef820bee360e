"""Baumgarte-stabilized acceleration-level constraints + Adams–Bashforth–Moulton 4 (PECE)."""

from __future__ import annotations

from typing import ClassVar

from daebench.integrators.base import STEP_SETTINGS, Capabilities, Setting
from daebench.integrators.compiled import CompiledIntegrator
from daebench.stepping import abm as _abm
from daebench.stepping.stability import AbmPece


class BaumgarteABM4(CompiledIntegrator):
    r"""Baumgarte stabilization at acceleration level, integrated with the
    4th-order Adams–Bashforth–Moulton predictor–corrector (PECE) at fixed step.

    Each evaluation of the right-hand side solves

        [[M, C_qᵀ], [C_q, 0]] [q̈; λ] = [Q; γ − 2δ (C_q v + C_t) − ε² C],

    i.e. the constraint is replaced by C̈ + 2δ Ċ + ε² C = 0 (index 1), and
    y = (q, v) is integrated with ẏ = (v, q̈). In Baumgarte's (1972) notation
    C̈ + 2α Ċ + β² C = 0, δ = α is the damping rate [1/s] and ε = β the natural
    frequency [rad/s] of the constraint-violation dynamics; δ = ε critically
    damps it. δ = ε = 0 is the unstabilized acceleration form, whose drift grows
    like t² (C) and t (Ċ).

    Stepping: AB4 predictor, evaluate, AM4 (3-step Adams–Moulton) corrector,
    evaluate — two right-hand sides per step. The history f_{n−3..n} is built by
    three classical RK4 steps after every :meth:`start` (the driver restarts after
    each event). A step shorter than h (landing on ``t_stop``) is an RK4 step of that
    size, after which the history is rebuilt.

    Settings
    --------
    h, h_contact : float
        Fixed step sizes.
    delta, epsilon : float ≥ 0, default 0
        Baumgarte parameters (the beam-impact paper uses (0, 0), (10, 50), (1000, 5000)).

    Notes
    -----
    Order 4 (the index-1 ODE; with δ = ε = 0 its solution from consistent values
    is the exact constrained motion). Explicit, hence only conditionally stable:
    on y′ = λy the PECE pair is stable for real hλ ∈ (−1.285, 0); on the imaginary
    axis (undamped oscillation, hω) it has no interval of strict stability — the
    amplification grows as |ζ| − 1 ≈ 1.6e-7 at hω = 0.1, 5e-4 at 0.4, 7e-3 at 0.8
    (consistent with its O(h⁵) local error), and becomes violent beyond
    hω ≈ 0.93 (|ζ| = 1.12 at hω = 1). Stiff modes (axial stretch of a beam, a Hertz
    contact) therefore make it diverge unless h ω_max < 1; large ε, δ add the
    stiff eigenvalues −δ ± √(δ² − ε²) of the violation dynamics. A non-finite
    state or one beyond ``BLOWUP`` times its start size raises
    ``StepFailure("diverged: …")``.

    The step is the compiled stepper :mod:`daebench.stepping.abm`, run by the common
    loop of :class:`~daebench.integrators.compiled.CompiledIntegrator` on every model.

    References
    ----------
    Baumgarte (1972), "Stabilization of constraints and integrals of motion in
    dynamical systems", Comput. Methods Appl. Mech. Eng. 1, 1–16.
    Hairer, Nørsett & Wanner (1993), Solving Ordinary Differential Equations I,
    §III.1 (Adams methods), §III.3 (predictor–corrector stability).
    Flores, Machado, Seabra & Pereira (2011), J. Comput. Nonlinear Dyn. 6, 011019
    (Baumgarte parameters in multibody dynamics).
    """


    name: ClassVar[str] = "baumgarte"
    description: ClassVar[str] = "Baumgarte-stabilized acceleration form + Adams–Bashforth–Moulton 4 (RK4 start)"
    capabilities: ClassVar[Capabilities] = Capabilities(
        order=4, fixed_step=True, adaptive=False, constraints=True, index=1)
    settings_spec: ClassVar[tuple[Setting, ...]] = (
        *STEP_SETTINGS,
        Setting("delta", float, 0.0, "Baumgarte damping δ in C̈ + 2δĊ + ε²C = 0 (Baumgarte's α) [1/s]",
                low=0.0, high=1e9),
        Setting("epsilon", float, 0.0, "Baumgarte stiffness ε in C̈ + 2δĊ + ε²C = 0 (Baumgarte's β) [rad/s]",
                low=0.0, high=1e9),
    )

    fail_messages = _abm.FAIL_MESSAGES

    def method(self) -> _abm.AbmMethod:
        return _abm.AbmMethod(float(self.settings["delta"]), float(self.settings["epsilon"]), float(self.h))

    def workspace(self, n: int, m: int) -> _abm.AbmWork:
        return _abm.workspace(n, m)

    def stability_model(self) -> AbmPece:
        return AbmPece()
