"""Performance profiles (Dolan & Moré, Math. Program. 91, 2002) over a case library.

For one measure, one target error and one cost (wall time by default), take from a
reach table (:func:`daebench.harness.analysis.costs.reach_table`) the cost ``c[p, s]`` at which
setting ``s`` reaches the target on case ``p``. The performance ratio is

    r[p, s] = c[p, s] / min_s' c[p, s']        (∞ when s does not reach it on p),

and the profile ρ_s(τ) = |{p : r[p, s] ≤ τ}| / n_p is the fraction of the cases on which
``s`` reaches the target within τ times the cost of the best setting on that case.
ρ_s(1) is the fraction of cases where ``s`` is the cheapest; ρ_s(∞) the fraction where it
reaches the target at all.

**Which cases count** (n_p): every case on which the measure exists (at least one of its
settings has a scored run on it), including cases no setting reaches the target on (as
in Dolan & Moré: they lower every ρ alike; their number is reported as ``unsolved``). A
setting absent from a case (not applicable there) counts as not reaching it. A cost that
is an upper bound (``reach_kind = 'bound'``: the cheapest run already reached the
target) is used as it is.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from daebench.core.params import ParamError  # noqa: E402
from daebench.harness.running import provenance  # noqa: E402
from daebench.harness.scoring import glossary  # noqa: E402

#: the τ of the profile table: cheapest, within 4×, at all
TABLE_TAUS = (1.0, 4.0, math.inf)


def ratio_matrix(reach: pd.DataFrame, measure: str, target: float, cost: str = "wall_s",
                 setting: str = "label") -> pd.DataFrame:
    """r[p, s] for one measure and target: cases as rows, settings as columns (∞ where a
    setting does not reach the target; a case on which no setting does has ∞ throughout).

    Raises
    ------
    ParamError
        For a reach table without the columns, or a measure/target it does not hold.
    """
    col = f"reach_{cost}"
    need = ["case", setting, "measure", "target", col, "reach_kind"]
    miss = [c for c in need if c not in reach.columns]
    if miss:
        raise ParamError(f"not a reach table (no column {', '.join(miss)}); make one with "
                         f"daebench.harness.analysis.costs.reach_table")
    sel = reach[(reach["measure"] == measure) & np.isclose(reach["target"].astype(float), float(target),
                                                            rtol=1e-12, atol=0.0)]
    if not len(sel):
        raise ParamError(f"the reach table has no rows for {measure} ≤ {target:g}")
    cases = [c for c, g in sel.groupby("case", sort=False) if (g["reach_kind"] != "no points").any()]
    settings = list(dict.fromkeys(sel[setting]))
    m = pd.DataFrame(math.inf, index=pd.Index(cases, name="case"), columns=settings)
    for _, r in sel[sel["case"].isin(cases)].iterrows():
        v = float(r[col])
        if math.isfinite(v) and v > 0:
            m.loc[r["case"], r[setting]] = v
    best = m.min(axis=1)
    out = m.div(best.where(np.isfinite(best), np.nan), axis=0)
    return out.fillna(math.inf)


def rho(ratios: pd.DataFrame, taus: Sequence[float]) -> pd.DataFrame:
    """ρ_s(τ) for each τ (rows) and setting (columns): the fraction of the cases (rows of
    ``ratios``) with r ≤ τ. τ = ∞ counts the cases a setting reaches at all."""
    n = len(ratios)
    rows = {}
    for t in taus:
        if n == 0:
            rows[t] = {s: math.nan for s in ratios.columns}
            continue
        hit = np.isfinite(ratios.to_numpy(float)) if math.isinf(t) else ratios.to_numpy(float) <= t * (1 + 1e-12)
        rows[t] = dict(zip(ratios.columns, hit.sum(axis=0) / n))
    return pd.DataFrame.from_dict(rows, orient="index")


def profile_table(reach: pd.DataFrame, cost: str = "wall_s", taus: Sequence[float] = TABLE_TAUS,
                  setting: str = "label") -> pd.DataFrame:
    """ρ_s(1), ρ_s(4), ρ_s(∞) per (measure, target, setting), with the number of cases and
    of cases no setting reaches (``unsolved``); rows sorted by ρ(1) then ρ(∞) within a
    (measure, target)."""
    rows = []
    for (m, t), _ in reach.groupby(["measure", "target"], sort=False):
        r = ratio_matrix(reach, m, t, cost, setting)
        if not len(r):
            continue
        p = rho(r, taus)
        unsolved = int((~np.isfinite(r.to_numpy(float))).all(axis=1).sum())
        part = []
        for s in r.columns:
            row = {"measure": m, "target": float(t), "setting": s, "cases": len(r), "unsolved": unsolved}
            for tau in taus:
                row[_rho_name(tau)] = float(p.loc[tau, s])
            part.append(row)
        part.sort(key=lambda x: (-x[_rho_name(taus[0])], -x[_rho_name(taus[-1])], x["setting"]))
        rows += part
    cols = ["measure", "target", "setting", "cases", "unsolved"] + [_rho_name(t) for t in taus]
    return pd.DataFrame(rows, columns=cols)


def _rho_name(tau: float) -> str:
    return "rho_inf" if math.isinf(tau) else f"rho_{tau:g}"


def curve(ratios: pd.DataFrame, setting: str) -> tuple[np.ndarray, np.ndarray]:
    """The step function of one setting: τ at each jump (from 1) and ρ after it."""
    r = np.sort(ratios[setting].to_numpy(float))
    n = len(r)
    fin = r[np.isfinite(r)]
    tau = np.concatenate([[1.0], fin])
    y = np.concatenate([[np.sum(fin <= 1.0 * (1 + 1e-12)) / n], np.arange(1, fin.size + 1) / n])
    return tau, y


def figure(reach: pd.DataFrame, path: str | Path, cost: str = "wall_s", prov: dict[str, Any] | None = None,
           setting: str = "label", cost_label: str | None = None) -> list[Path]:
    """One panel per (measure, target): ρ_s(τ) as a step plot on a log τ axis, one line per
    setting; written as ``<path>.png`` and ``.svg``. Returns the files."""
    cost_label = cost_label or glossary.describe(cost).words
    keys = list(reach.groupby(["measure", "target"], sort=False).groups)
    if not keys:
        raise ParamError("the reach table is empty: nothing to profile")
    ncol = min(3, len(keys))
    nrow = math.ceil(len(keys) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 3.6 * nrow + 0.6), squeeze=False)
    names = list(dict.fromkeys(reach[setting].astype(str)))       # one colour and line style per setting
    style = {s: dict(color=f"C{i % 10}", ls=("-", "--", ":", "-.")[(i // 10) % 4]) for i, s in enumerate(names)}
    handles = {}
    for ax, (m, t) in zip(axes.flat, keys):
        r = ratio_matrix(reach, m, t, cost, setting)
        fin = r.to_numpy(float)
        top = max(4.0, float(np.nanmax(np.where(np.isfinite(fin), fin, np.nan))) * 1.5) if np.isfinite(fin).any() else 4.0
        for s in r.columns:
            x, y = curve(r, s)
            (ln,) = ax.step(np.append(x, top), np.append(y, y[-1]), where="post", lw=1.4, label=str(s),
                            **style[str(s)])
            handles.setdefault(str(s), ln)
        ax.set_xscale("log")
        ax.set_xlim(1.0, top)
        ax.set_xticks([2.0 ** k for k in range(0, int(math.log2(top)) + 1)])
        ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(f"{glossary.target_text(m, float(t))}  ({len(r)} cases)", fontsize=9, wrap=True)
        ax.set_xlabel(f"τ: {cost_label} within τ × the best setting's on the case")
        ax.set_ylabel("ρ(τ): fraction of cases")
        ax.grid(True, which="both", alpha=0.3)
    for ax in list(axes.flat)[len(keys):]:
        ax.axis("off")
    labels = [s for s in names if s in handles]
    fig.legend([handles[s] for s in labels], labels, loc="lower center", ncol=min(6, max(1, len(labels))), fontsize=7,
               title="integrator (settings)", title_fontsize=7, bbox_to_anchor=(0.5, 0.0))
    fig.suptitle(f"Performance profiles (Dolan & Moré): cost = {cost_label}", fontsize=10)
    fig.tight_layout(rect=(0, 0.06 + 0.03 * math.ceil(len(labels) / 6), 1, 0.97))
    p = Path(path)
    files = provenance.write_figure(fig, p.with_suffix(".png"), p.with_suffix(".svg"), prov=prov, dpi=110)
    plt.close(fig)
    return files


def conclusions(prof: pd.DataFrame) -> list[str]:
    """The library-wide answer of a profile table (:func:`profile_table`), one sentence per
    accuracy band (measure and target): the setting cheapest on most cases, the one that
    qualifies on most, and the cases no setting qualifies on."""
    out = []
    for (m, t), g in prof.groupby(["measure", "target"], sort=False):
        n = int(g["cases"].iloc[0])
        head = f"{glossary.target_text(m, float(t))} ({n} case{'s' if n != 1 else ''})"
        g1 = g.sort_values(["rho_1", "rho_4", "setting"], ascending=[False, False, True], kind="stable")
        best = g1.iloc[0]
        if not float(best["rho_inf"]) > 0:
            out.append(f"{head}: no setting qualifies on any case.")
            continue
        gi = g.sort_values(["rho_inf", "rho_1", "setting"], ascending=[False, False, True], kind="stable").iloc[0]
        s = (f"{head}: {best['setting']} is the cheapest on {round(best['rho_1'] * n)} and within 4× on "
             f"{round(best['rho_4'] * n)}")
        if gi["setting"] != best["setting"]:
            s += f"; {gi['setting']} qualifies on the most cases ({round(gi['rho_inf'] * n)})"
        else:
            s += f", and qualifies on {round(best['rho_inf'] * n)}"
        un = int(g["unsolved"].iloc[0]) if "unsolved" in g else 0
        out.append(s + (f"; no setting qualifies on {un}." if un else "."))
    return out
