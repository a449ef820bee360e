"""The stability map's outputs: a markdown table, parquet/csv, and the figure h_max vs N."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from daebench.harness.files import atomic_write, under_root, write_error
from daebench.harness.running import provenance


def _h(x: float) -> str:
    return "∞" if x == math.inf else ("—" if not math.isfinite(x) else f"{x:.3g}")


def _omega(x: float) -> str:
    return "∞" if x == math.inf else ("n/a" if not math.isfinite(x) else f"{x:.3f}")


def markdown(df: pd.DataFrame, h_max: float) -> str:
    """One row per (setting, N): the measured bracket beside the prediction."""
    lines = ["| integrator, settings | N | ω_max [rad/s] | trial [s] | method | strict interval hω "
             "| run interval hω* | predicted h_max [s] | measured h_max [s]: stable – unstable | first unstable run "
             "| agrees | predicted h_max for the whole run [s] | measured for the whole run [s] | agrees |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in df.itertuples():
        meas = _bracket(r.h_stable, r.h_unstable)
        run = (f"{_bracket(r.h_stable_run, r.h_unstable_run)} ({_why(r.unstable_status_run, r.unstable_message_run)}) "
               f"| {_agrees(r.agrees_run)}" if hasattr(r, "h_stable_run") else "— | —")
        lines.append(f"| {r.label} | {'' if r.N is None or (isinstance(r.N, float) and math.isnan(r.N)) else int(r.N)} "
                     f"| {r.omega_max:.5g} | {r.t_trial:.3g} | {r.method} | {_omega(r.interval_strict)} "
                     f"| {_omega(r.interval)} "
                     f"| {_h(r.h_pred)} | {meas} | {r.unstable_status or '—'} | {'yes' if r.agrees else 'NO'} "
                     f"| {_h(getattr(r, 'h_pred_run', math.nan))} ({getattr(r, 't_run', math.nan):g} s) | {run} |")
    return "\n".join(lines)


def _why(status: str, message: str) -> str:
    """The status of the first unstable run, with the start of its reason where it did not
    simply diverge."""
    if not status:
        return "—"
    if status == "diverged" or not message:
        return status
    reason = message.split(" — ")[0].split(" (t = ")[0]
    return f"{status}: {reason[:90]}"


def _agrees(ok: bool | None) -> str:
    return "n/a (failed, not diverged)" if ok is None or (isinstance(ok, float) and math.isnan(ok)) else \
        ("yes" if ok else "NO")


def _bracket(lo: float, hi: float) -> str:
    """A bisection's result in words: the bracket, or which bound was not crossed."""
    if math.isfinite(lo) and math.isfinite(hi):
        return f"{lo:.4g} – {hi:.4g}"
    if math.isfinite(lo):
        return f"≥ {lo:.3g} (no instability up to the upper bound)"
    return f"< {hi:.3g} (unstable at the lower bound)"


