"""SUNDIALS IDA at C speed: the GGL residual and Jacobian as compiled C callbacks, the
driver's quiet steps in one compiled loop around ``IDASolve`` (numba).

scikit-sundae's wheel ships the SUNDIALS shared libraries (IDA, serial N_Vector, dense
SUNMatrix and SUNLinearSolver). This module calls them directly: every library function
is reached through its address (passed to compiled code as an integer and called with
:func:`ccall`), so the compiled loops hold no ctypes objects and cache on disk. The
residual and Jacobian are numba ``cfunc`` s, one per phase-data type, which IDA calls
with ``user_data`` pointing at a slot (fixed for the solver's life: IDA hands the
Jacobian the ``user_data`` it saw at its first step) that holds the address of the
compiled entry's own copy of a context tuple (phase data, scratch arrays, counters): the
callbacks run only inside the compiled entries (:mod:`daebench.stepping.ida_advance`), which
fill the slot first.

The numbers are those of the scikit-sundae path (:mod:`daebench.integrators.ida`): the
same SUNDIALS calls in the same order (``IDASetStopTime`` / ``IDASolve(IDA_ONE_STEP)``
/ ``IDAClearStopTime`` per step, ``IDAReInit`` per phase), the same residual
(:func:`ggl_residual`) and the same Jacobian entries (:func:`ggl_jacobian`).
"""

from __future__ import annotations

import ctypes
import math
from typing import NamedTuple

import numpy as np
from numba import carray, cfunc, njit, types, typeof

from daebench.core import phase
from daebench.stepping.ida_advance import (ADV_FAIL, ADV_MAX, ADV_NONFINITE, ADV_PYTHON, ADV_STOP,  # noqa: F401
                                           ADV_STUCK, DENSE_EDGE, IDA_NORMAL, IDA_ONE_STEP, advance_loop, interpolate,
                                           solve)
from daebench.stepping.sundials_c import (A_MATDATA, A_NVDATA, NativeUnavailable, as_int, ccall, deref_key,
                                          double_ptr, lib, message, type_key)

__all__ = ["NativeIDA", "NativeUnavailable", "ggl_residual", "ggl_jacobian", "advance_loop", "solve"]

# -- the residual and the Jacobian, compiled ---------------------------------------------------------
class Context(NamedTuple):
    """What the callbacks need (IDA's ``user_data`` points at a copy of it)."""

    ph: tuple              # phase data
    m: int
    addr: np.ndarray       # int64: function addresses (_ADDR_NAMES)
    counts: np.ndarray     # int64[2]: residual calls, Jacobian calls
    M: np.ndarray
    Q: np.ndarray
    C: np.ndarray
    Cq: np.ndarray
    Ct: np.ndarray
    gam: np.ndarray
    Kq: np.ndarray         # n × n scratch of the Jacobian
    Kv: np.ndarray
    Km: np.ndarray
    Kc: np.ndarray
    Kvc: np.ndarray        # m × n
    zeros: np.ndarray      # n


def make_context(ph, n: int, m: int, addresses: np.ndarray) -> Context:
    mm = max(m, 1)
    return Context(ph, m, addresses, np.zeros(2, np.int64), np.zeros((n, n)), np.zeros(n), np.zeros(m),
                   np.zeros((m, n)), np.zeros(m), np.zeros(m), np.zeros((n, n)), np.zeros((n, n)),
                   np.zeros((n, n)), np.zeros((n, n)), np.zeros((mm, n)), np.zeros(n))


