"""Integrators whose step is a compiled stepper (:mod:`daebench.stepping.methods`).

:class:`CompiledIntegrator` is the base of every built-in stepping integrator and of any
plugin that wants their speed: a subclass names its method data and workspace, and the
base runs :func:`daebench.stepping.runner.run_phase` — one compiled loop for every
stepper, every model, fixed or adaptive step — both for single steps and for the
driver's many-steps-per-call :meth:`advance`. Subclass contract:

* ``method(self) -> NamedTuple``: the method's data (from ``self.settings``);
* ``workspace(self, n, m) -> NamedTuple``: its history and scratch arrays;
* ``fail_messages``: {status: text} for the stepper's failure codes (``{maxiter}`` and
  other settings may be formatted in).

The stepper's three functions are registered for the method data class
(``daebench.stepping.methods.start/step/accept.register``). A plugin's stepper (a method
data class from outside daebench) reaches the loop as compiled values
(:mod:`daebench.stepping.method_handles`): the loop is compiled once for every plugin, and
an edit of the plugin compiles only its own code.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from daebench.integrators.base import Advance, Integrator, RecordedAdvance, StepFailure
from daebench.stepping import method_handles, methods, runner, watch as _watch
from daebench.stepping.dense import MAX_OUTPUT_ROWS
from daebench.stepping.methods import C_JAC, C_LU, C_NEWTON, C_RES, StateArrays
from daebench.stepping.runner import C_REJECTED, UNDERFLOW_ERROR, UNDERFLOW_FAIL
from daebench.core.system import State

MAX_STEPS_PER_CALL = 2000  # keeps a caller (progress, wall-time caps) responsive
_NO_ROWS = np.zeros((0, 1))
_NONE = (np.zeros(0), _NO_ROWS)  # (output times, rows): no rows recorded


def code_owner(cls: type) -> type:
    """The class whose compiled loop the runs of integrator class ``cls`` use: for a
    compiled stepper the class that defines its method data (hht, genalpha and newmark are
    one Newmark-family loop), otherwise ``cls`` itself. Runs with one owner compile the
    same code; a sweep's workers take runs of different owners first
    (:func:`daebench.harness.sweeps.sweep.compile_order`)."""
    if isinstance(cls, type) and issubclass(cls, CompiledIntegrator):
        for klass in cls.__mro__:
            if "method" in vars(klass) and klass is not CompiledIntegrator:
                return klass
    return cls


class CompiledIntegrator(Integrator):
    """Base of integrators with a compiled stepper (see the module docstring)."""

    fail_messages: ClassVar[dict[int, str]] = {}
    _outputs: tuple[np.ndarray, np.ndarray] = _NONE
    _n_recorded = 0

    def method(self) -> Any:
        raise NotImplementedError

    def workspace(self, n: int, m: int) -> Any:
        raise NotImplementedError

    # -- lifecycle -----------------------------------------------------------------------
    def _start(self) -> None:
        p, s = self.problem, self.state
        n, m = p.n, p.m
        if s.a.size != n or s.lam.size != m:
            raise ValueError(f"start() needs a consistent state with {n} accelerations and {m} multipliers "
                             f"(use Problem.acceleration)")
        self._meth = self.method()
        self._ws = self.workspace(n, m)
        self._ctl = self.step_control()
        self._cur = StateArrays(s.q.copy(), s.v.copy(), s.a.copy(), s.lam.copy())
        self._new = methods.state_arrays(n, m)
        self._prev = methods.state_arrays(n, m)
        self._cnt = np.zeros(runner.N_COUNTERS + 1, dtype=np.int64)
        self._blind = _watch.blind(p.n_contacts)
        self._h_next = self.h
        # a plugin's stepper reaches the loop as compiled values (its edits compile its own code only)
        mh = method_handles.handle(self._meth, self._ws, p.kernel, self._ctl, self._cur, self._cnt) \
            if method_handles.applies(self._meth) else None
        self._stepper = (mh, mh) if mh is not None else (self._meth, self._ws)
        status = methods.start(*self._stepper, p.kernel, float(s.t), self._cur, self._cnt)
        self._sync()
        if status:
            raise StepFailure(f"{self._message(status)} (start at t = {s.t:.9g})")

    # -- stepping ----------------------------------------------------------------------------
    def _run(self, t_stop: float, w: _watch.Watch, max_steps: int) -> tuple[int, float, float]:
        t0 = self.state.t
        t_out, out = self._outputs  # set by advance() for the one call that records output rows
        status, k, t_prev, t_now, h_next, h_fail, inner, err, self._n_recorded, _ = runner.run_phase(
            *self._stepper, self.problem.kernel, self._ctl, w, float(t0), float(t_stop), float(self._h_next),
            self._cur, self._new, self._prev, int(max_steps), self._cnt, t_out, out)
        self._sync()
        self._h_next = h_next
        if k:
            self.counters.steps += k - 1  # the base counts the step it is asked for
            self.prev = self._state(t_prev, self._prev)
            self.state = self._state(t_now, self._cur)
        t = self.state.t
        if status == UNDERFLOW_FAIL:
            raise StepFailure(f"step size underflow after a failed step: {self._message(inner)} (t = {t:.9g})", t)
        if status == UNDERFLOW_ERROR:
            raise StepFailure(f"step size underflow (t = {t:.9g}, local error {err:.3g})", t)
        if status:
            raise StepFailure(f"{self._message(status)} (t = {t:.9g}, h = {h_fail:.3g})", t)
        return k, t_prev, t_now

    def _step_impl(self, t_stop: float) -> State:
        self._run(t_stop, self._blind, 1)
        return self.state

    @property
    def records_outputs(self) -> bool:
        """Whether :meth:`advance` takes the output times: when the subclass keeps the Hermite
        :meth:`dense` the runner writes (:mod:`daebench.stepping.dense`) and this
        :meth:`advance` (one that books contact work of its own hands every step back)."""
        own = getattr(self.advance, "__func__", None)  # an instance-level wrapper is not this advance
        return type(self).dense is Integrator.dense and own is CompiledIntegrator.advance

    def advance(self, t_stop: float, watch: _watch.Watch | None = None,
                outputs: np.ndarray | None = None) -> Advance:
        """Many steps in one compiled call, stopping after the first the driver must see.
        With ``outputs`` (the output times from the watch's next one on) a step whose only
        news is an output time is kept: the states at its output times (those :meth:`dense`
        gives) come back in ``RecordedAdvance.outputs``."""
        if t_stop <= self.state.t:
            raise ValueError(f"t_stop = {t_stop} is not after t = {self.state.t}")
        if watch is None:
            return super().advance(t_stop, None)
        w = _watch.own_copy(watch)
        n, m = self.problem.n, self.problem.m
        out = _NO_ROWS
        if outputs is not None and len(outputs):
            t_out = np.ascontiguousarray(outputs[:MAX_OUTPUT_ROWS], dtype=float)
            out = np.empty((t_out.size, 2 + 3 * n + m))
            self._outputs = (t_out, out)
        try:
            k, _, _ = self._run(t_stop, w, MAX_STEPS_PER_CALL)
        except StepFailure as exc:  # the driver writes the rows the quiet steps before it recorded
            exc.outputs = self._recorded(out, n)
            raise
        finally:
            self._outputs = _NONE
        self.counters.steps += 1
        return RecordedAdvance(self.prev, self.state, k, w.armed, w.cmax, self._take_events(),
                               outputs=self._recorded(out, n))

    def _recorded(self, out: np.ndarray, n: int) -> list[tuple[float, State]]:
        """(output time, state) of the rows the last compiled call wrote to ``out``."""
        return [(float(r[0]), State(float(r[1]), r[2:2 + n].copy(), r[2 + n:2 + 2 * n].copy(),
                                    r[2 + 2 * n:2 + 3 * n].copy(), r[2 + 3 * n:].copy()))
                for r in out[:self._n_recorded]]

    # -- helpers ----------------------------------------------------------------------------------
    def _state(self, t: float, arrays: StateArrays) -> State:
        return State(float(t), arrays.q.copy(), arrays.v.copy(), arrays.a.copy(), arrays.lam.copy())

    def _message(self, status: int) -> str:
        text = self.fail_messages.get(int(status), f"step failed (status {status})")
        return text.format(**self.settings)

    def _sync(self) -> None:
        """Move the compiled counters into the integrator's and the problem's counters."""
        c = self._cnt
        self.counters.newton_iterations += int(c[C_NEWTON])
        self.counters.lu_factorizations += int(c[C_LU])
        self.counters.rejected += int(c[C_REJECTED])
        self.problem.counters.residual_evals += int(c[C_RES])
        self.problem.counters.jacobian_evals += int(c[C_JAC])
        c[:] = 0
