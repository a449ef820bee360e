"""Shared core of the Newmark family: Newmark-β, HHT-α and HHT-α with GGL stabilization.

One step from (q_n, v_n, a_n, λ_n) to t_{n+1} = t_n + h solves, for the unknowns
x = (q_{n+1}, λ̃ = βh² λ_{n+1}, μ):

    a_{n+1} = (q_{n+1} − q̂ − C_qᵀ μ) / (βh²),       q̂ = q_n + h v_n + (½ − β) h² a_n
    v_{n+1} = v̂ + γ h a_{n+1},                         v̂ = v_n + (1 − γ) h a_n

    r1 = βh² [ M a_{n+1}/(1+α) + (C_qᵀλ − Q)_{n+1} − α/(1+α) (C_qᵀλ − Q)_n ] = 0     (n)
    r2 = C(t_{n+1}, q_{n+1})                                                        = 0     (m)
    r3 = (βh/γ) [ C_q v_{n+1} + C_t ]                                               = 0     (m, GGL only)

* α = 0 and no r3 (μ ≡ 0): Newmark-β with the position constraint enforced by the
  multiplier at t_{n+1} (index 3).
* α ∈ [−1/3, 0], β = (1−α)²/4, γ = ½ − α: HHT-α in the form of Negrut, Rampalli,
  Ottarsson & Sajdak (2007), eq. (8): the mass term is taken at t_{n+1}, the forces
  are averaged between t_n and t_{n+1}.
* With r3: the stabilized index-2 (GGL) variant of Arnold & Brüls (2007): q_{n+1}
  gets the extra correction C_qᵀμ so that both C = 0 and Ċ = 0 hold at every step.
  The correction does not enter a_{n+1} and v_{n+1} except through the velocity
  constraint; μ is O(h³) on smooth solutions, so the order is unchanged.

Scaling (why the iteration matrix stays well conditioned as h → 0). The unknown
is q_{n+1} itself, so the constraint rows r2 have the O(1) Jacobian C_q; the
equations of motion are multiplied by βh² and the multiplier is replaced by
λ̃ = βh² λ, so that

    J = [[ M/(1+α) + βh²(K_M/(1+α) + K_C − K_q) − γh K_v ,  C_qᵀ ,  −(M/(1+α) − γh K_v) C_qᵀ ],
         [ C_q                                            ,  0    ,  0                        ],
         [ C_q                                            ,  0    ,  −C_q C_qᵀ                ]]

with K_q = ∂Q/∂q, K_v = ∂Q/∂v, K_M = ∂(M a)/∂q, K_C = ∂(C_qᵀλ)/∂q. Every block
is O(1) for h → 0 (this is the 1/(βh²) row / βh² column scaling of Bottasso, Bauchau
& Cardona 2007 expressed through the choice of unknowns). Two small terms are left
out of J — (βh/γ)∂(C_q v)/∂q in the last row and ∂(C_qᵀμ)/∂q — which costs nothing
but a contraction rate O(h) of the (already modified) Newton iteration.

Newton: the factorized J is kept across iterations and steps (modified Newton)
while the contraction rate stays below ``NEWTON_RATE_REFRESH``; a poor rate, a
step size far from the one J was built for, or a failed iteration with a stale J
triggers a refresh. Convergence: the scaled increment
max(|Δq|, |Δμ|, |Δλ̃|/m_s)/max(1, |q|) (m_s the largest mass-matrix diagonal) —
or its rate-based estimate ρ/(1−ρ)|Δ| — is below ``newton_tol``, and the
constraint residuals of the new iterate, normalized by the row norms of C_q, are
below ``newton_tol`` too (positions: relative to max(1,|q|), velocities:
``VEL_TOL_FACTOR``·newton_tol relative to max(1,|v|), but never below the
round-off of a velocity computed as a displacement difference times γ/(βh)).
The default newton_tol = 1e-12 keeps the accumulated Newton error near 1 % of
the discretization error on the pendulum at h = 1.25e-3; the velocity test is
the one that binds, because a velocity error δv per step grows into a position
error ~ T²δv/(2h). Only cheap constraint functions are re-evaluated for that check.

Adaptive mode: the local error estimate of Zienkiewicz & Xie (1991),
e = h² |β − ⅙| (a_{n+1} − a_n) (for |β − ⅙| < 10⁻³ the coefficient is replaced by
``ZX_MIN_COEFF`` so that the estimate never vanishes), measured in the RMS norm
weighted by atol + rtol |q|; step factor SAFETY·err^(−1/3) clipped to
[FAC_MIN, FAC_MAX]. A Newton failure in adaptive mode shrinks the step by
``FAC_NEWTON_FAIL``; both kinds of retry count as rejected steps.

References
----------
Hilber, Hughes & Taylor (1977), Earthquake Eng. Struct. Dyn. 5, 283–292.
Negrut, Rampalli, Ottarsson & Sajdak (2007), J. Comput. Nonlinear Dyn. 2, 73–85.
Arnold & Brüls (2007), Multibody Syst. Dyn. 18, 185–202.
Bottasso, Bauchau & Cardona (2007), SIAM J. Sci. Comput. 29, 397–414.
Zienkiewicz & Xie (1991), Earthquake Eng. Struct. Dyn. 20, 871–887.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dgetrf, dgetrs

from daebench.integrators import _compiled_models as _cm
from daebench.integrators import _compiled_newmark as _cn
from daebench.integrators.base import Integrator, Setting, State, StepFailure
from daebench.system import central_difference

NEWTON_RATE_REFRESH = 0.1    # contraction rate above which a reused iteration matrix is rebuilt
NEWTON_RATE_DIVERGE = 2.0    # rate above which a fresh-matrix iteration is declared divergent
JAC_H_RATIO = 2.0            # rebuild the matrix when h differs by more than this factor from its h
VEL_TOL_FACTOR = 10.0        # velocity-constraint residual tolerance relative to newton_tol·max(1, |v|)
ROUNDOFF = 50.0 * np.finfo(float).eps  # relative residual floor the Newton test never asks to beat
SNAP = 1e-6                  # stretch a step by up to this fraction of h to land exactly on t_stop
SAFETY = 0.9                 # step-size controller safety factor
FAC_MIN, FAC_MAX = 0.2, 5.0  # bounds of the step-size change factor
FAC_NEWTON_FAIL = 0.25       # step shrink after a Newton failure (adaptive mode)
H_MIN_REL = 1e-12            # smallest step relative to max(1, |t|) before giving up
ZX_MIN_COEFF = 1.0 / 24.0    # error coefficient used when β = 1/6 makes h²(β − 1/6) vanish

NEWTON_SETTINGS = (
    Setting("newton_tol", float, 1e-12, "Newton tolerance on the scaled displacement increment and "
            "the normalized constraint residuals", low=1e-15, high=1e-3),
    Setting("newton_maxiter", int, 8, "Newton iterations per attempt before the matrix is rebuilt / "
            "the step fails", low=1, high=100),
    Setting("reuse_jacobian", bool, True, "modified Newton: keep the factorized iteration matrix across "
            "iterations and steps while the contraction rate is good"),
)


class _Fail(Exception):
    """Newton did not converge (internal; turned into StepFailure or a step rejection)."""


class NewmarkFamily(Integrator):
    """Base of :class:`~daebench.integrators.newmark.Newmark` and
    :class:`~daebench.integrators.hht.HHT` (see the module docstring).

    Subclasses implement :meth:`_coefficients` returning (α, β, γ, ggl).
    """

    def _coefficients(self) -> tuple[float, float, float, bool]:
        raise NotImplementedError

    # -- start ------------------------------------------------------------------
    def _start(self) -> None:
        p, s = self.problem, self.state
        alpha, beta, gamma, ggl = self._coefficients()
        self._alpha, self._beta, self._gamma = alpha, beta, gamma
        self._ggl = bool(ggl) and p.m > 0
        n, m = p.n, p.m
        self._nx = n + m + (m if self._ggl else 0)
        # F_n = (C_qᵀλ − Q)_n, the force average HHT needs (unused for α = 0)
        if alpha != 0.0:
            Q = p.force(s.t, s.q, s.v)
            F = -Q
            if m:
                F = F + p.constraint_jacobian(s.t, s.q).T @ s.lam
            self._F = F
        else:
            self._F = np.zeros(n)
        if s.a.size != n:
            raise ValueError("start() needs a consistent state with accelerations a (use Problem.acceleration)")
        if s.lam.size != m:
            raise ValueError(f"start() needs {m} multipliers in state.lam, got {s.lam.size}")
        self._lu = None
        self._lu_h = 0.0
        self._h_next = self.h
        self._prev_al: tuple[float, np.ndarray, np.ndarray] | None = None  # (h, a, λ) of the step before
        # compiled path (daebench.integrators._compiled_newmark): the same Newton iteration in numba
        # when the model exposes kernels; its iteration state lives in arrays
        self._md = _cm.descriptor(p.system)
        if self._md is not None:
            nx = self._nx
            self._F = np.ascontiguousarray(self._F, dtype=float)
            self._c_active = np.array(p.active, dtype=np.int64)
            self._c_st = np.zeros(4)
            self._c_LU = np.zeros((nx, nx))
            self._c_piv = np.zeros(nx, dtype=np.int64)
            self._c_aold = np.zeros(n)
            self._c_lold = np.zeros(m)
            self._c_cnt = np.zeros(4, dtype=np.int64)
            self._c_cnt0 = np.zeros(4, dtype=np.int64)

    # -- one accepted step ------------------------------------------------------------
    def _step_impl(self, t_stop: float) -> State:
        s = self.state
        adaptive = self.adaptive
        h_min = H_MIN_REL * max(1.0, abs(s.t))
        while True:
            remaining = t_stop - s.t
            h_try = self._h_next if adaptive else self.h
            h = remaining if h_try * (1.0 + SNAP) >= remaining else h_try
            try:
                q, v, a, lam, F = self._newton(h)
            except _Fail as exc:
                if not adaptive:
                    raise StepFailure(f"{exc} (t = {s.t:.9g}, h = {h:.3g})") from None
                self.counters.rejected += 1
                self._h_next = FAC_NEWTON_FAIL * h
                if self._h_next < h_min:
                    raise StepFailure(f"step size underflow after Newton failure: {exc} (t = {s.t:.9g})") from None
                continue
            if adaptive:
                err = self._error_norm(h, q, a)
                if err > 1.0:
                    self.counters.rejected += 1
                    self._h_next = h * max(FAC_MIN, SAFETY * err ** (-1.0 / 3.0))
                    if self._h_next < h_min:
                        raise StepFailure(f"step size underflow (t = {s.t:.9g}, local error {err:.3g})")
                    continue
                fac = FAC_MAX if err == 0.0 else min(FAC_MAX, SAFETY * err ** (-1.0 / 3.0))
                # a step cut short to land on t_stop says nothing against the step it replaced
                self._h_next = max(h * fac, h_try) if h < h_try else h * fac
            self._F = F
            self._prev_al = (h, s.a, s.lam)
            if self._md is not None:
                self._c_aold[:] = s.a
                self._c_lold[:] = s.lam
                self._c_st[_cn.ST_PREV] = 1.0
                self._c_st[_cn.ST_HOLD] = h
            t_new = t_stop if h == remaining else s.t + h
            return State(t_new, q, v, a, lam)

    def _error_norm(self, h: float, q: np.ndarray, a: np.ndarray) -> float:
        """Zienkiewicz–Xie local error estimate in the weighted RMS norm."""
        s = self.state
        c = abs(self._beta - 1.0 / 6.0)
        if c < 1e-3:
            c = ZX_MIN_COEFF
        e = (c * h * h) * (a - s.a)
        w = self.settings["atol"] + self.settings["rtol"] * np.maximum(np.abs(q), np.abs(s.q))
        return float(np.sqrt(np.mean((e / w) ** 2)))

    # -- compiled path -------------------------------------------------------------------
    def _coeff_args(self) -> tuple:
        s = self.settings
        return (self._alpha, self._beta, self._gamma, self._ggl, float(s["newton_tol"]),
                int(s["newton_maxiter"]), bool(s["reuse_jacobian"]))

    def _sync_compiled(self) -> None:
        """Move the compiled counters into the integrator's and the problem's counters."""
        d = self._c_cnt - self._c_cnt0
        self._c_cnt0[:] = self._c_cnt
        self.counters.newton_iterations += int(d[_cn.C_NEWTON])
        self.counters.lu_factorizations += int(d[_cn.C_LU])
        self.problem.counters.residual_evals += int(d[_cn.C_RES])
        self.problem.counters.jacobian_evals += int(d[_cn.C_JAC])

    def _fail_message(self, status: int) -> str:
        return _cn.FAIL_MESSAGES[status].format(maxiter=self.settings["newton_maxiter"])

    def _newton_compiled(self, h: float):
        s = self.state
        n, m = self.problem.n, self.problem.m
        out = (np.empty(n), np.empty(n), np.empty(n), np.empty(m), np.empty(n))
        status = _cn.newton_once(self._md, self._c_active, float(s.t), s.q, s.v, s.a, s.lam, self._F, float(h),
                                 *self._coeff_args(), self._c_st, self._c_LU, self._c_piv, self._c_aold,
                                 self._c_lold, self._c_cnt, *out)
        self._sync_compiled()
        if status:
            raise _Fail(self._fail_message(status))
        return out

    def can_advance(self, problem) -> bool:
        return self._md is not None and problem is self.problem

    def advance(self, t_stop: float, watch=None) -> State:
        """Phase runner (:func:`daebench.integrators._compiled_newmark.run_phase`), fixed
        or adaptive step: many steps per call, stopping after the first step the driver
        must see."""
        if watch is None or not self.can_advance(self.problem):
            return self.step(t_stop)
        s = self.state
        if t_stop <= s.t:
            raise ValueError(f"t_stop = {t_stop} is not after t = {s.t}")
        n, m = self.problem.n, self.problem.m
        q, v, a, lam = s.q.copy(), s.v.copy(), s.a.copy(), s.lam.copy()
        pq, pv, pa, plam = np.empty(n), np.empty(n), np.empty(n), np.empty(m)
        ctl = np.array([float(self.adaptive), self.settings["rtol"], self.settings["atol"], H_MIN_REL,
                        self._h_next, 0.0, 0.0, 0.0])
        status, k, t_prev, t_now, h_fail = _cn.run_phase(
            self._md, self._c_active, watch.inactive, watch.lam_rows, watch.armed, bool(watch.continuous),
            bool(watch.track), watch.cmax, float(s.t), q, v, a, lam, self._F, float(self.h), float(t_stop),
            float(watch.t_out_next), float(watch.t_end), int(watch.max_steps), *self._coeff_args(),
            self._c_st, self._c_LU, self._c_piv, self._c_aold, self._c_lold, self._c_cnt, pq, pv, pa, plam, ctl)
        self._sync_compiled()
        self._h_next = float(ctl[_cn.CTL_HNEXT])
        self.counters.rejected += int(ctl[_cn.CTL_REJECTED])
        if k:
            self.counters.steps += k
            self.prev = State(t_prev, pq, pv, pa, plam)
            self.state = State(t_now, q, v, a, lam)
        t_fail = self.state.t
        if status == _cn.UNDERFLOW_NEWTON:
            raise StepFailure(f"step size underflow after Newton failure: "
                              f"{self._fail_message(int(ctl[_cn.CTL_NEWTON]))} (t = {t_fail:.9g})")
        if status == _cn.UNDERFLOW_ERROR:
            raise StepFailure(f"step size underflow (t = {t_fail:.9g}, local error {ctl[_cn.CTL_ERR]:.3g})")
        if status:
            raise StepFailure(f"{self._fail_message(status)} (t = {t_fail:.9g}, h = {h_fail:.3g})")
        return self.state

    # -- the Newton iteration ----------------------------------------------------------
    def _newton(self, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if self._md is not None:
            return self._newton_compiled(h)
        p, s = self.problem, self.state
        n, m, ggl = p.n, p.m, self._ggl
        al, be, ga = self._alpha, self._beta, self._gamma
        tol = self.settings["newton_tol"]
        maxiter = self.settings["newton_maxiter"]
        reuse = self.settings["reuse_jacobian"]
        c = self.counters
        t1 = s.t + h
        bh2 = be * h * h
        w1 = 1.0 / (1.0 + al)
        wF = al / (1.0 + al)
        vs = be * h / ga  # scale of the velocity-constraint rows
        q_hat = s.q + h * s.v + ((0.5 - be) * h * h) * s.a
        v_hat = s.v + ((1.0 - ga) * h) * s.a
        F_old = self._F

        def unpack(x: np.ndarray, Cq: np.ndarray | None):
            q = x[:n]
            mu_term = Cq.T @ x[n + m:] if ggl else 0.0
            a = (q - q_hat - mu_term) / bh2
            return q, a, v_hat + (ga * h) * a

        # predictor: a and λ extrapolated linearly from the last two steps (constant after a
        # restart), μ = 0; the linear extrapolation makes the predicted q_{n+1} accurate to O(h⁴),
        # so that the modified Newton iteration usually needs one or two corrections
        a_pred, l_pred = s.a, s.lam
        if self._prev_al is not None:
            h_old, a_old, l_old = self._prev_al
            r_h = h / h_old
            a_pred = s.a + r_h * (s.a - a_old)
            if m:
                l_pred = s.lam + r_h * (s.lam - l_old)
        x0 = np.zeros(self._nx)
        x0[:n] = q_hat + bh2 * a_pred
        x0[n:n + m] = bh2 * l_pred

        if self._lu is None or not reuse or max(h / self._lu_h, self._lu_h / h) > JAC_H_RATIO:
            self._lu = None
        attempts = 0
        while True:
            attempts += 1
            x = x0.copy()
            fresh = False
            since = 0  # iterations with the current fresh matrix
            d_prev = None
            converged = False
            for it in range(maxiter):
                q = x[:n]
                Cq = p.constraint_jacobian(t1, q) if m else None
                q, a, v = unpack(x, Cq)
                M = p.mass(q)
                Q = p.force(t1, q, v)
                r = np.empty(self._nx)
                r1 = M @ a * w1 - Q - wF * F_old
                r[:n] = bh2 * r1
                if m:
                    lt = x[n:n + m]
                    r[:n] += Cq.T @ lt
                    r[n:n + m] = p.constraint(t1, q)
                    if ggl:
                        r[n + m:] = vs * (Cq @ v + p.constraint_t(t1, q))
                if not np.isfinite(r).all():
                    raise _Fail("non-finite residual in Newton iteration")
                if self._lu is None or not reuse:
                    self._factor(t1, h, q, v, a, x[n:n + m] / bh2 if m else None, M, Cq)
                    fresh = True
                    since = 0
                dx, info = dgetrs(self._lu[0], self._lu[1], r)
                dx = -dx
                c.newton_iterations += 1
                since += 1
                x += dx
                if not np.isfinite(x).all():
                    raise _Fail("non-finite Newton iterate")
                qscale = max(1.0, float(np.abs(x[:n]).max()))
                d = float(np.abs(dx[:n]).max())
                if m:
                    mscale = max(float(np.abs(M.diagonal()).max()), 1e-300)
                    d = max(d, float(np.abs(dx[n:n + m]).max()) / mscale)
                    if ggl:
                        d = max(d, float(np.abs(dx[n + m:]).max()))
                d /= qscale
                rate = d / d_prev if d_prev else None
                small = d <= max(tol, ROUNDOFF) or (rate is not None and rate < 1.0 and rate / (1.0 - rate) * d <= tol)
                if small and self._constraints_ok(t1, x, unpack, tol, qscale):
                    converged = True
                    break
                if rate is not None:
                    # a stale matrix that contracts poorly, or too slowly to finish within maxiter,
                    # is rebuilt at the next iterate
                    slow = rate >= 1.0 or d * rate ** (maxiter - it - 1) > tol * (1.0 - rate)
                    if not fresh and (rate > NEWTON_RATE_REFRESH or slow):
                        self._lu = None
                    elif fresh and rate > NEWTON_RATE_DIVERGE:
                        break
                d_prev = d
            if converged:
                break
            if attempts > 1 or (fresh and since >= 3):
                raise _Fail(f"Newton did not converge in {maxiter} iterations")
            self._lu = None  # one retry from the predictor with a fresh matrix
        q = x[:n].copy()
        Cq = p.constraint_jacobian(t1, q) if m else None
        q, a, v = unpack(x, Cq)
        lam = x[n:n + m] / bh2
        # F_{n+1} = (C_qᵀλ − Q)_{n+1} from the converged equations of motion (no extra force call)
        F_new = wF * F_old - w1 * (M @ a) if al != 0.0 else F_old
        return q, v, a, lam, F_new

    def _constraint_norms(self, t: float, q: np.ndarray, v: np.ndarray, Cq: np.ndarray) -> tuple[float, float]:
        """max_i |C_i| / ‖C_q,i‖₁ and max_i |Ċ_i| / ‖C_q,i‖₁ (a distance and a speed)."""
        p = self.problem
        rown = np.maximum(np.sum(np.abs(Cq), axis=1), 1e-300)
        pos = float(np.max(np.abs(p.constraint(t, q)) / rown))
        vel = float(np.max(np.abs(Cq @ v + p.constraint_t(t, q)) / rown))
        return pos, vel

    def _constraints_ok(self, t1: float, x: np.ndarray, unpack, tol: float, qscale: float) -> bool:
        p = self.problem
        if p.m == 0:
            return True
        Cq = p.constraint_jacobian(t1, x[:p.n])
        q, a, v = unpack(x, Cq)
        pos, vel = self._constraint_norms(t1, q, v, Cq)
        if pos > max(tol, ROUNDOFF) * qscale:
            return False
        if self._ggl:
            # a velocity is a displacement difference divided by βh/γ: never ask for less than its round-off
            floor = ROUNDOFF * qscale * self._gamma / (self._beta * (t1 - self.state.t))
            if vel > max(VEL_TOL_FACTOR * tol * max(1.0, float(np.abs(v).max())), floor):
                return False
        return True

    def _factor(self, t1: float, h: float, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                lam: np.ndarray | None, M: np.ndarray, Cq: np.ndarray | None) -> None:
        """Build and LU-factorize the scaled iteration matrix J (module docstring)."""
        p = self.problem
        n, m, ggl = p.n, p.m, self._ggl
        al, be, ga = self._alpha, self._beta, self._gamma
        bh2 = be * h * h
        w1 = 1.0 / (1.0 + al)
        Kq, Kv = p.force_jacobian(t1, q, v)
        KM = p.mass_jacobian_product(q, a)
        J = np.zeros((self._nx, self._nx))
        J11 = w1 * M + bh2 * (w1 * KM - Kq) - (ga * h) * Kv
        if m:
            J11 = J11 + bh2 * p.constraint_force_jacobian(t1, q, lam)
            J[:n, n:n + m] = Cq.T
            J[n:n + m, :n] = Cq
            if ggl:
                J[:n, n + m:] = -(w1 * M - (ga * h) * Kv) @ Cq.T
                # the velocity rows: C_q + (βh/γ) ∂(C_q v)/∂q; the second term is O(h) but
                # it is what keeps the velocity constraint converging as fast as the rest
                J[n + m:, :n] = Cq + (be * h / ga) * central_difference(
                    lambda x: p.constraint_jacobian(t1, x) @ v, q, m)
                J[n + m:, n + m:] = -(Cq @ Cq.T)
        J[:n, :n] = J11
        if not np.isfinite(J).all():
            raise _Fail("non-finite iteration matrix")
        lu, piv, info = dgetrf(J)
        if info > 0:
            raise _Fail("singular iteration matrix (dependent constraints?)")
        self._lu = (lu, piv)
        self._lu_h = h
        self.counters.lu_factorizations += 1
