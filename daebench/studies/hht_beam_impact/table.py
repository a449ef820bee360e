"""The source paper's protocol constants and its Table 1 (published wall times), and the
measured Table 1 built from sweep rows — what :mod:`.paper`, :mod:`.paper_claims` and
:mod:`.paper_figures` share (kept apart so that none of them imports another's caller)."""

from __future__ import annotations

import math

import pandas as pd

SCENE = "beam-impact"
BASE_OBSERVABLES = ["theta_deg", "omega", "tip_x", "tip_y", "tip_w2", "gap"]


def observables(N: int) -> list[str]:
    """Scored observables of a run with N modes: the motion and each modal participation W1…WN."""
    return BASE_OBSERVABLES + [f"W{i}" for i in range(1, N + 1)]
HHT_ALPHAS = (0.0, -0.15, -1.0 / 3.0)
BAUMGARTE = ((0.0, 0.0), (10.0, 50.0), (1000.0, 5000.0))
QUICK_RUN_CAP = 60.0   # s: a --quick run slower than this is reported as failed (keeps CI bounded)

#: Table 1 of the published study (wall-clock seconds, 2017, MATLAB-era code) — "published" data.
PUBLISHED_TABLE1 = pd.DataFrame(
    {"N": [3, 5, 7, 9],
     "HHT α=0": [305, 799, 2914, 9818],
     "HHT α=-0.15": [244, 589, 2573, 8725],
     "HHT α=-1/3": [166, 401, 2092, 7233],
     "Baumgarte (0,0)": [67, 339, 1285, 2341],
     "Baumgarte (10,50)": [64, 325, 1217, 2231],
     "Baumgarte (1000,5000)": [63, 319, 1198, 2192]}).set_index("N")


# ==== Table 1 ===================================================================
def _cell(r: pd.Series) -> str:
    if r["status"] == "completed":
        return f"{r['wall_s']:.1f}"
    t = r.get("verdict_t")
    return f"{r['status']}" + (f" (t={t:.3g} s)" if isinstance(t, float) and math.isfinite(t) else "")


def table1(df: pd.DataFrame) -> pd.DataFrame:
    """Tidy table: N, setting, measured seconds (or the verdict), published seconds."""
    rows = []
    for _, r in df[df["set"] == "table"].iterrows():
        N, s = int(r["N"]), r["setting"]
        pub = PUBLISHED_TABLE1.loc[N, s] if (N in PUBLISHED_TABLE1.index and s in PUBLISHED_TABLE1) else math.nan
        rows.append({"N": N, "setting": s, "status": r["status"],
                     "measured_s": r["wall_s"] if r["status"] == "completed" else math.nan,
                     "measured": _cell(r), "published_s": pub, "steps": r.get("steps", math.nan)})
    return pd.DataFrame(rows)
