"""SUNDIALS IDA (through scikit-sundae) on an index-reduced form: the reference solver.

Method
------
IDA is a variable-order (1–5), variable-step BDF code in fixed-leading-coefficient
form with a modified Newton iteration and a dense direct linear solver here.
BDF1 and BDF2 are A-stable; BDF3–5 are A(α)-stable (α ≈ 86°, 73°, 52°), so order
5 loses stability for modes close to the imaginary axis — for lightly damped
structural modes IDA's order selection usually lowers the order itself, and
``max_order`` caps it explicitly.

Formulation
-----------
Unconstrained phases (m = 0), y = (q, v)::

    q̇ − v = 0,        M(q) v̇ − Q(t, q, v) = 0.

Constrained phases (m > 0): the stabilized index-2 form of Gear, Gupta and
Leimkuhler (GGL), y = (q, v, λ, μ)::

    q̇ − v + C_qᵀ μ = 0
    M(q) v̇ + C_qᵀ λ − Q(t, q, v) = 0
    C(t, q) = 0
    C_q v + C_t = 0

λ and μ are algebraic; μ = 0 on the exact solution and only absorbs the
projection onto the position manifold, so both the position and the velocity
constraints hold to the Newton tolerance at every step (no drift). The state
returned to the driver carries ``lam = λ`` (λ ≥ 0 compressive contact) and
``a = v̇`` from IDA's BDF derivative.

Error test and algebraic variables
----------------------------------
scikit-sundae 1.2 passes ``algebraic_idx`` to ``IDASetId`` only (used by
``IDACalcIC``); it does not expose ``IDASetSuppressAlg``, so λ and μ stay in the
local error test and in the weighted norm of the Newton convergence test. For an
index-2 system that is too strict: the multipliers' corrections scale like 1/h²
and their BDF error estimate is not of the order of the differential variables'.
Measured: with λ, μ at the tolerance of q, v, IDA stops with repeated corrector
convergence failures at its first steps (Andrews, ``alg_atol = 1e-4``: at t = 0;
Cartesian pendulum, ``alg_atol = 1e-12``: at t = 7e-7). We therefore give λ and μ
the absolute tolerance ``alg_atol``, large by default, which takes them out of
both tests in practice. Their accuracy then follows from q and v: on the
pendulum at rtol = 1e-12 the error of λ is 3e-7 (of q: 2.5e-11).

Jacobian
--------
``jacobian = "analytic"`` (default) assembles the iteration matrix
∂F/∂y + c_j ∂F/∂ẏ from the problem's mass, force Jacobian, ∂(M a)/∂q,
∂(C_qᵀλ)/∂q and C_q; ∂(C_q v + C_t)/∂q is taken by central differences of C_q,
and ∂(C_qᵀμ)/∂q is dropped (μ = O(tolerance), a modified Newton tolerates it).
``jacobian = "fd"`` uses IDA's internal difference-quotient Jacobian (one
residual per column: 2n + 2m residual calls per Jacobian). Measured on
Andrews' mechanism (n = 7, m = 6) at rtol = atol = 1e-10: the same 4.2e3 steps
either way; 5.8e3 residual calls and 1.23 s assembled, 12.5e3 and 1.43 s FD.

Compiled residual
-----------------
The residual is one numba call (:func:`ggl_residual`) on the phase
(:mod:`daebench.core.phase`), for every model. The Jacobian is assembled in Python from the
problem's compiled pieces (one per ~40 steps). :meth:`IDA.advance` lets the driver hand
over many steps per call, with each quiet step checked by one compiled call
(:func:`daebench.stepping.watch.quiet`). Measured on beam-impact (t_end 0.5 s, default
tolerances, 87.6e3 steps): 17.5 s → 9.5 s (compiled residual, cheaper driver checks) →
5.9 s (advance); SUNDIALS' own step is now about half of the time; advance() takes exactly
the steps of the one-step loop (tests/integrators/test_ida.py).

Backends
--------
``backend = "native"`` (default) calls the SUNDIALS libraries of scikit-sundae's wheel
directly (:mod:`daebench.stepping.ida_native`): the residual and the Jacobian are
compiled C callbacks and :meth:`IDA.advance` runs its quiet steps in one compiled loop;
``backend = "sksundae"`` goes through scikit-sundae's Python interface (Python callbacks,
one Python call per step). Both make the same SUNDIALS calls with the same residual and
Jacobian entries, so their histories agree to the last digit (tests/stepping/test_ida_native.py);
the run record names the backend among the settings. A model written in Python (its
kernels call Python through ``numba.objmode``: :class:`daebench.core.kernels.PyModel`)
always runs through scikit-sundae: inside a C callback numba cannot hand an exception the
model raises back to Python (it prints "Exception ignored" and IDA goes on with a stale
residual; a compiled ``try`` around the call leaves the exception pending instead, and
Python then fails with ``SystemError``), whereas scikit-sundae's Python callbacks end the
run with the model's own message. Such a model costs ~10 µs per kernel call anyway.

Dense output
------------
:meth:`IDA.dense` calls IDA in ``normal`` mode with t inside the last internal
step, which only evaluates IDA's interpolating polynomial (``IDAGetSolution``)
and takes no step (verified in tests/integrators/test_ida.py against direct solves to t).
Its error is of the size of the step error (pendulum, rtol 1e-8: 4.5e-8 both).

Step size
---------
IDA chooses its own steps: ``adaptive`` must be true. The protocol settings
``h`` and ``h_contact`` (shared by every stepping integrator) are declared but a value
other than their default is refused (it would be ignored); bound the step with
``max_step`` and seed it with ``first_step``.

Counters
--------
``lu_factorizations`` = IDA's Jacobian evaluations (one LU each with the dense
solver); ``newton_iterations`` = IDA's residual evaluations inside the Newton
iteration (scikit-sundae exposes ``nfev``/``njev`` only, so this counts the one
residual each iteration costs). Rejected steps are not exposed by
scikit-sundae 1.2 and stay 0.

References
----------
A. C. Hindmarsh, P. N. Brown, K. E. Grant, S. L. Lee, R. Serban, D. E. Shumaker,
C. S. Woodward, "SUNDIALS: Suite of nonlinear and differential/algebraic equation
solvers", ACM TOMS 31 (2005) 363–396.
C. W. Gear, B. Leimkuhler, G. K. Gupta, "Automatic integration of Euler–Lagrange
equations with constraints", J. Comput. Appl. Math. 12–13 (1985) 77–90.
K. E. Brenan, S. L. Campbell, L. R. Petzold, *Numerical Solution of Initial-Value
Problems in Differential-Algebraic Equations*, SIAM, 1996.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from sksundae.ida import IDA as _SundaeIDA

from daebench.integrators.base import (
    STEP_SETTINGS,
    Advance,
    Capabilities,
    Integrator,
    IntegratorError,
    RecordedAdvance,
    Setting,
    StepFailure,
    hermite_state,
)
from daebench.stepping import ida_native as _native
from daebench.stepping.dense import MAX_OUTPUT_ROWS
from daebench.stepping.ida_native import ggl_residual
from daebench.stepping import watch as _watch
from daebench.stepping.methods import StateArrays
from daebench.core.kernels import PyModel
from daebench.core.system import State

MAX_NUM_STEPS = 500  # IDA's limit per call; one call = one internal step here
ALG_ATOL_DEFAULT = 1e10  # absolute tolerance of λ, μ: takes them out of the error test
MAX_STEPS_PER_CALL = 2000  # advance(): keeps the driver responsive


class IDA(Integrator):
    """SUNDIALS IDA, variable-order variable-step BDF (orders 1–5), on the GGL
    stabilized index-2 form of the equations of motion.

    Parameters
    ----------
    rtol, atol : float
        Relative and absolute local error tolerances of q and v.
    alg_atol : float
        Absolute tolerance of the algebraic variables λ, μ (large = out of the
        error test; see the module docstring).
    max_step : float
        Largest step [s]; 0 = unbounded.
    first_step : float
        First step after every (re)start [s]; 0 = IDA's own estimate.
    max_order : int
        Highest BDF order, 1..5.
    jacobian : {"analytic", "fd"}
        Assembled iteration matrix or IDA's difference quotients.
    h, h_contact :
        Shared protocol settings; IDA chooses its steps, so a value other than the
        default is refused.
    adaptive : bool
        Must be true.

    Notes
    -----
    Stability: BDF1–2 A-stable, BDF3–5 A(α)-stable. See the module docstring for
    the formulation, the error test of the multipliers and the references
    (Hindmarsh et al. 2005; Gear, Gupta, Leimkuhler 1985; Brenan, Campbell,
    Petzold 1996).
    """


    name = "ida"
    description = "SUNDIALS IDA: variable-order BDF (1-5) on the GGL index-2 form; the reference solver"
    capabilities = Capabilities(order=5, fixed_step=False, adaptive=True, constraints=True,
                                index=3, dense_output=True)
    settings_spec = STEP_SETTINGS + (
        Setting("adaptive", bool, True, "always true: IDA chooses its own steps"),
        Setting("rtol", float, 1e-8, "relative tolerance of the local error", low=1e-14, high=1e-2),
        Setting("atol", float, 1e-10, "absolute tolerance of the local error of q and v",
                low=1e-16, high=1.0),
        Setting("alg_atol", float, ALG_ATOL_DEFAULT,
                "absolute tolerance of the multipliers λ, μ (large = not in the error test)",
                low=1e-16, high=1e20),
        Setting("max_step", float, 0.0, "largest step [s]; 0 = unbounded", low=0.0, high=1e5),
        Setting("first_step", float, 0.0, "first step after a (re)start [s]; 0 = IDA's estimate",
                low=0.0, high=1e5),
        Setting("max_order", int, 5, "highest BDF order", low=1, high=5),
        Setting("jacobian", str, "analytic", "iteration matrix: assembled or IDA's finite differences",
                choices=("analytic", "fd")),
        Setting("backend", str, "native",
                "native: SUNDIALS called directly with compiled callbacks and a compiled step loop "
                "(a model written in Python runs through sksundae); "
                "sksundae: through scikit-sundae's Python interface (same numbers, slower)",
                choices=("native", "sksundae")),
    )

    def __init__(self, **settings) -> None:
        super().__init__(**settings)
        self._solvers: dict[tuple[int, int, bool], _SundaeIDA | _native.NativeIDA] = {}
        self._solver: _SundaeIDA | _native.NativeIDA | None = None
        self._n = self._m = 0
        self._nfev = self._njev = 0
        self._ida_t = 0.0

    def _check_settings(self) -> None:
        if not self.settings["adaptive"]:
            raise IntegratorError(
                "integrator 'ida' always chooses its own steps; drop `--opt adaptive=false` "
                "(bound the step with `--opt max_step=...` instead)."
            )
        for key in ("h", "h_contact"):  # declared for the shared protocol; a value given for IDA does nothing
            default = next(p.default for p in self.settings_spec if p.name == key)
            if self.settings[key] != default:
                raise IntegratorError(
                    f"integrator 'ida' chooses its own steps: setting '{key}' = {self.settings[key]:g} would be "
                    f"ignored; bound the step with `--opt max_step=...` or seed it with `--opt first_step=...`")

    # -- lifecycle -------------------------------------------------------------
    def _start(self) -> None:
        p = self.problem
        n, m = p.n, p.m
        self._n, self._m = n, m
        st = self.state
        # a and λ follow from (t, q, v); recompute so IDA starts exactly consistent
        # even if the driver's impact map left them stale.
        a, lam = p.acceleration(st.t, st.q, st.v)
        st.a, st.lam = a, lam
        self._c_M, self._c_Q = np.zeros((n, n)), np.zeros(n)
        self._c_C, self._c_Cq, self._c_Ct, self._c_gam = np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)
        solver = self._solver_for(n, m)
        y0 = np.concatenate([st.q, st.v, lam, np.zeros(m)]) if m else np.concatenate([st.q, st.v])
        yp0 = np.concatenate([st.v, a, np.zeros(2 * m)])
        if isinstance(solver, _native.NativeIDA):
            solver.counters = p.counters
            res = solver.init_step(float(st.t), y0, yp0, p.kernel)
        else:
            res = solver.init_step(float(st.t), y0, yp0)
        if not res.success:
            raise StepFailure(f"IDA could not start at t = {st.t:g}: {res.message}")
        self._solver = solver
        self._nfev, self._njev = int(res.nfev), int(res.njev)
        self._ida_t = float(st.t)  # IDA's internal time (may lag self.state.t, see _step_impl)

    def _solver_for(self, n: int, m: int) -> _SundaeIDA | _native.NativeIDA:
        """One scikit-sundae solver per system size, reused across phases (IDAReInit)."""
        cache = self._solvers
        key = (n, m, isinstance(self.problem.kernel.model, PyModel))
        if key not in cache:
            s = self.settings
            N = 2 * n + 2 * m
            atol = np.full(N, s["atol"])
            atol[2 * n:] = s["alg_atol"]
            opts = dict(
                rtol=s["rtol"], atol=atol, max_step=s["max_step"], first_step=s["first_step"],
                max_order=s["max_order"], max_num_steps=MAX_NUM_STEPS, linsolver="dense",
                algebraic_idx=list(range(2 * n, N)) if m else None,
            )
            if s["backend"] == "native" and not isinstance(self.problem.kernel.model, PyModel):
                del opts["linsolver"]
                cache[key] = _native.NativeIDA(N, n, m, analytic_jacobian=s["jacobian"] == "analytic", **opts)
                return cache[key]
            if s["jacobian"] == "analytic":
                opts["jacfn"] = self._jac
            cache[key] = _SundaeIDA(self._res, **opts)
        return cache[key]

    # -- residual and Jacobian ----------------------------------------------------
    def _res(self, t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray) -> None:
        self.problem.counters.residual_evals += 1
        ggl_residual(self.problem.kernel, self._m, t, y, yp, res, self._c_M, self._c_Q, self._c_C, self._c_Cq,
                     self._c_Ct, self._c_gam)

    def _jac(self, t: float, y: np.ndarray, yp: np.ndarray, res: np.ndarray, cj: float,
             JJ: np.ndarray) -> None:
        p, n, m = self.problem, self._n, self._m
        q, v = y[:n], y[n:2 * n]
        vd = yp[n:2 * n]
        M = p.mass(q)
        Kq, Kv = p.force_jacobian(t, q, v)
        JJ[:, :] = 0.0
        eye = np.eye(n)
        JJ[:n, :n] = cj * eye
        JJ[:n, n:2 * n] = -eye
        JJ[n:2 * n, :n] = p.mass_jacobian_product(q, vd) - Kq
        JJ[n:2 * n, n:2 * n] = cj * M - Kv
        if m == 0:
            return
        lam = y[2 * n:2 * n + m]
        Cq = p.constraint_jacobian(t, q)
        JJ[:n, 2 * n + m:] = Cq.T
        JJ[n:2 * n, :n] += p.constraint_force_jacobian(t, q, lam)
        JJ[n:2 * n, 2 * n:2 * n + m] = Cq.T
        JJ[2 * n:2 * n + m, :n] = Cq
        JJ[2 * n + m:, :n] = p.velocity_constraint_jacobian(t, q, v)
        JJ[2 * n + m:, n:2 * n] = Cq

    # -- stepping ---------------------------------------------------------------------
    def _unpack(self, t: float, y: np.ndarray, yp: np.ndarray) -> State:
        n, m = self._n, self._m
        return State(float(t), y[:n].copy(), y[n:2 * n].copy(), yp[n:2 * n].copy(),
                     y[2 * n:2 * n + m].copy())

    def _account(self, res) -> None:
        nfev, njev = int(res.nfev), int(res.njev)
        self.counters.newton_iterations += nfev - self._nfev
        self.counters.lu_factorizations += njev - self._njev
        self._nfev, self._njev = nfev, njev

    def _step_impl(self, t_stop: float) -> State:
        st = self.state
        t_stop = float(t_stop)
        scale = max(1.0, abs(t_stop))
        if t_stop - self._ida_t <= 1e-13 * scale:
            # Too close to IDA's time for it to take a step (IDA refuses |Δt| of a
            # few roundoffs); a Taylor step is exact to roundoff here.
            dt = t_stop - st.t
            return State(t_stop, st.q + dt * st.v + 0.5 * dt * dt * st.a, st.v + dt * st.a,
                         st.a.copy(), st.lam.copy())
        for _ in range(3):
            try:
                res = self._solver.step(t_stop, method="onestep", tstop=t_stop)
            except (RuntimeError, ValueError) as exc:
                raise StepFailure(f"IDA at t = {st.t:.9g}: {exc}") from None
            if not res.success:
                raise StepFailure(f"IDA at t = {st.t:.9g}: {res.message} (status {res.status})")
            self._account(res)
            t_new = float(np.ravel(res.t)[0]) if np.ndim(res.t) else float(res.t)
            # After a dense() call IDA's next one-step call may only return the
            # solution at its current time (tretlast < tn); call again then.
            if t_new > st.t:
                break
        else:
            raise StepFailure(f"IDA made no progress from t = {st.t:.9g} (step size below roundoff; "
                              f"last status: {res.message})")
        y, yp = np.asarray(res.y).ravel(), np.asarray(res.yp).ravel()
        if not math.isfinite(float(y.sum()) + float(yp.sum())):  # NaN/inf propagate through a sum
            raise StepFailure(f"IDA produced non-finite values at t = {t_new:.9g}")
        self._ida_t = t_new
        return self._unpack(t_new, y, yp)

    # -- many steps per call (the driver's fast path) ---------------------------------
    records_outputs = True  # advance() takes the output times and writes their rows (native backend)

    def advance(self, t_stop: float, watch: _watch.Watch | None = None,
                outputs: np.ndarray | None = None) -> Advance:
        """Take IDA steps until one the driver must see (:func:`daebench.stepping.watch.quiet`):
        the quiet steps' checks, re-arming and constraint maxima run compiled. Same steps,
        same states as stepping through the driver one at a time. With ``outputs`` (the
        output times from the watch's next one on; native backend) a step whose only news
        is an output time is kept: the states at its output times (those :meth:`dense`
        gives) come back in ``RecordedAdvance.outputs``."""
        if watch is None:
            return super().advance(t_stop, None)
        n, m = self._n, self._m
        w = _watch.own_copy(watch)
        C, Cq, Ct, gam = np.empty(m), np.empty((m, n)), np.empty(m), np.empty(m)
        if isinstance(self._solver, _native.NativeIDA):
            return self._advance_native(float(t_stop), w, C, Cq, Ct, gam, outputs=outputs)
        t_end_tol = 1e-15 * max(1.0, float(t_stop))
        prev = self.state
        for k in range(1, MAX_STEPS_PER_CALL + 1):
            prev = self.state
            new = self.step(t_stop)
            if new.t >= t_stop - t_end_tol or not _watch.quiet(
                    self.problem.kernel, w, float(new.t), StateArrays(new.q, new.v, new.a, new.lam), C, Cq, Ct, gam):
                break
        return Advance(prev, self.state, k, w.armed, w.cmax, self._take_events())

    def _advance_native(self, t_stop: float, w: _watch.Watch, C, Cq, Ct, gam,
                        budget: int = MAX_STEPS_PER_CALL, outputs: np.ndarray | None = None) -> Advance:
        """:meth:`advance` with the step loop compiled (:func:`daebench.stepping.ida_advance.advance_loop`):
        the same IDA calls and checks as :meth:`_step_impl` and :func:`daebench.stepping.watch.quiet`."""
        if t_stop <= self.state.t:
            raise ValueError(f"t_stop = {t_stop} is not after t = {self.state.t}")
        N = 2 * self._n + 2 * self._m
        start = self.state
        buf = None if outputs is None or not len(outputs) else np.empty((min(len(outputs), MAX_OUTPUT_ROWS), 2 + 2 * N))
        k, code, flag, ida_t, prev, cur, nfev, njev, rows, used = self._solver.advance(
            float(start.t), self._ida_t, t_stop, budget, w, C, Cq, Ct, gam, outputs, buf)
        self.counters.newton_iterations += nfev - self._nfev
        self.counters.lu_factorizations += njev - self._njev
        self._nfev, self._njev = nfev, njev
        recorded = [(float(r[0]), self._unpack(r[1], r[2:2 + N], r[2 + N:])) for r in rows]
        if k:
            self._ida_t = ida_t
            self.prev = start if k == 1 else self._unpack(prev[0], prev[1:1 + N], prev[1 + N:])
            self.state = self._unpack(cur[0], cur[1:1 + N], cur[1 + N:])
            self.counters.steps += k
        t_now = self.state.t
        if code == _native.ADV_FAIL:
            raise StepFailure(f"IDA at t = {t_now:.9g}: {_native.message(flag)} (status {flag})")
        if code == _native.ADV_STUCK:
            raise StepFailure(f"IDA made no progress from t = {t_now:.9g} (step size below roundoff; "
                              f"last status: {_native.message(flag)})")
        if code == _native.ADV_NONFINITE:
            raise StepFailure(f"IDA produced non-finite values after t = {t_now:.9g}")
        prev_state = self.prev if k else start
        if used:
            w = w._replace(t_out_next=float(outputs[used]) if used < len(outputs) else math.inf)
            outputs = outputs[used:]
        if code == _native.ADV_PYTHON:  # the Taylor step of _step_impl, then the loop's own check
            prev_state = self.state
            new = self.step(t_stop)
            k += 1
            t_end_tol = 1e-15 * max(1.0, t_stop)
            if new.t < t_stop - t_end_tol and _watch.quiet(
                    self.problem.kernel, w, float(new.t), StateArrays(new.q, new.v, new.a, new.lam), C, Cq, Ct,
                    gam) and k < budget:
                more = self._advance_native(t_stop, w, C, Cq, Ct, gam, budget - k, outputs)
                return RecordedAdvance(more.prev, more.new, k + more.steps, more.armed, more.cmax, more.events,
                                       outputs=recorded + more.outputs)
        return RecordedAdvance(prev_state, self.state, k, w.armed, w.cmax, self._take_events(), outputs=recorded)

    def dense(self, t: float) -> State:
        """State at t within the last step from IDA's own interpolating polynomial
        (the BDF predictor polynomial of the current order; q, v, v̇ and λ)."""
        s0, s1, t = self.prev, self.state, float(t)
        if s0 is None or not self._polynomial_serves(np.array([t]))[0]:
            return s1.copy() if s0 is None or t >= s1.t else hermite_state(s0, s1, t)
        res = self._solver.step(t, method="normal")   # behind IDA's time: IDAGetSolution, never a step
        if not res.success:
            return hermite_state(s0, s1, t)
        return self._unpack(t, np.asarray(res.y).ravel(), np.asarray(res.yp).ravel())

    def dense_many(self, ts: Sequence[float]) -> list[State]:
        """:meth:`dense` at each of the times ``ts``: those IDA's polynomial serves in one
        compiled call (native backend), the rest one by one."""
        ts = np.asarray(ts, dtype=float)
        if self.prev is None or not isinstance(self._solver, _native.NativeIDA):
            return [self.dense(t) for t in ts]
        inner = np.flatnonzero(self._polynomial_serves(ts))
        got, N = dict(zip(inner.tolist(), self._solver.interpolate(ts[inner]))), self._solver.size  # (rows IDA gave)
        return [self._unpack(t, got[i][:N], got[i][N:]) if i in got else self.dense(t) for i, t in enumerate(ts)]

    def _polynomial_serves(self, ts: np.ndarray) -> np.ndarray:
        """Which times IDA's polynomial serves: within the last step (from its start to
        DENSE_EDGE before its end, the end state there), IDA not past it (else Hermite)."""
        s0, s1 = self.prev, self.state
        return (ts >= s0.t) & (ts < s1.t - _native.DENSE_EDGE * (s1.t - s0.t)) & (s1.t <= self._ida_t)
