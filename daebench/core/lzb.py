"""The Liu–Zhao–Brogliato (LZB) multiple-impact law: a simultaneous impact of several
frictionless contacts resolved at the impulse level, from the contacts' stiffness ratios
and energetic restitution (Liu, Zhao & Brogliato 2008; Nguyen & Brogliato 2014).

The impact is a process in the normal impulses P_i of the contacts taking part (rows G
of their gap Jacobians, ġ = G v < 0 approaching), with the configuration frozen and the
Darboux–Keller dynamics

    M dv = Gᵀ dP   (bilateral rows B v = 0 kept),   so   dġ = W dP,   W = G M_B⁻¹ Gᵀ.

Each contact stores a potential energy E_i: in compression (ġ_i < 0) dE_i = −ġ_i dP_i; in
expansion (ġ_i > 0) dE_i = −ġ_i dP_i / e_i², so that of the work W_c stored in a
compression only e_i² W_c is given back (energetic restitution e_i: the "bi-stiffness"
compliance of the papers; e_i = 0 releases nothing). The contact force behind the
impulses is the compliance law F_i = K_i δ_iⁿ, written with the energy,
F_i = K_i^{1/(n+1)} ((n + 1) E_i)^{n/(n+1)}, and the impulses of the contacts are
distributed as the forces are: with the *primary* contact j, the one storing the most
energy,

    dP_i = (K_i/K_j)^{1/(n+1)} ((n+1) E_i)^{n/(n+1)} / ((n+1) E_j)^{n/(n+1)} dP_j.

The process ends when every contact has given back its energy and none approaches; v⁺ is
then v⁻ + M_B⁻¹ Gᵀ P. The energy balance is exact: T⁻ − T⁺ = Σ_i D_i with the dissipation
D_i = (1/e_i² − 1) ∫_expansion ġ_i dP_i of each contact (its energy lost), which the
result books per contact next to the integration's own energy residual. "None approaches"
is decided to the accuracy asked: approaches slower than u_end = :data:`END_FRACTION` ×
the accuracy (relative to |ġ⁻_j|) are not resolved, and the process ends once no contact
approaches faster and each stores less than ½ u_end²/W_ii (booked as lost). Behind the
wave of a long chain the balls keep relative speeds of round-off size; resolved, their
contacts' slow touches would take most of the steps.

Integration. The distributing rule is the ratio of dP_i = F_i dτ to dP_j = F_j dτ for
one auxiliary parameter τ (the time a compliant model would take; only the stiffness
ratios reach v⁺). The process is integrated in τ, where it is regular — in P_j it is
not at its ends, where F_j → 0 — with state (ġ, δ, P, D), δ_i the deformation whose
potential is E_i = K_i δ_i^{n+1}/(n+1) (dδ_i/dτ = −ġ_i in compression, −ġ_i/e_i² in
expansion): classical Runge–Kutta (order 4) with each step bounded by

* the impulse step: the primary's impulse grows by at most ΔP = P*/N in a step, P* =
  |ġ⁻_j| / W_jj the impulse that stops the first primary contact (the fastest approach);
* the time step T*/N, T* = min_i δ*_i/|ġ⁻_j| with δ*_i = ((n+1) |ġ⁻_j|² / (2 W_ii K_i))^{1/(n+1)}
  the two-body compression of contact i at the fastest approach speed; e_i T*/N while
  contact i expands (an expansion lasts e_i times its compression);
* a grading (h ≤ (T*/N) ((s + h₀)/T*)^β, s the distance in τ from the first touch or to
  a predicted separation, β = 1 − (n+1)/:data:`GRADING`, h₀ = T* N^{−1/(1−β)}) towards
  the points where a contact touches or leaves at a finite speed: there F ∝ s^n is not
  smooth, and uniform steps would give order n + 1 = 5/2 instead of 4 (separations of
  contacts storing less than N⁻⁴ of the first primary's two-body energy are not graded:
  their error is below the target).

The switches — a contact starting compression (ġ_i through 0 from above), turning to
expansion (ġ_i through 0 from below), separating (δ_i through 0) — are located by the
secant method on the step size to :data:`LOCATE_TOL` (relative), so that each step
integrates a smooth right-hand side. Accuracy: the error of v⁺ (relative to |ġ⁻_j|) falls
as N⁻⁴; :func:`steps_for` chooses N = :data:`STEP_CONSTANT` × accuracy^(−1/4), a constant
measured on two-ball impacts and chains of 10 and 100 balls (equal, tapered, e = 0.5 … 1:
errors at N = 50 — the default accuracy 1e-8 — between 1.7e-9 and 6.9e-9 m/s for a 1 m/s
striker; tests/core/test_lzb.py checks the order). Compiled with numba: a ten-ball chain at
the default accuracy takes about 1 200 steps and 4 ms.

A simultaneous impact of two bodies reduces to Newton's law with restitution e (the
energetic coefficient of a frictionless two-body impact is Newton's): the energy given
back is e² W_c, W_c = ½ m* ġ⁻².

References
----------
C. Liu, Z. Zhao, B. Brogliato, Frictionless multiple impacts in multibody systems. I.
Theoretical framework, Proc. R. Soc. A 464 (2008) 3193–3211.
C. Liu, Z. Zhao, B. Brogliato, Energy dissipation and dispersion effects in a granular
media, Phys. Rev. E 78 (2008) 011303.
N. S. Nguyen, B. Brogliato, Multiple Impacts in Dissipative Granular Chains, Springer (2014).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial
from typing import Callable

import numpy as np
from numba import njit

from daebench.core.frictional_impact import FrictionalImpact, constrained_inverse

NAME = "lzb (Liu–Zhao–Brogliato multiple impacts, energetic restitution)"
ACCURACY = 1e-8          # default accuracy target: error of v⁺ relative to the fastest approach speed
STEP_CONSTANT = 0.5      # N = STEP_CONSTANT × accuracy^(−1/4) steps per impulse and time scale (measured)
MIN_STEPS = 8            # N never below this
GRADING = 4.4            # β = 1 − (n + 1)/GRADING: grading exponent 1/(1 − β) above RK4's 4/(n + 1)
ROUNDOFF = 1e-13         # a switching function crossed zero once below −ROUNDOFF (relative)
END_FRACTION = 0.1       # approaches slower than END_FRACTION × the accuracy (relative) are not resolved
LOCATE_TOL = 1e-10       # a switch is located once its function lies in [−LOCATE_TOL, −ROUNDOFF)
LOCATE_ITERS = 60        # secant iterations per located switch
MAX_STEPS = 2_000_000    # steps after which the process is declared not to end
LZB_NO_END = -20         # status: the process did not end within MAX_STEPS

OPEN, COMPRESSION, EXPANSION = 0, 1, 2


@dataclass
class LZBImpact(FrictionalImpact):
    """The outcome of :func:`lzb_impact`: the fields of Newton's law's
    (:class:`daebench.core.frictional_impact.FrictionalImpact`, no tangential impulse)
    and the process's own book."""

    dissipation: np.ndarray = field(default_factory=lambda: np.zeros(0))  # energy lost per contact [J]
    energy_residual: float = math.nan  # (T⁻ − T⁺) − Σ dissipation: the integration's energy error [J]
    steps: int = 0                    # accepted steps (located switches included)
    evaluations: int = 0              # right-hand-side evaluations
    step_count: int = 0               # N, the steps per impulse and time scale


