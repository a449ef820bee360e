"""Closed forms written here, not taken from daebench, for the tests of `daebench score`: the
pendulum's exact angle (Jacobi elliptic functions, scipy.special.ellipj) and the dropped
ball's impact times and motion (t_k = t_1 + (2 v_1/g) Σ e^j, parabolas between)."""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ellipj, ellipk

G, L, THETA0 = 9.81, 1.0, 30.0          # cases/pendulum.toml
E_BALL, H0, T_BALL = 0.8, 1.0, 2.5      # cases/ball.toml


def pendulum_theta_deg(t: np.ndarray) -> np.ndarray:
    """θ(t) [deg] of the pendulum released from rest at THETA0: θ = 2 arcsin(k sn(ω_n t + K | k²)),
    k = sin(θ0/2), ω_n = √(g/l) (from rest the motion starts at the turning point, u = K)."""
    m = math.sin(0.5 * math.radians(THETA0)) ** 2
    sn, _, _, _ = ellipj(math.sqrt(G / L) * np.asarray(t, float) + ellipk(m), m)
    return np.degrees(2.0 * np.arcsin(math.sqrt(m) * sn))


def ball_impacts() -> list[float]:
    """Impact times of the ball dropped from H0 with restitution E_BALL, up to T_BALL."""
    t1, v1 = math.sqrt(2 * H0 / G), math.sqrt(2 * G * H0)
    out = [t1]
    while out[-1] + 2 * v1 * E_BALL ** len(out) / G <= T_BALL:
        out.append(out[-1] + 2 * v1 * E_BALL ** len(out) / G)
    return out


def ball_motion(t: np.ndarray, impacts: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """(x, v) of the ball at t (after impact k it leaves the ground at v1 e^k)."""
    v1 = math.sqrt(2 * G * H0)
    k = np.searchsorted(impacts, t, side="right")
    t0 = np.where(k > 0, np.asarray(impacts + [math.nan])[np.maximum(k - 1, 0)], 0.0)
    x0 = np.where(k > 0, 0.0, H0)
    v0 = np.where(k > 0, v1 * E_BALL ** k, 0.0)
    tau = t - t0
    return x0 + v0 * tau - 0.5 * G * tau * tau, v0 - G * tau
