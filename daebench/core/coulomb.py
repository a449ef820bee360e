"""Coulomb friction at the closed contacts of a phase, compiled: the data the compiled
phase reads (:class:`FrictionData`) and the rules the driver and the compiled loops share.

The mechanism (stick rows, slip force, the switches between them) is explained in
:mod:`daebench.driver.stickslip`, which decides the sticking and slipping contacts; this
module is what the phase (:mod:`daebench.core.phase`) makes of that decision, so that a
frictional phase runs through the same compiled functions as a frictionless one:

* **stick rows** (:func:`stick_rows`) — constraint rows of the phase after the model's
  bilateral ones: C_T = s(q) − s(q*) (the tangential position as the Gauss–Legendre line
  integral of the tangent row t_q from the anchor q*), C_q = t_q, C_t = 0 and
  γ_T = −(t_q)_q[v] v by a 4-point central difference;
* **slip force** — −μ s λ_N t_qᵀ per slipping contact, λ_N its consistent normal force
  (:func:`daebench.core.phase.slip_normal_forces`: the augmented system with the friction
  columns), added to the phase's applied force;
* **the switches** (:func:`switches`) — a slipping contact's slip rate through zero
  (:func:`slip_rate`), a stick group's force out of its cone (:func:`cone_margin`): the
  one rule the driver's event search and the compiled watch both apply;
* **the slip friction's work** (:func:`book_step`, :func:`book_rows`) — the trapezoidal
  rule over the integrator's own steps, as the driver books every work, done by the
  compiled loop for the steps it takes on its own (so that a slipping phase runs many
  steps per call like a frictionless one).

A frictionless phase carries :data:`NONE`, of its own class :class:`Frictionless` (the
same fields, empty): compiled code reaches the friction data through :func:`present`, None
for it, so that numba drops the friction branches when it compiles a frictionless phase —
nothing here is compiled, or run, for it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from numba.extending import overload

from daebench.core import kernels
from daebench.core.borrow import uncounted

QUAD_NODES = 6             # Gauss–Legendre nodes of the tangential-position line integral
GAMMA_STEP = 1e-3          # rad-scale step of the 4-point difference for γ_T = −(t_q)_q[v] v
CONE_TOL = 1e-9            # |λ_T| ≤ μ λ_N (1 + CONE_TOL) + round-off: still sticking
SLIP_MIN = 1e-9            # m/s: a slip velocity below this after an impact sticks
BOOK_SLOTS = 5             # book: W and P at the last step's start, W and P at its end, steps booked

_GL_X, _GL_W = np.polynomial.legendre.leggauss(QUAD_NODES)
_GL_X, _GL_W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W


class FrictionData(NamedTuple):
    """The closed frictional contacts of one phase (fixed for the phase) and the scratch of
    its compiled functions. Stick row r is constraint row ``nb − n_stick + r`` of the phase;
    a closed contact's normal row is ``nb + its index in the active set``."""

    stick: np.ndarray       # int64 (n_stick): the contact of each stick row kept
    anchor: np.ndarray      # float64 (n_stick, n): its anchor q*
    group_ptr: np.ndarray   # int64 (n_stick + 1): group r's members are group_act[group_ptr[r]:group_ptr[r + 1]]
    group_act: np.ndarray   # int64: the active index of each member (its normal row)
    group_mu: np.ndarray    # float64 (n_stick): the group's μ (its members' smallest)
    slip: np.ndarray        # int64 (n_slip): the slipping contacts
    slip_act: np.ndarray    # int64 (n_slip): their active index
    slip_s: np.ndarray      # float64 (n_slip): their slip direction s = ±1
    slip_mu: np.ndarray     # float64 (n_slip): their μ
    book: np.ndarray        # float64[BOOK_SLOTS]: slip friction work W and power P (book_step)
    row_work: np.ndarray    # float64: W at each output row the compiled loop wrote (book_rows)
    # scratch (sized n, m = the phase's constraint rows)
    A: np.ndarray           # (n + m, n + m)
    piv: np.ndarray         # int64 (n + m)
    b: np.ndarray           # (n + m)
    M: np.ndarray           # (n, n)
    Q: np.ndarray           # (n)
    C: np.ndarray           # (m)
    Cq: np.ndarray          # (m, n)
    Ct: np.ndarray          # (m)
    gam: np.ndarray         # (m)
    T: np.ndarray           # (n_slip, n): tangent rows of the slipping contacts
    tq: np.ndarray          # (n)
    pt: np.ndarray          # (n): a quadrature or difference point of a stick row
    zero: np.ndarray        # (n) zeros (the velocity the tangent rows of positions are taken at)
    xd: np.ndarray          # (n): a perturbed coordinate vector (force Jacobian)
    fp: np.ndarray          # (n)
    fm: np.ndarray          # (n)


