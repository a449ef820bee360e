"""The stepper interface: what a method's data class implements to run in
:func:`daebench.stepping.runner.run_phase` (and so under the event-driven driver, fixed
or adaptive, compiled) — the counterpart for methods of :mod:`daebench.core.kernels`.

A method is two NamedTuples of its own: its *data* (coefficients, settings: fixed for
a run) and its *workspace* (history and scratch arrays: changed in place). It
registers three functions for its data class::

    start(meth, ws, ph, t, cur, cnt) -> status
        (Re)start at the consistent state ``cur`` of a new phase: forget history.
    step(meth, ws, ph, ctl, t, h, cur, new, cnt) -> (status, err)
        Propose the state at t + h from ``cur`` into ``new`` (q, v, a, λ). status 0 =
        solved, > 0 = the step failed (the method's own codes, 1 … 99). err is the
        weighted RMS local error estimate (:func:`daebench.stepping.control.weighted_rms`
        with ctl.rtol, ctl.atol), read only by adaptive control.
    accept(meth, ws, h, prev, cur) -> None
        The step from ``prev`` to ``cur`` of size h was accepted: update the history.

``cur``, ``new`` and ``prev`` are :class:`StateArrays`; ``ph`` is the phase
(:class:`daebench.core.phase.PhaseData`) through which the model is evaluated; ``cnt`` is
an int64 array of work counters (:data:`C_NEWTON`, …) the method adds to.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from daebench.core.dispatch import generic

C_NEWTON, C_LU, C_RES, C_JAC = range(4)
N_COUNTERS = 4


class StateArrays(NamedTuple):
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    lam: np.ndarray


def state_arrays(n: int, m: int) -> StateArrays:
    return StateArrays(np.empty(n), np.empty(n), np.empty(n), np.empty(m))


@generic
def start(meth, ws, ph, t, cur, cnt):
    """Restart on a new phase at the consistent state ``cur``; returns a status."""


@generic
def step(meth, ws, ph, ctl, t, h, cur, new, cnt):
    """Propose the step t → t + h into ``new``; returns (status, err)."""


@generic
def accept(meth, ws, h, prev, cur):
    """Commit the accepted step prev → cur (size h) to the method's history."""
