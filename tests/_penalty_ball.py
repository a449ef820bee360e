"""The ball on the penalty law's ground, integrated independently of daebench (scipy's DOP853
on m ẍ = −m g + max(0, −k x − c ẋ)·[x < 0]): the truth the penalty ball's tests hold runs to."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

M, G, K, C, H0 = 1.0, 9.81, 1e5, 45.0, 1.0   # the ball's values and the penalty law's defaults


def penalty_ball_height(t_out: np.ndarray, damping: float = C) -> np.ndarray:
    """x(t) of m ẍ = −m g + max(0, −k x − c ẋ)·[x < 0] (clipped, as daebench.core.contact)."""
    def rhs(t, y):
        x, v = y
        f = max(0.0, -K * x - damping * v) if x < 0.0 else 0.0
        return [v, -G + f / M]
    sol = solve_ivp(rhs, (0.0, float(t_out[-1])), [H0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14,
                    t_eval=t_out, max_step=1e-4)
    return sol.y[0]