def _i(*shape: int) -> np.ndarray:
    return np.zeros(shape, np.int64)


def _f(*shape: int) -> np.ndarray:
    return np.zeros(shape)


#: the class of :data:`NONE`: FrictionData's fields, a type of its own in compiled code
Frictionless = NamedTuple("Frictionless", [(f, np.ndarray) for f in FrictionData._fields])


def present(fr):
    """``fr``, or None for a frictionless phase's :data:`NONE`. In compiled code the answer
    follows from the type: a function given ``present(ph.friction)`` that tests ``fr is
    None`` has its friction branch removed before typing (numba's branch pruning on None
    arguments), when compiled for a frictionless phase."""
    return None if isinstance(fr, Frictionless) else fr


@overload(present, inline="always")
def _present_compiled(fr):
    if fr.instance_class is Frictionless:
        return lambda fr: None
    return lambda fr: fr


#: the friction data of a frictionless phase
NONE = Frictionless(_i(0), _f(0, 0), _i(1), _i(0), _f(0), _i(0), _i(0), _f(0), _f(0), _f(BOOK_SLOTS), _f(0),
                    _f(0, 0), _i(0), _f(0), _f(0, 0), _f(0), _f(0), _f(0, 0), _f(0), _f(0), _f(0, 0), _f(0), _f(0),
                    _f(0), _f(0), _f(0), _f(0))

#: output rows whose friction work a compiled call can write (at least what one call records)
ROW_CAPACITY = 4096


def friction_data(n: int, m: int, active: tuple[int, ...], groups: dict[int, list[int]],
                  anchors: dict[int, np.ndarray], slip: dict[int, float], mu: np.ndarray) -> FrictionData:
    """The friction data of a phase with n coordinates and m constraint rows (stick rows
    included): ``groups`` {kept stick contact: its parallel group}, ``anchors`` {contact: q*},
    ``slip`` {contact: s}, ``mu`` per contact; :data:`NONE` when nothing sticks or slips."""
    if not groups and not slip:
        return NONE
    kept = list(groups)
    members = [active.index(c) for k in kept for c in groups[k]]
    ptr = np.cumsum([0] + [len(groups[k]) for k in kept]).astype(np.int64)
    sl = list(slip)
    k = m + n
    return FrictionData(
        np.array(kept, np.int64), np.array([anchors[c] for c in kept], float).reshape(len(kept), n), ptr,
        np.array(members, np.int64), np.array([min(float(mu[c]) for c in groups[k]) for k in kept]),
        np.array(sl, np.int64), np.array([active.index(c) for c in sl], np.int64),
        np.array([float(slip[c]) for c in sl]), np.array([float(mu[c]) for c in sl]), _f(BOOK_SLOTS),
        _f(ROW_CAPACITY if sl else 0), _f(k, k), _i(k), _f(k), _f(n, n), _f(n), _f(m), _f(m, n), _f(m), _f(m),
        _f(len(sl), n), _f(n), _f(n), _f(n), _f(n), _f(n), _f(n))


# -- the rules --------------------------------------------------------------------------------
@uncounted
def slip_rate(md, c, q, v, tq, zero):
    """The slip velocity t_q(q) v of contact c (``tq`` receives its tangent row, taken at the
    velocity ``zero``, a zero vector, like the stick rows)."""
    kernels.tangent(md, c, q, zero, tq)
    u = 0.0
    for i in range(q.shape[0]):
        u += tq[i] * v[i]
    return u


@njit(cache=True)
def cone_margin(mu, lam_n, lam_t):
    """μ Σλ_N − |λ_T| of a stick group, with the tolerance CONE_TOL (and round-off of λ_T):
    negative when its force has left the friction cone."""
    return mu * lam_n * (1.0 + CONE_TOL) + 1e-12 * abs(lam_t) - abs(lam_t)


@uncounted
def group_margin(fr, r, nb, lam):
    """(cone margin, λ_T) of stick group r at the phase's multipliers λ (``nb``: the phase's
    bilateral rows, stick rows included)."""
    lam_t = lam[nb - fr.stick.shape[0] + r]
    lam_n = 0.0
    for k in range(fr.group_ptr[r], fr.group_ptr[r + 1]):
        lam_n += lam[nb + fr.group_act[k]]
    return cone_margin(fr.group_mu[r], lam_n, lam_t), lam_t