def figure(df: pd.DataFrame, path: Path, title: str, h_max: float, mark_h: float | None = None,
           fmt: str | None = None, prov: dict[str, Any] | None = None) -> Path:
    """h_max against N, one colour and marker per integrator setting, every marker at its
    own N: measured on the trial (filled; hollow = no instability up to the bisection bound)
    and over the scene's whole run (×, where its bracket ends in a divergence), predicted for the trial (dashed) and
    for the whole run (dotted), log axis."""
    import matplotlib  # lazy: matplotlib (heavy) only when the figure is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # lazy: as above
    from matplotlib.lines import Line2D  # lazy: as above

    fig, ax = plt.subplots(figsize=(10.0, 5.0))
    labels = list(dict.fromkeys(df["label"]))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    markers = "osD^v<>pP*Xh"
    handles = []
    for i, lab in enumerate(labels):
        d = df[df["label"] == lab]
        n = d["N"].to_numpy(float)               # at its own N: settings differ by colour and marker
        c, mk = colours[i % len(colours)], markers[i % len(markers)]
        lo, hi = d["h_stable"].to_numpy(float), d["h_unstable"].to_numpy(float)
        both = np.isfinite(lo) & np.isfinite(hi)
        if both.any():
            ax.errorbar(n[both], lo[both], yerr=[np.zeros(both.sum()), (hi - lo)[both]], fmt=mk, color=c, ms=5,
                        capsize=2)
        up = np.isfinite(lo) & ~np.isfinite(hi)
        if up.any():
            ax.plot(n[up], lo[up], mk, color=c, ms=7, mfc="none")
        if "h_stable_run" in d:    # measured over the whole run where it diverged: crosses at its own N
            lo_r, hi_r = d["h_stable_run"].to_numpy(float), d["h_unstable_run"].to_numpy(float)
            ok = np.isfinite(lo_r) & np.isfinite(hi_r) & (d["unstable_status_run"] == "diverged").to_numpy()
            ax.plot(n[ok], lo_r[ok], "x", color=c, ms=7, mew=1.5)
        for col, ls in (("h_pred", "--"), ("h_pred_run", ":")):
            pred = d[col].to_numpy(float) if col in d else np.full(len(d), np.nan)
            fin = np.isfinite(pred)
            if fin.any():
                ax.plot(n[fin], pred[fin], ls, color=c, lw=1.2)
        handles.append(Line2D([], [], color=c, marker=mk, ls="", label=lab))
    handles += [Line2D([], [], color="k", marker="o", ls="", label="measured on the trial (bar: last bracket)"),
                Line2D([], [], color="k", marker="o", mfc="none", ls="", label="no instability up to the upper bound"),
                Line2D([], [], color="k", ls="--", label="predicted for the trial (∞: not drawn)"),
                Line2D([], [], color="k", ls=":", label="predicted for the whole run"),
                Line2D([], [], color="k", marker="x", ls="", mew=1.5, label="measured over the whole run (diverged)")]
    if mark_h:
        ax.axhline(mark_h, color="0.3", ls=":", lw=1.0)
        handles.append(Line2D([], [], color="0.3", ls=":", label=f"h = {mark_h:g} s"))
    ax.set_yscale("log")
    ax.set_xlabel("modes per direction N [–]")
    ax.set_ylabel("largest stable step h_max [s]")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(handles=handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax.set_xticks(sorted(set(df["N"].dropna().astype(int))))
    fig.tight_layout(rect=(0, 0.03, 1, 1))   # room for the provenance footer
    provenance.write_figure(fig, path, prov=prov, dpi=150, fmt=fmt)
    plt.close(fig)
    return path


def paths(out_dir: Path, stem: str) -> list[Path]:
    """The four files of the map ``stem`` in ``out_dir``: .parquet, .csv, .md, .png."""
    return [under_root(out_dir, f"{stem}{suffix}") for suffix in (".parquet", ".csv", ".md", ".png")]


def write(df: pd.DataFrame, out_dir: Path, stem: str, title: str, h_max: float,
          mark_h: float | None = None, scenes: tuple[tuple[str, str], ...] = ()) -> list[Path]:
    """<stem>.parquet, .csv, .md and .png in ``out_dir`` (each path checked to stay in it,
    each file written atomically; a failure says what was kept)."""
    flat = df.assign(settings=df["settings"].astype(str))
    files = paths(out_dir, stem)
    kept = "the table was printed above"
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(exc, "the stability folder", out_dir, kept) from None
    atomic_write(files[0], lambda p: flat.to_parquet(p, index=False), "the stability table", kept)
    atomic_write(files[1], lambda p: flat.to_csv(p, index=False, float_format="%.6g"), "the stability table", kept)
    prov = provenance.collect(scenes)
    footer = provenance.markdown_footer(prov)
    atomic_write(files[2], lambda p: p.write_text(f"# {title}\n\n{markdown(df, h_max)}\n{footer}"),
                 "the stability table", kept)
    atomic_write(files[3], lambda p: figure(df, p, title, h_max, mark_h, fmt="png", prov=prov), "the stability figure",
                 kept)
    return files
