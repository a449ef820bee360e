"""Figures (matplotlib, Agg backend; every figure saved as PNG and SVG with the
provenance footer): work-precision diagrams with the Pareto front, time histories
of θ, energy residual and constraint residuals, modal participation W_i(t)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from daebench import provenance  # noqa: E402

LABELS = {"wall_s": "wall time [s]", "cpu_s": "CPU time [s]", "steps": "steps",
          "residual_evals": "residual evaluations", "lu_factorizations": "LU factorizations",
          "newton_iterations": "Newton iterations", "theta_deg": "θ [deg]",
          "energy_residual": "energy residual [J]", "E": "total energy [J]"}


def label_of(col: str) -> str:
    """Axis label for a column name (err_theta_max → 'max error of θ [deg]')."""
    if col in LABELS:
        return LABELS[col]
    m = re.fullmatch(r"err_(.+)_(final|max|l2)", col)
    if m:
        what = {"theta": "θ [deg]", "tip": "tip position [m]"}.get(m.group(1), m.group(1))
        return f"{ {'final': 'final', 'max': 'max', 'l2': 'L2'}[m.group(2)]} error of {what}"
    return col


def save(fig: Any, stem: str | Path, prov: dict[str, Any] | None = None) -> list[Path]:
    """Add the provenance footer, write <stem>.png and <stem>.svg, close the figure."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    provenance.add_figure_footer(fig, prov or provenance.collect())
    out = []
    for ext in ("png", "svg"):
        p = stem.with_suffix(f".{ext}")
        fig.savefig(p, dpi=130)
        out.append(p)
    plt.close(fig)
    return out


