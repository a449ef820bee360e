"""Step-size control, apart from the stepper (as diffrax separates them).

A stepper proposes a step of size h and an error estimate err (a weighted RMS norm,
:func:`weighted_rms`: err ≤ 1 means within tolerance). :class:`StepControl` decides:

* fixed steps: every step is h (``adaptive`` False), the error is ignored;
* adaptive: accept when err ≤ 1; the next step is h · clip(SAFETY · err^(−1/(p+1)),
  FAC_MIN, FAC_MAX) (an I-controller, p the order of the error estimate's method); a
  rejected step retries with that factor (≥ FAC_MIN); a step whose nonlinear solve
  failed retries with FAC_FAIL · h. A step cut short to land on t_stop does not shrink
  the step it replaced.

:func:`land` is the one rule for reaching ``t_stop`` exactly: a step within SNAP · h of
it is stretched (or shrunk) to end on it, so no sliver of a step is ever taken.

References: Hairer, Nørsett & Wanner (1993), Solving ODEs I, §II.4 (step-size control);
Söderlind (2002), Automatic control and adaptive time-stepping, Numer. Algorithms 31.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from numba import njit

#: stretch a step by up to this fraction of h to land exactly on t_stop. t advances by
#: t + h in floating point, whose rounding accumulates: t_end = 400 s in steps of 1e-3 s
#: falls 2.5e-9 s = 2.5e-6 h short after 400 000 steps, and a window of 1e-6 h took a
#: 400 001st step of 2.5e-9 s. The drift is ≲ N · ulp(t_end) / 2; 1e-3 h covers it up to
#: N ≈ 3e6 steps at t_end = 1e3 s, and stretching one step by 0.1 % changes no error order.
SNAP = 1e-3
SAFETY = 0.9                 # step-size controller safety factor
FAC_MIN, FAC_MAX = 0.2, 5.0  # bounds of the step-size change factor
FAC_FAIL = 0.25              # step shrink after a failed nonlinear solve (adaptive mode)
H_MIN_REL = 1e-12            # smallest step relative to max(1, |t|) before giving up


class StepControl(NamedTuple):
    """Fixed step ``h`` or adaptive control to (rtol, atol); ``exponent`` = 1/(p+1)."""

    adaptive: bool
    h: float
    rtol: float
    atol: float
    exponent: float
    h_min_rel: float = H_MIN_REL


def fixed(h: float) -> StepControl:
    return StepControl(False, float(h), 0.0, 0.0, 0.5)


def adaptive(h0: float, rtol: float, atol: float, order: int) -> StepControl:
    """Error control for a method whose local error estimate is O(h^(order+1))."""
    return StepControl(True, float(h0), float(rtol), float(atol), 1.0 / (order + 1.0))


@njit(cache=True, inline="always")
def land(t, t_stop, h_try):
    """(h, t_new) of a step of about ``h_try`` from t that ends exactly on t_stop when it
    comes within SNAP · h_try of it."""
    remaining = t_stop - t
    if h_try * (1.0 + SNAP) >= remaining:
        return remaining, t_stop
    return h_try, t + h_try


@njit(cache=True, inline="always")
def weighted_rms(e, y_new, y_old, rtol, atol):
    """‖e / (atol + rtol · max(|y_new|, |y_old|))‖_RMS."""
    n = e.shape[0]
    acc = 0.0
    for i in range(n):
        w = atol + rtol * max(abs(y_new[i]), abs(y_old[i]))
        acc += (e[i] / w) ** 2
    return math.sqrt(acc / n) if n else 0.0


@njit(cache=True, inline="always")
def judge(ctl, err, h, h_try):
    """(accepted, next step) after a step of size h (tried as h_try) with error err."""
    if err > 1.0:
        return False, h * max(FAC_MIN, SAFETY * err ** (-ctl.exponent))
    fac = FAC_MAX if err == 0.0 else min(FAC_MAX, SAFETY * err ** (-ctl.exponent))
    if h < h_try:  # cut short to land on t_stop: says nothing against h_try
        return True, max(h * fac, h_try)
    return True, h * fac


@njit(cache=True, inline="always")
def h_min(ctl, t):
    return ctl.h_min_rel * max(1.0, abs(t))
