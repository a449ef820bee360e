"""Closed forms of the planar rigid-body cases (:mod:`daebench.models.rigid2d`): the
independent truth their tests assert.

Block on an incline (``block-incline``), launched up the slope at v0 (φ the incline, μ
the friction coefficient, g gravity)::

    sliding up:      ẍ = −g (sin φ + μ cos φ),   stops at  t_s = v0 / (g (sin φ + μ cos φ)),
                                                            x_s = v0² / (2 g (sin φ + μ cos φ))
    then tan φ ≤ μ:  sticks at x_s
         tan φ > μ:  slides back, ẍ = −g (sin φ − μ cos φ)

Rocking block (``rocking-block``; Housner 1963): a rectangle of half-width b and
half-height h, R = √(b² + h²), slenderness α = atan(b/h), rocking about a corner that
sticks, no bounce. The impact on the other corner conserves the angular momentum about
it; the angular velocity after an impact is r = 1 − (3/2) sin²α times the one before.
Between impacts the motion about the pivot conserves energy with I_O = (4/3) m R²::

    ½ I_O ω² = m g R (cos(α − |θ_0|) − cos(α − |θ|))

so the block released from rest at tilt θ0 reaches θ = 0 with
ω₁ = √(2 m g R (cos(α − θ0) − cos α) / I_O), and the k-th impact has ω_k⁻ = r^{k−1} ω₁.

Falling rod (``falling-rod``): a uniform rod (length L, J = m L²/12) at tilt θ strikes
the ground with its lower end at normal velocity U_N⁻ < 0 (slip U_T⁻). With the
contact's Delassus matrix W = G M⁻¹ Gᵀ over (normal, tangent) rows G and Newton's law
with Coulomb friction (the impact law the time steppers converge to), the impulse
(P_N, P_T) is

    stick  (|P_T| ≤ μ P_N):  W (P_N, P_T) = (−(1 + e) U_N⁻, −U_T⁻)
    slip   P_T = −s μ P_N:    P_N = −(1 + e) U_N⁻ / (W_NN − s μ W_NT),  s = sign(U_T⁺)

and v⁺ = v⁻ + M⁻¹ Gᵀ (P_N, P_T). Frictionless (μ = 0): P_N = −(1 + e) U_N⁻ / W_NN.

References: G. W. Housner, "The behavior of inverted pendulum structures during
earthquakes", Bull. Seismol. Soc. Am. 53 (1963) 403–417. F. Pfeiffer, C. Glocker,
Multibody Dynamics with Unilateral Contacts (1996), §7. C. Glocker, Set-Valued Force
Laws (2001).
"""

from __future__ import annotations

import math

import numpy as np


def incline_motion(v0: float, phi: float, mu: float, g: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x(t) − x(0), ẋ(t)) of a block launched up an incline at v0 > 0 (φ in radians)."""
    t = np.asarray(t, float)
    a1 = g * (math.sin(phi) + mu * math.cos(phi))
    ts = v0 / a1
    xs = v0 * v0 / (2.0 * a1)
    up = t <= ts
    x = np.where(up, v0 * t - 0.5 * a1 * t * t, xs)
    v = np.where(up, v0 - a1 * t, 0.0)
    if math.tan(phi) > mu:
        a2 = g * (math.sin(phi) - mu * math.cos(phi))
        tau = np.maximum(t - ts, 0.0)
        x = np.where(up, x, xs - 0.5 * a2 * tau * tau)
        v = np.where(up, v, -a2 * tau)
    return x, v


def incline_stop(v0: float, phi: float, mu: float, g: float) -> tuple[float, float]:
    """(t_s, x_s): when and how far up the slope the block stops."""
    a1 = g * (math.sin(phi) + mu * math.cos(phi))
    return v0 / a1, v0 * v0 / (2.0 * a1)


def housner_ratio(width: float, height: float) -> float:
    """Angular-velocity ratio per impact of a rocking rectangle, 1 − 1.5 sin²α."""
    alpha = math.atan(width / height)
    return 1.0 - 1.5 * math.sin(alpha) ** 2


def rocking_impact_omegas(width: float, height: float, theta0: float, g: float, count: int) -> np.ndarray:
    """|ω| just before each of the first ``count`` impacts of a block released from rest
    at tilt θ0 (radians, 0 < θ0 < α)."""
    b, h = 0.5 * width, 0.5 * height
    R = math.hypot(b, h)
    alpha = math.atan(b / h)
    w1 = math.sqrt(2.0 * g * R * (math.cos(alpha - abs(theta0)) - math.cos(alpha)) / (4.0 / 3.0 * R * R))
    r = housner_ratio(width, height)
    return w1 * r ** np.arange(count)


def rod_impact(length: float, theta: float, vy_minus: float, vx_minus: float, e: float, mu: float,
               mass: float = 1.0) -> tuple[float, float, np.ndarray]:
    """(P_N, P_T, v⁺ = (ẋ, ẏ, θ̇)) of a falling rod (no rotation before) striking with its
    lower end (body point (0, −L/2)) at tilt θ (radians)."""
    J = mass * length * length / 12.0
    p, r = 0.0, -0.5 * length
    s, c = math.sin(theta), math.cos(theta)
    Minv = np.diag([1.0 / mass, 1.0 / mass, 1.0 / J])
    G = np.array([[0.0, 1.0, p * c - r * s], [1.0, 0.0, -(p * s + r * c)]])
    W = G @ Minv @ G.T
    vm = np.array([vx_minus, vy_minus, 0.0])
    un, ut = G @ vm
    if mu == 0.0:
        P = np.array([-(1.0 + e) * un / W[0, 0], 0.0])
    else:
        P = np.linalg.solve(W, [-(1.0 + e) * un, -ut])
        if abs(P[1]) > mu * P[0]:
            for sgn in (1.0, -1.0):
                pn = -(1.0 + e) * un / (W[0, 0] - sgn * mu * W[0, 1])
                P = np.array([pn, -sgn * mu * pn])
                ut_plus = ut + W[1] @ P
                if pn >= 0.0 and sgn * ut_plus >= 0.0:
                    break
    return float(P[0]), float(P[1]), vm + Minv @ G.T @ P