def steps_for(accuracy: float) -> int:
    """N for an accuracy target (error of v⁺ relative to the fastest approach speed):
    the error falls as N⁻⁴ with the constant :data:`STEP_CONSTANT` (module docstring)."""
    if not (0.0 < accuracy < 1.0):
        raise ValueError(f"the LZB accuracy target must lie in (0, 1), got {accuracy!r}")
    return max(MIN_STEPS, math.ceil(STEP_CONSTANT * accuracy ** -0.25))


PLASTIC_E = 0.05     # below this energetic restitution the process's steps grow fast as the accuracy tightens


def failure_message(status: int, steps_per_scale: int = 0, restitution: float | None = None) -> str:
    """Why the process failed and what to change. It does not end within :data:`MAX_STEPS`
    when N (``steps_per_scale``, from the accuracy target) is large, above all for a nearly
    plastic contact: with e = 0 a compressed contact gives nothing back and the process
    ends only once the approaches fall below the target, its steps growing about as
    accuracy^(−0.46) — measured on three equal balls: 23 000 at 1e-8, 536 000 at 1e-11,
    beyond 2 000 000 at 1e-13 (e = 0.5: 12 942 at 1e-13)."""
    if status != LZB_NO_END:
        return f"LZB multiple impact failed (status {status})"
    at = f" at N = {steps_per_scale} steps per impulse and time scale" if steps_per_scale else ""
    why = (f"; with energetic restitution e = {restitution:g} the process ends only once every approach is "
           f"below the accuracy target, and its steps grow about as accuracy^(−0.46) (e = 0, three balls: "
           f"536 000 at 1e-11)" if restitution is not None and restitution < PLASTIC_E else "")
    return (f"LZB multiple impact did not end within {MAX_STEPS} steps{at}{why}: raise contact.lzb_accuracy "
            f"(the default {ACCURACY:g} takes N = {steps_for(ACCURACY)}; N ∝ accuracy^(−1/4)), or use "
            f"contact.impact_law = simultaneous (Newton's law, one LCP per impact)")


