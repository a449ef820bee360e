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
from matplotlib import ticker  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from daebench.core.observables import Observable  # noqa: E402
from daebench.core.params import ParamError  # noqa: E402
from daebench.harness.files import DamagedFile, parse_json  # noqa: E402
from daebench.harness.running import provenance  # noqa: E402
from daebench.harness.scoring import glossary, pipeline  # noqa: E402
from daebench.models.scenes import load_scene  # noqa: E402

#: units of the constraint residual columns (the driver writes them while a contact is
#: closed; C is then a gap or a joint position error)
RESIDUALS = {"C": ("|C|", "m"), "Cdot": ("|Ċ|", "m/s"), "Cddot": ("|C̈|", "m/s²")}

LABELS = {"wall_s": "wall time [s]", "cpu_s": "CPU time [s]", "steps": "steps",
          "residual_evals": "residual evaluations", "lu_factorizations": "LU factorizations",
          "newton_iterations": "Newton iterations",
          "energy_residual": "energy residual [J]", "E": "total energy [J]"}


def _declared(key: str, name: str, model: str | None = None) -> Any:
    """The one declaration (:mod:`daebench.core.observables`) whose ``key`` ('name' or
    'score_name') is ``name``: model ``model``'s, else across the registered models (None:
    none, or two that differ in unit)."""
    pool = pipeline.every_declared()
    if model is not None:
        d = pipeline.declared(model)
        pool = [*d.declared, *d.positions]
    found = {d for d in pool if getattr(d, key) == name}
    if len({d.text for d in found}) == 1:
        return found.pop()
    units = {d.unit for d in found}
    if len(units) == 1:  # models label it differently but agree on its unit: name and unit
        return Observable(name, units.pop())
    return None


def model_of(df: pd.DataFrame) -> str | None:
    """The model of a sweep table's runs (one case, or cases of one model), for labels; None
    when its rows name no case or cases of several models."""
    if "case" not in df.columns:
        return None
    models = set()
    for case in pd.unique(df["case"].dropna()):
        try:
            models.add(load_scene(str(case)).model)
        except ParamError:  # a case file moved since the sweep: the labels fall back to every model's
            return None
    return models.pop() if len(models) == 1 else None


def label_of(col: str, model: str | None = None) -> str:
    """Axis label for a column name: its display name with unit from the glossary
    (:mod:`daebench.harness.scoring.glossary`: 'θ max error over the trusted span [deg]',
    with the label and unit the model declares; without ``model``, those all models agree
    on); an observable's own column by its declaration."""
    if col in LABELS:
        return LABELS[col]
    m = glossary.describe(col, model)
    if m.words != col:
        return m.name
    d = _declared("name", col, model)
    return d.text if d is not None else col


def save(fig: Any, stem: str | Path, prov: dict[str, Any] | None = None) -> list[Path]:
    """Add the provenance footer, write <stem>.png and <stem>.svg, close the figure."""
    stem = Path(stem)
    out = provenance.write_figure(fig, stem.with_suffix(".png"), stem.with_suffix(".svg"), prov=prov or None)
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


def tidy_log_ticks(ax: Any) -> None:
    """Minor tick labels of a log axis only at 2× and 5× a power of ten (matplotlib labels
    every minor tick of a short range, and the labels collide)."""
    def minor(x: float, _pos: Any) -> str:
        m = x / 10 ** np.floor(np.log10(x) + 1e-12)
        return f"{x:g}" if round(m) in (2, 5) and abs(m - round(m)) < 1e-6 else ""

    for axis in (ax.xaxis, ax.yaxis):
        if axis.get_scale() == "log":
            axis.set_minor_formatter(ticker.FuncFormatter(minor))


def readable_log_limits(ax: Any) -> None:
    """Widen each log axis to the nearest 1-2-5 marks around its data, so that a range
    shorter than a decade (a CPU axis over 0.24–0.62 s) still carries at least two
    labelled ticks (:func:`tidy_log_ticks` labels 2× and 5× a power of ten)."""
    marks = np.array([1.0, 2.0, 5.0, 10.0])
    for axis, get, set_ in ((ax.xaxis, ax.get_xlim, ax.set_xlim), (ax.yaxis, ax.get_ylim, ax.set_ylim)):
        if axis.get_scale() != "log":
            continue
        lo, hi = get()
        if not (lo > 0 and hi > lo and np.isfinite(lo) and np.isfinite(hi)):
            continue
        dlo, dhi = 10.0 ** np.floor(np.log10(lo)), 10.0 ** np.floor(np.log10(hi))
        new_lo = dlo * marks[marks * dlo <= lo * (1 + 1e-12)].max()
        new_hi = dhi * marks[marks * dhi >= hi * (1 - 1e-12)].min()
        set_(new_lo, new_hi)