def pareto_front(x: Sequence[float], y: Sequence[float]) -> np.ndarray:
    """Mask of the points no other point beats in both x and y (smaller is better);
    non-finite points are never on the front."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    mask = np.zeros(x.size, bool)
    best = np.inf
    for i in sorted(np.flatnonzero(ok), key=lambda i: (x[i], y[i])):
        if y[i] < best:
            mask[i] = True
            best = y[i]
    return mask


def work_precision(df: pd.DataFrame, x: str = "wall_s", y: str = "err_theta_max", group: str = "label",
                   stem: str | Path | None = None, prov: dict[str, Any] | None = None,
                   title: str = "") -> tuple[Any, list[Path]]:
    """Error (y) against cost (x), log–log, one line per ``group``, the Pareto front
    marked. Runs without a finite positive x and y (failed, diverged) are listed in
    the legend as not shown."""
    for c in (x, y):
        if c not in df.columns:
            raise KeyError(f"column '{c}' is not in the table; columns: {', '.join(map(str, df.columns))}")
    fig, ax = plt.subplots(figsize=(7.0, 5.0))
    xs = pd.to_numeric(df[x], errors="coerce").to_numpy(float)
    ys = pd.to_numeric(df[y], errors="coerce").to_numpy(float)
    keys = df[group].astype(str) if group in df.columns else df["integrator"].astype(str)
    for k in dict.fromkeys(keys):
        sel = (keys == k).to_numpy() & np.isfinite(xs) & np.isfinite(ys) & (xs > 0) & (ys > 0)
        n_bad = int(((keys == k).to_numpy() & ~sel).sum())
        lab = k + (f" ({n_bad} not shown)" if n_bad else "")
        if sel.any():
            order = np.argsort(xs[sel])
            ax.loglog(xs[sel][order], ys[sel][order], "o-", ms=4, label=lab)
        else:
            ax.plot([], [], "x", label=lab)
    front = pareto_front(xs, ys)
    if front.any():
        o = np.argsort(xs[front])
        ax.step(xs[front][o], ys[front][o], where="post", color="k", lw=0.8, ls="--", alpha=0.6)
        ax.scatter(xs[front], ys[front], s=90, facecolors="none", edgecolors="k", label="Pareto front", zorder=5)
    ax.set_xlabel(label_of(x))
    ax.set_ylabel(label_of(y))
    ax.set_title(title or "work–precision")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig, (save(fig, stem, prov) if stem is not None else [])


def _constraint_axes(ax: Any, hists: Mapping[str, pd.DataFrame]) -> None:
    styles = {"C": "-", "Cdot": "--", "Cddot": ":"}
    for i, (lab, h) in enumerate(hists.items()):
        for c, ls in styles.items():
            if c in h.columns and h[c].notna().any():
                ax.semilogy(h["t"], np.abs(h[c]) + 1e-300, ls, color=f"C{i}", lw=0.9,
                            label=f"{lab}: |{ {'C': 'C', 'Cdot': 'Ċ', 'Cddot': 'C̈'}[c]}|")
    ax.set_ylabel("constraint residual")
    if ax.lines:
        ax.legend(fontsize=6, ncol=2)


def history(hists: Mapping[str, pd.DataFrame], stem: str | Path | None = None,
            prov: dict[str, Any] | None = None, title: str = "") -> tuple[Any, list[Path]]:
    """θ(t), energy residual(t) and constraint residuals |C|, |Ċ|, |C̈| (while closed),
    one colour per history."""
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 8.0), sharex=True)
    for i, (lab, h) in enumerate(hists.items()):
        th = "theta_deg" if "theta_deg" in h.columns else next(
            (c for c in h.columns if c not in ("t",)), None)
        if th is not None:
            axes[0].plot(h["t"], h[th], color=f"C{i}", lw=1.0, label=lab)
        if "energy_residual" in h.columns:
            axes[1].plot(h["t"], h["energy_residual"], color=f"C{i}", lw=1.0, label=lab)
    axes[0].set_ylabel(label_of("theta_deg"))
    axes[1].set_ylabel(label_of("energy_residual"))
    _constraint_axes(axes[2], hists)
    axes[2].set_xlabel("t [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    if title:
        axes[0].set_title(title)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig, (save(fig, stem, prov) if stem is not None else [])


def modal_participation(hists: Mapping[str, pd.DataFrame], stem: str | Path | None = None,
                        prov: dict[str, Any] | None = None, modes: Sequence[int] | None = None,
                        title: str = "") -> tuple[Any, list[Path]]:
    """W_i(t) of each history, one panel per history (modes default: all present)."""
    n = max(len(hists), 1)
    fig, axes = plt.subplots(n, 1, figsize=(7.5, 2.4 * n + 0.6), sharex=True, squeeze=False)
    for ax, (lab, h) in zip(axes[:, 0], hists.items()):
        cols = [c for c in h.columns if re.fullmatch(r"W\d+", c)]
        if modes is not None:
            cols = [f"W{m}" for m in modes if f"W{m}" in h.columns]
        for c in cols:
            ax.plot(h["t"], h[c], lw=0.9, label=c)
        ax.set_ylabel("W_i")
        ax.set_title(lab, fontsize=9)
        ax.grid(True, alpha=0.3)
        if cols:
            ax.legend(fontsize=6, ncol=min(len(cols), 9))
    axes[-1, 0].set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig, (save(fig, stem, prov) if stem is not None else [])


def series(hists: Mapping[str, pd.DataFrame], column: str, stem: str | Path | None = None,
           prov: dict[str, Any] | None = None, title: str = "", logy: bool = False,
           ylabel: str | None = None) -> tuple[Any, list[Path]]:
    """One column of several histories against t."""
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for i, (lab, h) in enumerate(hists.items()):
        if column in h.columns:
            y = np.abs(h[column]) if logy else h[column]
            (ax.semilogy if logy else ax.plot)(h["t"], y, color=f"C{i % 10}", lw=1.0, label=lab)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(ylabel or label_of(column))
    ax.grid(True, alpha=0.3)
    if ax.lines:
        ax.legend(fontsize=7)
    ax.set_title(title, fontsize=9)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return fig, (save(fig, stem, prov) if stem is not None else [])


def read_history(path: str | Path) -> pd.DataFrame:
    """A history file (.csv or .parquet) as written by `daebench run`."""
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"history file '{p}' does not exist")
    return pd.read_parquet(p) if p.suffix == ".parquet" else pd.read_csv(p)