@njit(cache=True)
def ggl_residual(ph, m, t, y, yp, res, M, Q, C, Cq, Ct, gam):
    """F(t, y, ẏ) of the GGL form, y = (q, v, λ, μ) (see :mod:`daebench.integrators.ida`),
    into ``res``."""
    n = M.shape[0]
    q = y[:n]
    v = y[n:2 * n]
    phase.mass_force(ph, t, q, v, M, Q)
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += M[i, j] * yp[n + j]
        res[i] = yp[i] - v[i]
        res[n + i] = acc - Q[i]
    if m == 0:
        return
    phase.constraints(ph, t, q, v, C, Cq, Ct, gam)
    for r in range(m):
        lam = y[2 * n + r]
        mu = y[2 * n + m + r]
        cv = 0.0
        for i in range(n):
            res[i] += Cq[r, i] * mu
            res[n + i] += Cq[r, i] * lam
            cv += Cq[r, i] * v[i]
        res[2 * n + r] = C[r]
        res[2 * n + m + r] = cv + Ct[r]


@njit(cache=True)
def ggl_jacobian(cx, t, y, yp, cj, JJ):
    """The iteration matrix ∂F/∂y + c_j ∂F/∂ẏ of the GGL form into the row-major ``JJ``
    (the entries of :meth:`daebench.integrators.ida.IDA._jac`, operation for operation)."""
    ph, m = cx.ph, cx.m
    n = cx.M.shape[0]
    q, v, vd = y[:n], y[n:2 * n], yp[n:2 * n]
    M, Kq, Kv, Km = cx.M, cx.Kq, cx.Kv, cx.Km
    phase.mass_force(ph, 0.0, q, cx.zeros, M, cx.Q)
    phase.force_jacobian(ph, t, q, v, Kq, Kv)
    phase.mass_jacobian_product(ph, q, vd, Km)
    JJ[:, :] = 0.0
    for i in range(n):
        for j in range(n):
            JJ[i, j] = cj * (1.0 if i == j else 0.0)
            JJ[i, n + j] = -1.0 if i == j else -0.0
            JJ[n + i, j] = Km[i, j] - Kq[i, j]
            JJ[n + i, n + j] = cj * M[i, j] - Kv[i, j]
    if m == 0:
        return
    lam = y[2 * n:2 * n + m]
    Cq = cx.Cq
    phase.constraint_jacobian(ph, t, q, Cq, cx.C, cx.zeros)
    Kc = cx.Kc
    Kc[:, :] = 0.0
    phase.constraint_force_jacobian(ph, t, q, lam, Kc)
    Kvc = cx.Kvc[:m]
    Kvc[:, :] = 0.0
    phase.velocity_constraint_jacobian(ph, t, q, v, Kvc)
    for i in range(n):
        for j in range(n):
            JJ[n + i, j] += Kc[i, j]
    for r in range(m):
        for i in range(n):
            JJ[i, 2 * n + m + r] = Cq[r, i]
            JJ[n + i, 2 * n + r] = Cq[r, i]
            JJ[2 * n + r, i] = Cq[r, i]
            JJ[2 * n + m + r, i] = Kvc[r, i]
            JJ[2 * n + m + r, n + i] = Cq[r, i]


_RES_SIG = types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr, types.voidptr)
_JAC_SIG = types.int32(types.float64, types.float64, types.voidptr, types.voidptr, types.voidptr, types.voidptr,
                       types.voidptr, types.voidptr, types.voidptr, types.voidptr)
_CALLBACKS: dict = {}


@njit(cache=True)
def _vec(cx, nv, size):
    """The data of an N_Vector as an array."""
    addr = ccall(types.int64, cx.addr[A_NVDATA], (as_int(nv),))
    return carray(double_ptr(addr), (size,))