def lzb_impact(M: np.ndarray, GN: np.ndarray, v_minus: np.ndarray, stiffness: np.ndarray | float,
               exponent: np.ndarray | float, e: np.ndarray | float, B: np.ndarray | None = None, *,
               accuracy: float = ACCURACY, steps: int | None = None) -> LZBImpact:
    """The LZB law (module docstring) at the contacts whose gap Jacobian rows are ``GN``
    with pre-impact velocities ``v_minus``: contact stiffness K_i and exponent n (``1.5``:
    Hertz), energetic restitution e_i (one value or one per contact), bilateral velocity
    constraints ``B v = 0`` kept. ``steps`` (N) overrides the one :func:`steps_for` gives
    the ``accuracy`` target."""
    GN = np.atleast_2d(np.asarray(GN, float))
    k, n = GN.shape
    B = np.zeros((0, n)) if B is None else np.atleast_2d(B)
    X = constrained_inverse(M, B, GN)
    K, eta, e = _per_contact(stiffness, k), _per_contact(exponent, k), _per_contact(e, k)
    if np.any(K <= 0.0) or np.any(eta <= 0.0):
        raise ValueError("the LZB law needs a positive stiffness and exponent at every contact")
    if np.any((e < 0.0) | (e > 1.0)):
        raise ValueError(f"energetic restitution must lie in [0, 1], got {e}")
    N = steps if steps is not None else steps_for(accuracy)
    P, D = np.zeros(k), np.zeros(k)
    u0 = GN @ v_minus
    status, n_steps, n_evals = _process(np.array(GN @ X, order="C"), np.array(u0), K, eta, e, int(N), P, D)
    v_plus = v_minus + X @ P
    loss = 0.5 * float(v_minus @ M @ v_minus - v_plus @ M @ v_plus)
    return LZBImpact(v_plus, P, np.zeros(k), u0, GN @ v_plus, np.zeros(k), loss, int(status),
                     dissipation=D, energy_residual=loss - float(D.sum()), steps=int(n_steps),
                     evaluations=int(n_evals), step_count=int(N))


