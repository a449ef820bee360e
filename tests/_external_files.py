"""Files another code might write, built from the closed forms of tests/_closed_forms.py (not
from daebench): the exact ball written event-driven (two rows per impact) and the pendulum."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from _closed_forms import E_BALL, G, H0, T_BALL, ball_impacts, ball_motion, pendulum_theta_deg


def ball_event_driven(shift_ulps: int = 0, n: int = 2501) -> pd.DataFrame:
    """The exact ball at n output times plus two rows (v⁻, v⁺; gap 0) at each impact, the
    impact rows ``shift_ulps`` units in the last place off the exact impact times
    (negative: before them, as an exact code's event location may land)."""
    imp = ball_impacts()
    at = []
    for x in imp:
        y = x
        for _ in range(abs(shift_ulps)):
            y = np.nextafter(y, -np.inf if shift_ulps < 0 else np.inf)
        at.append(float(y))
    t = np.sort(np.concatenate([np.linspace(0.0, T_BALL, n), at, at]))
    x, v = ball_motion(t, imp)
    first = np.flatnonzero(np.diff(t) == 0)
    v1 = math.sqrt(2 * G * H0)
    x[first], x[first + 1] = 0.0, 0.0
    v[first] = -v1 * E_BALL ** np.arange(len(imp))
    v[first + 1] = v1 * E_BALL ** np.arange(1, len(imp) + 1)
    return pd.DataFrame({"t": t, "x": x, "v": v, "gap": x})


def pendulum(n: int = 1001) -> pd.DataFrame:
    t = np.linspace(0.0, 1.0, n)
    return pd.DataFrame({"t": t, "theta_deg": pendulum_theta_deg(t)})


def csv(path, df: pd.DataFrame, meta=()) -> str:
    with open(path, "w") as fh:
        fh.write("".join(line + "\n" for line in meta))
        df.to_csv(fh, index=False)
    return str(path)