def callbacks(ctx_type):
    """(residual, Jacobian) cfuncs for one context type (compiled once per phase-data type,
    cached on disk: they close over the type's text, :func:`daebench.stepping.sundials_c.type_key`)."""
    got = _CALLBACKS.get(ctx_type)
    if got is not None:
        return got
    CTX = type_key(ctx_type)

    @cfunc(_RES_SIG, cache=True)
    def res(t, yy, yp, rr, ud):
        cx = deref_key(ud, CTX)
        size = 2 * cx.M.shape[0] + 2 * cx.m
        cx.counts[0] += 1
        ggl_residual(cx.ph, cx.m, t, _vec(cx, yy, size), _vec(cx, yp, size), _vec(cx, rr, size),
                     cx.M, cx.Q, cx.C, cx.Cq, cx.Ct, cx.gam)
        return 0

    @cfunc(_JAC_SIG, cache=True)
    def jac(t, cj, yy, yp, rr, JJ, ud, t1, t2, t3):
        cx = deref_key(ud, CTX)
        size = 2 * cx.M.shape[0] + 2 * cx.m
        cx.counts[1] += 1
        data = ccall(types.int64, cx.addr[A_MATDATA], (as_int(JJ),))
        JT = carray(double_ptr(data), (size, size))  # column-major data = the transpose, row-major
        ggl_jacobian(cx, t, _vec(cx, yy, size), _vec(cx, yp, size), cj, JT.T)
        return 0

    _CALLBACKS[ctx_type] = (res, jac)
    return res, jac


# -- the solver object -------------------------------------------------------------------------------
class StepResult(NamedTuple):
    """What one call returns (the fields of scikit-sundae's ``IDAResult`` that
    :mod:`daebench.integrators.ida` reads)."""

    success: bool
    status: int
    message: str
    t: float
    y: np.ndarray
    yp: np.ndarray
    nfev: int
    njev: int