def lzb_law(system: object, part: list[int]) -> Callable[..., LZBImpact]:
    """The LZB law of a system's contacts ``part``, called as ``law(M, GN, v_minus, e, B)``:
    :func:`lzb_impact` with the stiffness K_i and exponent n a model declares to offer it
    (``contact_stiffness`` per contact, ``contact_exponent``, default 1.5) and its accuracy
    target (``lzb_accuracy``, default :data:`ACCURACY`)."""
    K = getattr(system, "contact_stiffness", None)
    if K is None or not np.all(np.asarray(K, float)[part] > 0.0):
        raise ValueError(f"contact.impact_law = 'lzb' needs the contacts' stiffness: model "
                         f"{type(system).__name__} declares no positive contact_stiffness")
    return partial(lzb_impact, stiffness=np.asarray(K, float)[part],
                   exponent=float(getattr(system, "contact_exponent", 1.5)),
                   accuracy=float(getattr(system, "lzb_accuracy", ACCURACY)))


def _per_contact(x: np.ndarray | float, k: int) -> np.ndarray:
    """One value per contact, as a fresh writable array (one compiled signature for all calls)."""
    return np.array(np.broadcast_to(np.asarray(x, float), (k,)))


# -- the impact process, compiled -----------------------------------------------------------------
# State y = [ġ; δ; P; D] (4 × k); phase per contact: OPEN, COMPRESSION, EXPANSION. Scales
# s = [u*, δ*, T*, ΔP, h_T, β, h₀, E_min] (module docstring).
@njit(cache=True)
def _forces(K, eta, d, F):
    for i in range(d.shape[0]):
        F[i] = K[i] * max(d[i], 0.0) ** eta[i]


@njit(cache=True)
def _rhs(W, K, eta, inv_e2, phase, y, out, F):
    """dy/dτ with the phases frozen."""
    k = K.shape[0]
    _forces(K, eta, y[1], F)
    for i in range(k):
        out[0, i] = 0.0
    for j in range(k):                      # dġ = W F over the contacts that push
        if F[j] > 0.0:
            for i in range(k):
                out[0, i] += W[i, j] * F[j]
    for i in range(k):
        p = phase[i]
        rate = 1.0 if p == COMPRESSION else (inv_e2[i] if p == EXPANSION else 0.0)
        out[1, i] = -rate * y[0, i]
        out[2, i] = F[i]
        out[3, i] = (inv_e2[i] - 1.0) * y[0, i] * F[i] if p == EXPANSION else 0.0


@njit(cache=True)
def _rk4(W, K, eta, inv_e2, phase, y, h, out, ws, F):
    """One classical Runge–Kutta step of length h from y into out (ws: 5 × 4 × k scratch)."""
    k1, k2, k3, k4, yt = ws[0], ws[1], ws[2], ws[3], ws[4]
    _rhs(W, K, eta, inv_e2, phase, y, k1, F)
    yt[:, :] = y + 0.5 * h * k1
    _rhs(W, K, eta, inv_e2, phase, yt, k2, F)
    yt[:, :] = y + 0.5 * h * k2
    _rhs(W, K, eta, inv_e2, phase, yt, k3, F)
    yt[:, :] = y + h * k3
    _rhs(W, K, eta, inv_e2, phase, yt, k4, F)
    out[:, :] = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


@njit(cache=True)
def _switching(phase, y, u_scale, d_scale, u_end, g):
    """Per contact, the functions whose crossing below zero switches its phase (2 × k,
    relative): row 0 ġ + u_end (open: touches; expansion: compressed again) or −ġ
    (compression: turns to expansion); row 1 δ in expansion (separates), +∞ otherwise."""
    for i in range(phase.shape[0]):
        u = y[0, i] / u_scale
        g[0, i] = -u if phase[i] == COMPRESSION else u + u_end
        g[1, i] = y[1, i] / d_scale if phase[i] == EXPANSION else np.inf