def _setting_text(df: pd.DataFrame, i: int) -> str:
    """A run's step ('1e-4') or, without one, its tolerance ('tol 1e-6'), for a point label."""
    for col, fmt in (("h", "{:.3g}"), ("tol", "tol {:.0e}"), ("rtol", "tol {:.0e}")):
        if col in df.columns:
            v = pd.to_numeric(df[col], errors="coerce").iloc[i]
            if np.isfinite(v) and v > 0:
                return fmt.format(v)
    return ""


def _log_panels(df: pd.DataFrame, x: str, y: str | Sequence[str], group: str, width: float, height: float
                ) -> tuple[Any, Any, list[str], np.ndarray, pd.Series]:
    """The shared start of the log–log sweep figures: the y columns (checked), one panel
    each, x as numbers and the group key of every row."""
    ys_cols = [y] if isinstance(y, str) else list(y)
    if not ys_cols:
        raise ParamError("no error column to plot: give y (e.g. err_<observable>_max, a column of the table)")
    for c in (x, *ys_cols):
        if c not in df.columns:
            raise KeyError(f"column '{c}' is not in the table; columns: {', '.join(map(str, df.columns))}")
    fig, axes = plt.subplots(1, len(ys_cols), figsize=(width, height), squeeze=False)
    xs = pd.to_numeric(df[x], errors="coerce").to_numpy(float)
    keys = df[group].astype(str) if group in df.columns else df["integrator"].astype(str)
    return fig, axes, ys_cols, xs, keys


def convergence(df: pd.DataFrame, x: str = "h", y: str | Sequence[str] = (), group: str = "label",
                stem: str | Path | None = None, prov: dict[str, Any] | None = None,
                title: str = "") -> tuple[Any, list[Path]]:
    """Error against step size (or tolerance), log–log, one panel per ``y`` column, one
    line per ``group`` with its measured order (least-squares slope of log e over log x)
    in the legend, and a slope-2 guide."""
    n = 1 if isinstance(y, str) else len(y)
    model = model_of(df)
    fig, axes, ys_cols, xs, keys = _log_panels(df, x, y, group, 4.6 * n, 4.3)
    for j, (ax, yc) in enumerate(zip(axes[0], ys_cols)):
        ys = pd.to_numeric(df[yc], errors="coerce").to_numpy(float)
        for i, k in enumerate(dict.fromkeys(keys)):
            sel = (keys == k).to_numpy() & np.isfinite(xs) & np.isfinite(ys) & (xs > 0) & (ys > 0)
            if sel.sum() < 2:
                continue
            o = np.argsort(xs[sel])
            xv, yv = xs[sel][o], ys[sel][o]
            p = float(np.polyfit(np.log(xv), np.log(yv), 1)[0])
            ax.loglog(xv, yv, "o-", ms=4, color=f"C{i % 10}", label=f"{k}: order {p:.2f}")
            if i == 0:
                ax.loglog(xv, 0.4 * yv[-1] * (xv / xv[-1]) ** 2, "k:", lw=0.8, label="slope 2")
        ax.set_xlabel({"h": "step h [s]", "tol": "tolerance"}.get(x, label_of(x)))
        ax.set_ylabel(label_of(yc, model))
        ax.grid(True, which="both", alpha=0.3)
        tidy_log_ticks(ax)
        ax.legend(fontsize=7)
    fig.suptitle(title or "convergence")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig, (save(fig, stem, prov) if stem is not None else [])


def _steps_note(df: pd.DataFrame, rows: np.ndarray) -> str:
    """' (h a…b s)': the step sizes of a line's runs, for its legend entry ('' without steps)."""
    if "h" not in df.columns:
        return ""
    h = pd.to_numeric(df["h"], errors="coerce").to_numpy(float)[rows]
    h = np.unique(h[np.isfinite(h) & (h > 0)])
    if not h.size:
        return ""
    return f" (h {h[-1]:.3g} s)" if h.size == 1 else f" (h {h[-1]:.3g}…{h[0]:.3g} s)"


