"""Baumgarte-stabilized acceleration-level constraints + Adams–Bashforth–Moulton 4 (PECE)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from scipy.linalg.lapack import dgesv

from daebench.integrators import _compiled_abm as _ca
from daebench.integrators import _compiled_models as _cm
from daebench.integrators.base import STEP_SETTINGS, BatchWatch, Capabilities, Integrator, Setting, State, StepFailure
from daebench.system import Problem

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

    Compiled path: when the model exposes compiled kernels
    (:func:`daebench.integrators._compiled_models.descriptor`), the right-hand side,
    the step and a fixed-step phase runner (:meth:`advance`, many quiet steps per call)
    run in numba (:mod:`daebench.integrators._compiled_abm`), with the f history in
    arrays owned by the integrator. Same operations in the same order; the two paths
    differ by round-off only (the LU's summation order). ``DAEBENCH_COMPILED=0`` forces
    the Python path.

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

    # compiled path: the model descriptor of the current phase (None → Python path) and the
    # history arrays (see daebench.integrators._compiled_abm), set by _start
    _md: tuple | None = None
    _c_hist: np.ndarray | None = None

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
            raise StepFailure(self._diverged_message(not np.isfinite(y).all(), t))

    def _diverged_message(self, not_finite: bool, t: float) -> str:
        return (f"diverged: state {'not finite' if not_finite else 'exploded'} "
                f"at t = {t:.9g} (h = {self.h:.3g}; explicit ABM4 needs h·ω_max < 1)")

    # -- start / step ----------------------------------------------------------------
    def _start(self) -> None:
        s = self.state
        self._delta = float(self.settings["delta"])
        self._eps = float(self.settings["epsilon"])
        self._blowup = BLOWUP * max(1.0, float(np.abs(s.q).max(initial=0.0)), float(np.abs(s.v).max(initial=0.0)))
        # compiled path (daebench.integrators._compiled_abm) when the model exposes kernels;
        # the history lives in arrays (kept across phases while n is unchanged) so that
        # single steps and the phase runner interleave
        p = self.problem
        self._md = _cm.descriptor(p.system)
        if self._md is not None:
            n = p.n
            if self._c_hist is None or self._c_hist.shape != (4, 2 * n):
                self._c_hist = np.zeros((4, 2 * n))
                self._c_hn = np.zeros(1, dtype=np.int64)
                self._c_cnt = np.zeros(2, dtype=np.int64)
                self._c_cnt0 = np.zeros(2, dtype=np.int64)
            self._c_active = np.array(p.active, dtype=np.int64)
        self._restart()

    def _restart(self) -> None:
        """Forget the history: the next N_START steps are RK4 steps."""
        s = self.state
        if self._md is not None:
            lam = np.empty(self.problem.m)
            status = _ca.restart(self._md, self._c_active, float(s.t), np.concatenate([s.q, s.v]), lam,
                                 self._c_hist, self._c_hn, self._delta, self._eps, self._c_cnt)
            self._sync_compiled()
            if status:
                raise StepFailure(self._fail_message(status, s.t))
            self._lam = lam
            return
        f, lam = self._rhs(s.t, np.concatenate([s.q, s.v]))
        self._hist = [f]  # f_n last
        self._lam = lam

    def _state(self, t: float, y: np.ndarray, f: np.ndarray, lam: np.ndarray) -> State:
        n = self.problem.n
        return State(t, y[:n].copy(), y[n:].copy(), f[n:].copy(), lam)

    def _step_impl(self, t_stop: float) -> State:
        if self._md is not None:
            return self._step_compiled(t_stop)
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

    # -- compiled path -------------------------------------------------------------------
    def _sync_compiled(self) -> None:
        """Move the compiled counters into the integrator's and the problem's counters
        (one force evaluation and one LU per right-hand side, as in :meth:`_rhs`)."""
        d = self._c_cnt - self._c_cnt0
        self._c_cnt0[:] = self._c_cnt
        self.problem.counters.residual_evals += int(d[_ca.C_RES])
        self.counters.lu_factorizations += int(d[_ca.C_LU])

    def _fail_message(self, status: int, t: float) -> str:
        if status == _ca.ST_SINGULAR:
            return f"singular augmented mass matrix at t = {t:.9g}"
        return self._diverged_message(status == _ca.ST_NOT_FINITE, t)

    def _step_compiled(self, t_stop: float) -> State:
        s = self.state
        n = self.problem.n
        y = np.concatenate([s.q, s.v])
        lam = np.empty(self.problem.m)
        status, t_new, t_fail = _ca.step_once(
            self._md, self._c_active, float(s.t), float(t_stop), float(self.h), y, lam, self._c_hist, self._c_hn,
            self._delta, self._eps, self._blowup, self._c_cnt)
        self._sync_compiled()
        if status:
            raise StepFailure(self._fail_message(status, t_fail))
        return State(t_new, y[:n].copy(), y[n:].copy(), self._c_hist[self._c_hn[0] - 1, n:].copy(), lam)

    def can_advance(self, problem: Problem) -> bool:
        return self._md is not None and problem is self.problem

    def advance(self, t_stop: float, watch: BatchWatch | None = None) -> State:
        """Fixed-step phase runner (:func:`daebench.integrators._compiled_abm.run_fixed`):
        many steps per call, stopping after the first step the driver must see."""
        if watch is None or not self.can_advance(self.problem):
            return self.step(t_stop)
        s = self.state
        if t_stop <= s.t:
            raise ValueError(f"t_stop = {t_stop} is not after t = {s.t}")
        n, m = self.problem.n, self.problem.m
        y = np.concatenate([s.q, s.v])
        a, lam = s.a.copy(), s.lam.copy()
        py, pa, plam = np.empty(2 * n), np.empty(n), np.empty(m)
        status, k, t_prev, t_now, t_fail = _ca.run_fixed(
            self._md, self._c_active, watch.inactive, watch.lam_rows, watch.armed, bool(watch.continuous),
            bool(watch.track), watch.cmax, float(s.t), y, a, lam, float(self.h), float(t_stop),
            float(watch.t_out_next), float(watch.t_end), int(watch.max_steps), self._delta, self._eps,
            self._blowup, self._c_hist, self._c_hn, self._c_cnt, py, pa, plam)
        self._sync_compiled()
        if k:
            self.counters.steps += k
            self.prev = State(t_prev, py[:n].copy(), py[n:].copy(), pa, plam)
            self.state = State(t_now, y[:n].copy(), y[n:].copy(), a, lam)
        if status:
            raise StepFailure(self._fail_message(status, t_fail))
        return self.state