@njit(cache=True)
def _switch(K, eta, e, phase, y, c, which):
    """Switch contact c whose function ``which`` crossed zero."""
    p = phase[c]
    if which == 1:                           # separated: its energy is given back
        y[1, c] = 0.0
        phase[c] = OPEN
    elif p == OPEN or p == EXPANSION:
        phase[c] = COMPRESSION
    elif e[c] > 0.0:
        phase[c] = EXPANSION
    else:                                    # e = 0: nothing is given back
        y[3, c] += K[c] * y[1, c] ** (eta[c] + 1.0) / (eta[c] + 1.0)
        y[1, c] = 0.0
        phase[c] = OPEN


@njit(cache=True)
def _settle(W, K, eta, e, phase, y, u_scale, F):
    """Phases at a step's start where a switching function sits on zero: a compressed
    contact at rest that is being pushed apart turns to expansion; a contact with no
    deformation that is not pushed is open."""
    k = K.shape[0]
    _forces(K, eta, y[1], F)
    for i in range(k):
        du = 0.0
        for j in range(k):
            du += W[i, j] * F[j]
        u, d = y[0, i], y[1, i]
        if abs(u) <= ROUNDOFF * u_scale and du > 0.0 and phase[i] == COMPRESSION and d > 0.0:
            _switch(K, eta, e, phase, y, i, 0)
        if phase[i] != OPEN and y[1, i] <= 0.0 and u >= 0.0 and du >= 0.0:
            phase[i] = OPEN


@njit(cache=True)
def _step_size(K, eta, e, inv_e2, phase, y, tau, s):
    """The step (module docstring): at most h_T (e_i h_T while contact i expands), the
    primary's impulse step, graded near a touch at τ = 0 and a predicted separation."""
    T, dP, hT, beta, h0, E_min = s[2], s[3], s[4], s[5], s[6], s[7]
    h = _graded(tau, T, hT, h0, beta)
    Ej, j = 0.0, -1
    for i in range(K.shape[0]):
        d = y[1, i]
        if phase[i] != OPEN and d > 0.0:
            E = K[i] * d ** (eta[i] + 1.0) / (eta[i] + 1.0)
            if E > Ej:
                Ej, j = E, i
            if phase[i] == EXPANSION and y[0, i] > 0.0 and E > E_min:
                # an expansion lasts e_i times a compression: its scales shrink by e_i
                h = min(h, _graded(d / (inv_e2[i] * y[0, i]), e[i] * T, e[i] * hT, e[i] * h0, beta))
    if j >= 0:
        h = min(h, dP / (K[j] * y[1, j] ** eta[j]))
    return h


@njit(cache=True)
def _graded(dist, T, hT, h0, beta):
    """h_T, graded towards a non-smooth point at distance ``dist``: h_T ((dist + h₀)/T)^β."""
    return hT * ((dist + h0) / T) ** beta if dist < T else hT


@njit(cache=True)
def _advance(W, K, eta, e, inv_e2, phase, y, h, s, ws, F, y1, ym, g0, g1, gm):
    """One step of at most h from y, cut at the first switch (secant method on the step
    length); y and the phases updated in place. Returns (step length, evaluations)."""
    u_scale, d_scale, u_end = s[0], s[1], s[8]
    _switching(phase, y, u_scale, d_scale, u_end, g0)
    lo, hi = 0.0, h
    _rk4(W, K, eta, inv_e2, phase, y, hi, y1, ws, F)
    _switching(phase, y1, u_scale, d_scale, u_end, g1)
    evals = 4
    for _ in range(LOCATE_ITERS):
        est, worst = np.inf, 0.0
        for which in range(2):
            for i in range(K.shape[0]):
                if g1[which, i] < -ROUNDOFF:
                    worst = min(worst, g1[which, i])
                    est = min(est, lo + (hi - lo) * g0[which, i] / (g0[which, i] - g1[which, i]))
        if worst >= -LOCATE_TOL:
            break
        w = hi - lo
        est = min(max(est, lo + 1e-3 * w), hi - 1e-3 * w)
        _rk4(W, K, eta, inv_e2, phase, y, est, ym, ws, F)
        _switching(phase, ym, u_scale, d_scale, u_end, gm)
        evals += 4
        if np.any(gm < -ROUNDOFF):
            hi = est
            y1[:, :] = ym
            g1[:, :] = gm
        else:
            lo = est
            g0[:, :] = gm
    y[:, :] = y1
    for which in range(2):
        for i in range(K.shape[0]):
            if g1[which, i] < -ROUNDOFF:
                _switch(K, eta, e, phase, y, i, which)
    return hi, evals