def work_precision(df: pd.DataFrame, x: str = "cpu_s", y: str | Sequence[str] = (),
                   group: str = "label", stem: str | Path | None = None, prov: dict[str, Any] | None = None,
                   title: str = "") -> tuple[Any, list[Path]]:
    """Error (y) against cost (x), log–log, one line per ``group``, the Pareto front
    marked. Several ``y`` columns give one panel each, side by side, with one legend.
    Runs without a finite positive x and y (failed, diverged) are listed in the legend
    as not shown."""
    n = 1 if isinstance(y, str) else len(y)
    model = model_of(df)
    fig, axes, ys_cols, xs, keys = _log_panels(df, x, y, group, 7.0 if n == 1 else 4.6 * n, 5.0)
    for ax, yc in zip(axes[0], ys_cols):
        ys = pd.to_numeric(df[yc], errors="coerce").to_numpy(float)
        for i, k in enumerate(dict.fromkeys(keys)):
            sel = (keys == k).to_numpy() & np.isfinite(xs) & np.isfinite(ys) & (xs > 0) & (ys > 0)
            n_bad = int(((keys == k).to_numpy() & ~sel).sum())
            lab = k + _steps_note(df, (keys == k).to_numpy()) + (f" ({n_bad} not shown)" if n_bad else "")
            if sel.any():
                order = np.argsort(xs[sel])
                ax.loglog(xs[sel][order], ys[sel][order], "o-", ms=4, color=f"C{i % 10}", label=lab)
                for j in np.flatnonzero(sel):     # each point named by its step or tolerance
                    ax.annotate(_setting_text(df, int(j)), (xs[j], ys[j]), xytext=(3, 3),
                                textcoords="offset points", fontsize=5.5, color=f"C{i % 10}")
            else:
                ax.plot([], [], "x", color=f"C{i % 10}", label=lab)
        front = pareto_front(xs, ys)
        if front.any():
            o = np.argsort(xs[front])
            ax.step(xs[front][o], ys[front][o], where="post", color="k", lw=0.8, ls="--", alpha=0.6)
            ax.scatter(xs[front], ys[front], s=90, facecolors="none", edgecolors="k", label="Pareto front", zorder=5)
        ax.set_xlabel(label_of(x))
        ax.set_ylabel(label_of(yc, model))
        ax.grid(True, which="both", alpha=0.3)
        readable_log_limits(ax)
        tidy_log_ticks(ax)
    if n == 1:
        axes[0][0].legend(fontsize=7)
        axes[0][0].set_title(title or "work–precision")
        fig.tight_layout(rect=(0, 0.03, 1, 1))
    else:
        # one legend below the panels, where it hides no point of any of them
        handles, labels = axes[0][0].get_legend_handles_labels()
        rows = -(-len(labels) // 4)
        fig.legend(handles, labels, loc="lower center", ncol=min(4, max(1, len(labels))), fontsize=7,
                   bbox_to_anchor=(0.5, 0.3 / fig.get_figheight()))    # above the provenance footer
        fig.suptitle(title or "work–precision")
        fig.tight_layout(rect=(0, (0.45 + 0.17 * rows) / fig.get_figheight(), 1, 1))
    return fig, (save(fig, stem, prov) if stem is not None else [])


def small_multiples(cases: Mapping[str, tuple[pd.DataFrame, str]], x: str = "cpu_s", group: str = "label",
                    stem: str | Path | None = None, prov: dict[str, Any] | None = None,
                    title: str = "work–precision per case", ncol: int = 4) -> tuple[Any, list[Path]]:
    """One small log–log work–precision panel per case ({case: (its runs, the error column
    to plot)}), one colour per setting across all panels and one legend: the survey's
    cases side by side."""
    if not cases:
        raise ParamError("no case to plot")
    names = list(dict.fromkeys(str(k) for df, _ in cases.values() if group in df for k in df[group]))
    color = {k: f"C{i % 10}" for i, k in enumerate(names)}
    style = {k: ("-", "--", ":", "-.")[(i // 10) % 4] for i, k in enumerate(names)}
    ncol = min(ncol, len(cases))
    nrow = -(-len(cases) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.3 * ncol, 2.7 * nrow + 0.9), squeeze=False)
    handles: dict[str, Any] = {}
    for ax, (case, (df, y)) in zip(axes.flat, cases.items()):
        xs = pd.to_numeric(df[x], errors="coerce").to_numpy(float) if x in df else np.full(len(df), np.nan)
        ys = pd.to_numeric(df[y], errors="coerce").to_numpy(float) if y in df else np.full(len(df), np.nan)
        keys = df[group].astype(str).to_numpy()
        for k in dict.fromkeys(keys):
            sel = (keys == k) & np.isfinite(xs) & np.isfinite(ys) & (xs > 0) & (ys > 0)
            if sel.any():
                o = np.argsort(xs[sel])
                (ln,) = ax.loglog(xs[sel][o], ys[sel][o], "o", ls=style[k], ms=3, lw=1.1, color=color[k])
                handles.setdefault(k, ln)
        ax.set_title(case, fontsize=9)
        ax.set_xlabel(f"{LABELS.get(x, x)}, log", fontsize=7)
        ax.set_ylabel(label_of(y, model_of(df)).replace(" over the trusted span", ", trusted span")
                      + ", log", fontsize=7, wrap=True)
        ax.tick_params(labelsize=6, which="both")
        ax.grid(True, which="both", alpha=0.3)
        tidy_log_ticks(ax)
    for ax in list(axes.flat)[len(cases):]:
        ax.axis("off")
    labels = [k for k in names if k in handles]
    rows = -(-len(labels) // 6)
    fig.legend([handles[k] for k in labels], labels, loc="lower center", ncol=min(6, max(1, len(labels))),
               fontsize=7, title="integrator (settings)", title_fontsize=7,
               bbox_to_anchor=(0.5, 0.35 / fig.get_figheight()))    # above the provenance footer
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, (0.75 + 0.16 * rows) / fig.get_figheight(), 1, 0.97))
    return fig, (save(fig, stem, prov) if stem is not None else [])


def history(hists: Mapping[str, pd.DataFrame], stem: str | Path | None = None,
            prov: dict[str, Any] | None = None, title: str = "") -> tuple[Any, list[Path]]:
    """The headline observable(t) (the first a model declares to be scored around impacts),
    the energy-balance residual(t) and each constraint residual |C|, |Ċ|, |C̈| (while a
    contact is closed) on its own axis with its unit; one colour per history, labelled in
    the legend of the first panel."""
    heads = [d.name for d in pipeline.every_declared() if isinstance(d, Observable)
             and d.impact_windows and any(d.name in h.columns for h in hists.values())]
    panels = [(c, label_of(c), False) for c in heads[:1]] + [("energy_residual", label_of("energy_residual"), False)]
    panels += [(c, f"{sym} [{unit}]", True) for c, (sym, unit) in RESIDUALS.items()
               if any(c in h.columns and h[c].notna().any() for h in hists.values())]
    fig, axes = plt.subplots(len(panels), 1, figsize=(7.5, 2.3 * len(panels) + 0.8), sharex=True, squeeze=False)
    axes = axes[:, 0]
    for ax, (col, ylabel, logy) in zip(axes, panels):
        for i, (lab, h) in enumerate(hists.items()):
            if col not in h.columns:
                continue
            y = np.abs(h[col].to_numpy(float)) if logy else h[col].to_numpy(float)
            if logy:
                y = np.where(y > 0, y, np.nan)  # a log axis has no zero; gaps while no contact is closed
                ax.semilogy(h["t"], y, color=f"C{i % 10}", lw=0.9, label=lab)
            else:
                ax.plot(h["t"], y, color=f"C{i % 10}", lw=1.0, label=lab)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("t [s]")
    if axes[0].lines:
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


#: scene keys a figure's title names by their symbol (what a comparison's answer depends on)
TITLE_KEYS = (("discretization.n", "N"), ("contact.restitution", "e"))


def title_values(scene: Any) -> list[str]:
    """The scene's values of TITLE_KEYS by symbol, e.g. ``["N = 5", "e = 0"]`` (keys it lacks left out)."""
    values = [(sym, scene.get(key)) for key, sym in TITLE_KEYS]
    return [f"{sym} = {x:g}" for sym, x in values if isinstance(x, (int, float)) and not isinstance(x, bool)]


def sweep_title(df: pd.DataFrame, what: str = "work–precision") -> str:
    """Title of a sweep figure: what it shows, the case, the scene overrides shared by
    every run, how many runs."""
    case = str(df["case"].iloc[0]) if "case" in df.columns and len(df) else "sweep"
    shared: dict[str, Any] = {}
    for col in ("scene_set", "overrides"):     # --set of the sweep, then a grid's per-run overrides
        if col in df.columns and df[col].nunique() == 1 and str(df[col].iloc[0]) not in ("{}", "nan", "None"):
            try:
                cell = parse_json(str(df[col].iloc[0]), f"the table's {col} cell")
            except DamagedFile:
                cell = None
            if isinstance(cell, dict):  # a damaged cell only leaves the title without it
                shared.update(cell)
    keys = dict(TITLE_KEYS)
    try:    # the values the answer depends on, set or by default (N = 5 of beam-impact)
        parts = title_values(load_scene(case, shared))
        rest = {k: v for k, v in shared.items() if k not in keys}
    except ParamError:  # a case file moved since the sweep: the title names what the table holds
        parts, rest = [], shared
    parts += [f"{keys[k]} = {v}" if k in keys else f"{k}={v}" for k, v in rest.items()]
    return f"{what}, {case}{' ' + ', '.join(parts) if parts else ''} ({len(df)} runs)"