@uncounted
def switches(md, fr, nb, q, v, lam):
    """Whether a stick/slip switch happened at (q, v) with the consistent multipliers λ: a
    slipping contact's slip rate s t_q v below zero ("stop"), a stick group out of its cone
    ("slide") — the driver's rule (:func:`daebench.driver.events.find_event`)."""
    for k in range(fr.slip.shape[0]):
        if fr.slip_s[k] * slip_rate(md, fr.slip[k], q, v, fr.tq, fr.zero) < 0.0:
            return True
    for r in range(fr.stick.shape[0]):
        margin, _ = group_margin(fr, r, nb, lam)
        if margin < 0.0:
            return True
    return False


# -- stick rows -----------------------------------------------------------------------------
@uncounted
def stick_rows(md, fr, r0, q, v, C, Cq, Ct, gam):
    """Rows r0, r0 + 1, … of the stick rows (module docstring): C_T by the line integral of
    t_q from q* to q, C_q = t_q(q), C_t = 0, γ_T = −d/dε [t_q(q + εv) v] by the 4-point
    central difference with ε = GAMMA_STEP / max|v| (γ_T = 0 at v = 0)."""
    ns = fr.stick.shape[0]
    if ns == 0:
        return
    n = q.shape[0]
    scale = 0.0
    for i in range(n):
        scale = max(scale, abs(v[i]))
    e = GAMMA_STEP / scale if scale > 0.0 else 0.0
    tq, pt, z = fr.tq, fr.pt, fr.zero
    for r in range(ns):
        j = fr.stick[r]
        a = fr.anchor[r]
        row = r0 + r
        kernels.tangent(md, j, q, z, tq)
        for i in range(n):
            Cq[row, i] = tq[i]
        c = 0.0
        for k in range(_GL_X.shape[0]):
            for i in range(n):
                pt[i] = a[i] + _GL_X[k] * (q[i] - a[i])
            kernels.tangent(md, j, pt, z, tq)
            s = 0.0
            for i in range(n):
                s += tq[i] * (q[i] - a[i])
            c += _GL_W[k] * s
        C[row] = c
        Ct[row] = 0.0
        g = 0.0
        if e:
            f1 = _rate_at(md, j, q, v, e, tq, pt, z)
            f2 = _rate_at(md, j, q, v, -e, tq, pt, z)
            f3 = _rate_at(md, j, q, v, 2.0 * e, tq, pt, z)
            f4 = _rate_at(md, j, q, v, -2.0 * e, tq, pt, z)
            g = -(8.0 * (f1 - f2) - (f3 - f4)) / (12.0 * e)
        gam[row] = g


@uncounted
def _rate_at(md, j, q, v, s, tq, pt, z):
    """t_q(q + s v) · v."""
    n = q.shape[0]
    for i in range(n):
        pt[i] = q[i] + s * v[i]
    kernels.tangent(md, j, pt, z, tq)
    f = 0.0
    for i in range(n):
        f += tq[i] * v[i]
    return f


# -- the slip friction's work -----------------------------------------------------------------
def start_book(fr: FrictionData, work: float, power: float) -> None:
    """Before a compiled call: the work booked so far and the power at the state it starts from."""
    fr.book[:] = (work, power, work, power, 0.0)


@uncounted
def book_step(fr, t0, t1, power):
    """Book the step t0 → t1 ending at slip power ``power``: W += ½ (t1 − t0)(P0 + P1), the
    driver's trapezoidal rule; the step's start values kept for the driver."""
    b = fr.book
    b[0] = b[2]
    b[1] = b[3]
    b[2] = b[0] + 0.5 * (t1 - t0) * (b[1] + power)
    b[3] = power
    b[4] += 1.0


@uncounted
def book_rows(fr, t0, t1, t_out, oi, j, nrow):
    """The work at output times t_out[oi:j] inside the step t0 → t1 just booked, into
    row_work[nrow:]: W0 + ½ (t − t0)(P0 + P(t)), P linear over the step (the driver's
    rule for a row inside a step). Returns False when row_work cannot hold them."""
    if nrow + j - oi > fr.row_work.shape[0]:
        return False
    b = fr.book
    dt = t1 - t0
    for k in range(oi, j):
        to = t_out[k]
        th = 0.0 if dt == 0.0 else (to - t0) / dt
        pk = b[1] + th * (b[3] - b[1])
        fr.row_work[nrow + k - oi] = b[0] + 0.5 * (to - t0) * (b[1] + pk)
    return True