@njit(cache=True)
def _ended(W, K, eta, phase, y, u_min):
    """Whether the process has ended: no contact approaches faster than u_min and each
    stores less energy than ½ u_min²/W_ii (what an approach at u_min would store); the
    energy left is booked as lost (D) and the contacts open."""
    k = K.shape[0]
    for i in range(k):
        if y[0, i] < -u_min:
            return False
        if phase[i] != OPEN and K[i] * max(y[1, i], 0.0) ** (eta[i] + 1.0) / (eta[i] + 1.0) > 0.5 * u_min ** 2 / W[i, i]:
            return False
    for i in range(k):
        if phase[i] != OPEN:
            y[3, i] += K[i] * max(y[1, i], 0.0) ** (eta[i] + 1.0) / (eta[i] + 1.0)
            y[1, i] = 0.0
            phase[i] = OPEN
    return True


@njit(cache=True)
def _process(W, u0, K, eta, e, N, P, D):
    """The whole impact process from ġ⁻ = u0 with N steps per scale; the impulses and the
    dissipation per contact into P and D. Returns (status, steps, evaluations)."""
    k = u0.shape[0]
    u_scale = max(-u0.min(), 0.0)
    P[:] = 0.0
    D[:] = 0.0
    if u_scale == 0.0:
        return 0, 0, 0
    inv_e2 = np.zeros(k)
    for i in range(k):
        if e[i] > 0.0:
            inv_e2[i] = 1.0 / (e[i] * e[i])
    # scales: the two-body compression of each contact at the fastest approach speed
    j = int(np.argmin(u0))
    d_max = np.empty(k)
    for i in range(k):
        d_max[i] = ((eta[i] + 1.0) * u_scale ** 2 / (2.0 * W[i, i] * K[i])) ** (1.0 / (eta[i] + 1.0))
    T = d_max.min() / u_scale
    beta = max(0.0, 1.0 - (eta.min() + 1.0) / GRADING)
    u_end = END_FRACTION * (STEP_CONSTANT / N) ** 4
    s = np.array([u_scale, d_max.max(), T, u_scale / W[j, j] / N, T / N, beta,
                  T * N ** (-1.0 / (1.0 - beta)), 0.5 * u_scale ** 2 / W[j, j] * float(N) ** -4, u_end])
    y = np.zeros((4, k))
    y[0] = u0
    phase = np.zeros(k, np.int64)
    for i in range(k):
        if u0[i] < -u_end * u_scale:
            phase[i] = COMPRESSION
    ws = np.empty((5, 4, k))
    F = np.empty(k)
    y1, ym = np.empty((4, k)), np.empty((4, k))
    g0, g1, gm = np.empty((2, k)), np.empty((2, k)), np.empty((2, k))
    tau = 0.0
    steps = evals = 0
    while steps < MAX_STEPS:
        _settle(W, K, eta, e, phase, y, u_scale, F)
        if _ended(W, K, eta, phase, y, u_scale * u_end):
            P[:] = y[2]
            D[:] = y[3]
            return 0, steps, evals
        h = _step_size(K, eta, e, inv_e2, phase, y, tau, s)
        dt, n_eval = _advance(W, K, eta, e, inv_e2, phase, y, h, s, ws, F, y1, ym, g0, g1, gm)
        tau += dt
        evals += n_eval
        steps += 1
    P[:] = y[2]
    D[:] = y[3]
    return LZB_NO_END, steps, evals