class NativeIDA:
    """IDA with a dense linear solver on a system of ``size`` equations, called directly.

    Parameters
    ----------
    size : int
        Number of equations (2n + 2m).
    n, m : int
        Coordinates and constraints (the GGL layout y = (q, v, λ, μ)).
    rtol : float
    atol : array_like
        Per-component absolute tolerances (a scalar is broadcast).
    max_step, first_step : float
    max_order, max_num_steps : int
    algebraic_idx : sequence of int or None
    analytic_jacobian : bool
        The compiled Jacobian (else IDA's difference quotients).
    """

    def __init__(self, size: int, n: int, m: int, *, rtol: float, atol, max_step: float, first_step: float,
                 max_order: int, max_num_steps: int, algebraic_idx=None, analytic_jacobian: bool = True) -> None:
        self.size, self.n, self.m = int(size), int(n), int(m)
        self.rtol = float(rtol)
        self.atol = np.broadcast_to(np.asarray(atol, dtype=float), (self.size,)).copy()
        self.opts = (float(max_step), float(first_step), int(max_order), int(max_num_steps))
        self.alg = [] if algebraic_idx is None else list(algebraic_idx)
        self.analytic = bool(analytic_jacobian)
        self.lib = lib()
        self.mem = None
        self.cx: Context | None = None
        self.counters = None  # an object with residual_evals, jacobian_evals (the problem's)
        self._seen = np.zeros(2, np.int64)
        self.tret = np.zeros(1)
        self.slot = np.zeros(1, np.int64)  # IDA's user_data: the address of the context in use
        self._nstat = np.zeros(1, np.int64)

    # -- set-up -------------------------------------------------------------------
    def _check(self, flag: int, what: str) -> None:
        if flag is not None and flag < 0:
            raise RuntimeError(f"{what} failed: {message(flag)} (flag {flag})")

    def _create(self, t0: float, y0: np.ndarray, yp0: np.ndarray) -> None:
        L, N = self.lib, self.size
        ctx = ctypes.c_void_p()
        self._check(L.SUNContext_Create(0, ctypes.byref(ctx)), "SUNContext_Create")
        self.ctx = ctx
        L.SUNContext_ClearErrHandlers(ctx)  # failures come back as flags (reported by the caller)
        self.yy, self.yp = L.N_VNew_Serial(N, ctx), L.N_VNew_Serial(N, ctx)
        self.nv_atol, self.nv_id = L.N_VNew_Serial(N, ctx), L.N_VNew_Serial(N, ctx)
        self.nv_yd, self.nv_ypd = L.N_VNew_Serial(N, ctx), L.N_VNew_Serial(N, ctx)  # dense output rows
        self.yd, self.ypd_d = self._array(self.nv_yd), self._array(self.nv_ypd)
        self.y = self._array(self.yy)
        self.ypd = self._array(self.yp)
        self.y[:] = y0
        self.ypd[:] = yp0
        self._array(self.nv_atol)[:] = self.atol
        ident = self._array(self.nv_id)
        ident[:] = 1.0
        ident[self.alg] = 0.0
        self.A = L.SUNDenseMatrix(N, N, ctx)
        self.LS = L.SUNLinSol_Dense(self.yy, self.A, ctx)
        if not (self.yy and self.yp and self.nv_yd and self.nv_ypd and self.A and self.LS):
            raise MemoryError("SUNDIALS could not allocate the IDA vectors or the dense solver")
        self.mem = L.IDACreate(ctx)
        self._check(L.IDASetUserData(self.mem, self.slot.ctypes.data), "IDASetUserData")
        res, jac = callbacks(typeof(self.cx))
        self._res, self._jac = res, jac  # keep the cfuncs alive with the memory that calls them
        self._check(L.IDAInit(self.mem, res.address, t0, self.yy, self.yp), "IDAInit")
        self._check(L.IDASVtolerances(self.mem, self.rtol, self.nv_atol), "IDASVtolerances")
        self._check(L.IDASetLinearSolver(self.mem, self.LS, self.A), "IDASetLinearSolver")
        if self.analytic:
            self._check(L.IDASetJacFn(self.mem, jac.address), "IDASetJacFn")
        max_step, first_step, max_order, max_num_steps = self.opts
        self._check(L.IDASetMaxNonlinIters(self.mem, 4), "IDASetMaxNonlinIters")
        self._check(L.IDASetMaxConvFails(self.mem, 10), "IDASetMaxConvFails")
        self._check(L.IDASetId(self.mem, self.nv_id), "IDASetId")
        self._check(L.IDASetInitStep(self.mem, first_step), "IDASetInitStep")
        self._check(L.IDASetMinStep(self.mem, 0.0), "IDASetMinStep")
        self._check(L.IDASetMaxStep(self.mem, max_step), "IDASetMaxStep")
        self._check(L.IDASetMaxOrd(self.mem, max_order), "IDASetMaxOrd")
        self._check(L.IDASetMaxNumSteps(self.mem, max_num_steps), "IDASetMaxNumSteps")
        self._ctx_type = typeof(self.cx)

    def _array(self, nv) -> np.ndarray:
        ptr = self.lib.N_VGetArrayPointer(nv)
        return np.ctypeslib.as_array(ctypes.cast(ptr, ctypes.POINTER(ctypes.c_double)), (self.size,))

    def _stats(self) -> tuple[int, int]:
        L = self.lib
        out = ctypes.c_long()
        L.IDAGetNumResEvals(self.mem, ctypes.byref(out))
        nfev = out.value
        L.IDAGetNumJacEvals(self.mem, ctypes.byref(out))
        return int(nfev), int(out.value)

    def _book(self) -> None:
        """Add the callbacks' calls since the last call to the problem's counters."""
        c = self.cx.counts
        if self.counters is not None:
            self.counters.residual_evals += int(c[0] - self._seen[0])
            self.counters.jacobian_evals += int(c[1] - self._seen[1])
        self._seen[:] = c

    # -- scikit-sundae's interface ---------------------------------------------------
    def init_step(self, t0: float, y0: np.ndarray, yp0: np.ndarray, ph=None) -> StepResult:
        """(Re)start at t0 from (y0, ẏ0) on the phase data ``ph``."""
        cx = make_context(ph, self.n, self.m, self.lib.addresses)
        self._seen[:] = 0
        if self.mem is None:
            self.cx = cx
            self._create(float(t0), y0, yp0)
        else:
            if typeof(cx) != self._ctx_type:
                raise RuntimeError("native IDA: the phase data changed type within one solver")
            self.cx = cx
            self.y[:] = y0
            self.ypd[:] = yp0
            self._check(self.lib.IDAReInit(self.mem, float(t0), self.yy, self.yp), "IDAReInit")
        nfev, njev = self._stats()
        return StepResult(True, 0, message(0), float(t0), self.y.copy(), self.ypd.copy(), nfev, njev)

    def step(self, t: float, method: str = "normal", tstop: float | None = None) -> StepResult:
        itask = IDA_ONE_STEP if method == "onestep" else IDA_NORMAL
        flag = int(solve(self.cx, _ptr(self.mem), _ptr(self.yy), _ptr(self.yp), float(t),
                         math.inf if tstop is None else float(tstop), itask, self.tret, self.slot))
        self._book()
        nfev, njev = self._stats()
        return StepResult(flag >= 0, flag, message(flag), float(self.tret[0]), self.y.copy(), self.ypd.copy(),
                          nfev, njev)

    def advance(self, t_cur: float, ida_t: float, t_stop: float, max_steps: int, w, C, Cq, Ct, gam,
                t_out: np.ndarray | None = None, out: np.ndarray | None = None):
        """The compiled loop :func:`advance_loop`; returns (steps, code, flag, ida_t, prev, cur, nfev, njev,
        rows, consumed) with prev/cur the (t, y, ẏ) rows of the last step's start and end and ``rows``
        the first rows of ``out`` written (output times ``t_out[:consumed]``; none without ``t_out``)."""
        N = self.size
        prev, cur = np.empty(1 + 2 * N), np.empty(1 + 2 * N)
        cur[0] = t_cur
        cur[1:1 + N] = self.y
        cur[1 + N:] = self.ypd
        if t_out is None or out is None:
            t_out, out = _NO_TIMES, np.empty((0, 2 + 2 * N))
        k, code, flag, ida_t, nrow, oi = advance_loop(
            self.cx, _ptr(self.mem), _ptr(self.yy), _ptr(self.yp), self.y, self.ypd, float(t_cur), float(ida_t),
            float(t_stop), int(max_steps), w, prev, cur, self.tret, self.slot, C, Cq, Ct, gam,
            np.ascontiguousarray(t_out, dtype=float), out, self.yd, self.ypd_d, _ptr(self.nv_yd), _ptr(self.nv_ypd))
        self._book()
        nfev, njev = self._stats()
        return int(k), int(code), int(flag), float(ida_t), prev, cur, nfev, njev, out[:nrow], int(oi)

    def interpolate(self, ts: np.ndarray) -> np.ndarray:
        """(y, ẏ) rows of IDA's interpolating polynomial at the times ``ts`` within its last
        step (:func:`daebench.stepping.ida_advance.interpolate`): as many rows as IDA gave
        before it refused a time."""
        out = np.empty((len(ts), 2 * self.size))
        k = interpolate(self.cx, _ptr(self.mem), np.ascontiguousarray(ts, dtype=float), out, self.yd, self.ypd_d,
                        _ptr(self.nv_yd), _ptr(self.nv_ypd))
        return out[:k]

    def __del__(self) -> None:
        L = getattr(self, "lib", None)  # None: __init__ failed before loading the library
        if getattr(self, "mem", None) is None or L is None:
            return
        mem = ctypes.c_void_p(self.mem)
        L.IDAFree(ctypes.byref(mem))
        for nv in (self.yy, self.yp, self.nv_atol, self.nv_id, self.nv_yd, self.nv_ypd):
            L.N_VDestroy(nv)
        L.SUNMatDestroy(self.A)
        L.SUNLinSolFree(self.LS)
        L.SUNContext_Free(ctypes.byref(self.ctx))
        self.mem = None


_NO_TIMES = np.zeros(0)


def _ptr(p) -> int:
    return int(p or 0)
