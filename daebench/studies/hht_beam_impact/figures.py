"""Figures of the beam-impact study: series, the difference a claim is about, cost against N."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from daebench.harness.analysis import plots
from daebench.harness.scoring import metrics
from daebench.studies.hht_beam_impact.table import PUBLISHED_TABLE1


def fig_series(hm, col, stem, prov, title, logy=False, ylabel=None) -> list[Path]:
    if not hm:
        return []
    return plots.series(hm, col, stem, prov, title=title, logy=logy, ylabel=ylabel)[1]


def fig_difference(hm: dict[str, pd.DataFrame], base: str, col: str, stem: Path, prov: dict[str, Any],
                    title: str) -> list[Path]:
    """Top: ``col`` of every run against t. Bottom: |difference| to the run whose label
    starts with ``base`` (log axis) — the difference a claim is about, not six overlapping
    curves — over the base run's whole span, each run's curve ending where its history
    ends (a run that diverged after 6 ms used to cut every curve there)."""
    key = next((k for k in hm if k.startswith(base)), None)
    if key is None or len(hm) < 2:
        return fig_series(hm, col, stem, prov, title)
    unit = plots.label_of(col)
    fig, (ax, ad) = plt.subplots(2, 1, figsize=(7.5, 6.4), sharex=True)
    g = metrics.uniform_grid(0.0, float(hm[key]["t"].iloc[-1]), 4001)
    ref = metrics.interpolate(hm[key], col, g)
    for i, (lab, h) in enumerate(hm.items()):
        ax.plot(h["t"], h[col], color=f"C{i % 10}", lw=1.0, label=lab)
        if lab != key and len(h) > 1:
            d = np.abs(metrics.interpolate(h, col, g) - ref)   # NaN past the end of a shorter run
            ad.semilogy(g, np.where(d > 0, d, np.nan), color=f"C{i % 10}", lw=0.9, label=lab)
    sym, _, u = unit.partition(" [")
    ax.set_ylabel(unit)
    ad.set_ylabel(f"|Δ{sym}| [{u}" if u else f"|Δ{sym}|")
    ad.set_title(f"difference to {key}", fontsize=8)
    ad.set_xlabel("t [s]")
    for a in (ax, ad):
        a.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6)
    ax.set_title(title, fontsize=9)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return plots.save(fig, stem, prov)


def fig_cost(t: pd.DataFrame, stem: Path, prov: dict[str, Any]) -> list[Path]:
    fig, ax = plt.subplots(figsize=(7.0, 4.6))
    for i, s in enumerate(PUBLISHED_TABLE1.columns):
        m = t[t.setting == s].sort_values("N")
        ax.plot(m["N"], m["measured_s"], "o-", color=f"C{i}", label=f"{s} (this run)")
        ax.plot(PUBLISHED_TABLE1.index, PUBLISHED_TABLE1[s], "s--", color=f"C{i}", alpha=0.45, ms=3,
                label=f"{s} (published)")
        for _, r in m[m.status != "completed"].iterrows():
            ax.annotate(r["status"], (r["N"], ax.get_ylim()[0]), color=f"C{i}", fontsize=6)
    ax.set_yscale("log")
    ax.set_xlabel("number of modes N")
    ax.set_ylabel("wall-clock time [s]")
    ax.set_title("claim 7 / Table 1: cost against N (dashed: published, 2017)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=5.5, ncol=2)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return plots.save(fig, stem, prov)
