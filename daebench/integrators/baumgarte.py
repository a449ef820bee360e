"""Baumgarte-stabilized acceleration-level constraints + Adams–Bashforth–Moulton 4 (PECE)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from scipy.linalg.lapack import dgesv

from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator, Setting, State, StepFailure

SNAP = 1e-6            # stretch a step by up to this fraction of h to land exactly on t_stop
BLOWUP = 1e10          # |y| above BLOWUP·max(1, |y_start|) is divergence
AB4 = np.array([55.0, -59.0, 37.0, -9.0]) / 24.0   # on f_n, f_{n−1}, f_{n−2}, f_{n−3}
AM4 = np.array([9.0, 19.0, -5.0, 1.0]) / 24.0      # on f_{n+1}^P, f_n, f_{n−1}, f_{n−2}
N_START = 3            # RK4 steps that build the history after every (re)start


class BaumgarteABM4(Integrator):
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

    # -- the right-hand side -------------------------------------------------------
    def _rhs(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """ẏ = (v, q̈) and λ at (t, y = (q, v))."""
        p = self.problem
        n, m = p.n, p.m
        q, v = y[:n], y[n:]
        M = p.mass(q)
        Q = p.force(t, q, v)
        f = np.empty(2 * n)
        f[:n] = v
        if m == 0:
            _, _, acc, info = dgesv(M, Q)
            lam = np.zeros(0)
        else:
            Cq = p.constraint_jacobian(t, q)
            rhs_c = p.constraint_gamma(t, q, v)
            if self._delta:
                rhs_c = rhs_c - 2.0 * self._delta * (Cq @ v + p.constraint_t(t, q))
            if self._eps:
                rhs_c = rhs_c - self._eps ** 2 * p.constraint(t, q)
            A = np.zeros((n + m, n + m))
            A[:n, :n] = M
            A[:n, n:] = Cq.T
            A[n:, :n] = Cq
            _, _, sol, info = dgesv(A, np.concatenate([Q, rhs_c]))
            acc, lam = sol[:n], sol[n:]
        self.counters.lu_factorizations += 1
        if info != 0:
            raise StepFailure(f"singular augmented mass matrix at t = {t:.9g}")
        f[n:] = acc
        return f, lam

    def _check(self, t: float, y: np.ndarray) -> None:
        if not np.isfinite(y).all() or float(np.abs(y).max()) > self._blowup:
            raise StepFailure(f"diverged: state {'not finite' if not np.isfinite(y).all() else 'exploded'} "
                              f"at t = {t:.9g} (h = {self.h:.3g}; explicit ABM4 needs h·ω_max < 1)")

    # -- start / step ----------------------------------------------------------------
    def _start(self) -> None:
        s = self.state
        self._delta = float(self.settings["delta"])
        self._eps = float(self.settings["epsilon"])
        self._blowup = BLOWUP * max(1.0, float(np.abs(s.q).max(initial=0.0)), float(np.abs(s.v).max(initial=0.0)))
        self._restart()

    def _restart(self) -> None:
        """Forget the history: the next N_START steps are RK4 steps."""
        s = self.state
        f, lam = self._rhs(s.t, np.concatenate([s.q, s.v]))
        self._hist = [f]  # f_n last
        self._lam = lam

    def _state(self, t: float, y: np.ndarray, f: np.ndarray, lam: np.ndarray) -> State:
        n = self.problem.n
        return State(t, y[:n].copy(), y[n:].copy(), f[n:].copy(), lam)

    def _step_impl(self, t_stop: float) -> State:
        s = self.state
        remaining = t_stop - s.t
        h = self.h
        y = np.concatenate([s.q, s.v])
        if h * (1.0 + SNAP) >= remaining and remaining < h * (1.0 - SNAP):
            # a short final step: RK4 of that size, then rebuild the history
            y1 = self._rk4(s.t, y, remaining, self._hist[-1])
            self._check(t_stop, y1)
            f1, lam1 = self._rhs(t_stop, y1)
            self._hist = [f1]
            return self._state(t_stop, y1, f1, lam1)
        t1 = t_stop if h * (1.0 + SNAP) >= remaining else s.t + h
        h = t1 - s.t
        hist = self._hist
        if len(hist) <= N_START:
            y1 = self._rk4(s.t, y, h, hist[-1])
        else:
            fn, fn1, fn2, fn3 = hist[-1], hist[-2], hist[-3], hist[-4]
            yp = y + h * (AB4[0] * fn + AB4[1] * fn1 + AB4[2] * fn2 + AB4[3] * fn3)
            self._check(t1, yp)
            fp, _ = self._rhs(t1, yp)
            y1 = y + h * (AM4[0] * fp + AM4[1] * fn + AM4[2] * fn1 + AM4[3] * fn2)
        self._check(t1, y1)
        f1, lam1 = self._rhs(t1, y1)
        hist.append(f1)
        if len(hist) > 4:
            del hist[0]
        return self._state(t1, y1, f1, lam1)

    def _rk4(self, t: float, y: np.ndarray, h: float, f0: np.ndarray) -> np.ndarray:
        k1 = f0
        k2, _ = self._rhs(t + 0.5 * h, y + (0.5 * h) * k1)
        k3, _ = self._rhs(t + 0.5 * h, y + (0.5 * h) * k2)
        k4, _ = self._rhs(t + h, y + h * k3)
        return y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
