"""Figures from sweep tables and run histories (`daebench plot`)."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

from daebench.core.params import ParamError
from daebench.harness.analysis import plots
from daebench.harness.files import DamagedFile, OutputError, ensure_writable_dir, read_json, results_dir
from daebench.harness.running import provenance
from daebench.harness.running.history_io import history_label, read_history
from daebench.harness.sweeps.store import read_table


def _writable_stem(stem: Path) -> None:
    """Refuse, before any figure is drawn, a stem whose folder cannot be written or whose
    files would be folders or other non-files."""
    if not stem.name or stem.name in (".", ".."):
        raise OutputError(f"--out {stem} names no file; give a stem such as results/figures/my-figure")
    ensure_writable_dir(stem.parent, "the figure's folder (--out)", longest_name=f"{stem.name}.png")
    for ext in ("png", "svg"):
        f = stem.with_suffix(f".{ext}")
        if f.exists() and not f.is_file():
            raise OutputError(f"{f} exists and is not a regular file; give another --out")


def _ys(y: str | Sequence[str]) -> list[str]:
    return [c.strip() for c in y.split(",") if c.strip()] if isinstance(y, str) else list(y)


def plot_work_precision(table: str | Path, x: str = "cpu_s", y: str | Sequence[str] = "err_theta_max_trusted",
                        group: str = "label", out: str | Path | None = None) -> list[Path]:
    """Work–precision diagram (log–log, Pareto front marked) of a sweep table, one panel per
    ``y`` column, as PNG and SVG (default: next to the table); the files.

    Raises
    ------
    ParamError
        A table that cannot be read, is not a sweep table, lacks a column, or a figure
        that cannot be written.
    """
    p = Path(table)
    df = read_table(p)
    if "label" not in df.columns or "status" not in df.columns:
        raise ParamError(f"'{p}' is not a sweep table (no 'label'/'status' columns); `daebench plot history` plots "
                         f"run histories")
    prov = _table_provenance(p)
    ys = _ys(y)
    stem = Path(out) if out else p.with_name(f"{p.stem}-wp-{'+'.join(ys)}-vs-{x}")
    _writable_stem(stem)
    try:
        return plots.work_precision(df, x, ys, group, stem, prov, title=plots.sweep_title(df))[1]
    except KeyError as exc:
        raise ParamError(str(exc.args[0])) from None
    except OSError as exc:
        raise ParamError(f"cannot write the figure at {stem}: {exc.strerror or exc}") from None


def _table_provenance(p: Path) -> dict:
    """The provenance of the runs behind a sweep table (its sidecar's; this tree's when the
    sidecar is missing or damaged): a figure drawn later is stamped with the runs' commit."""
    try:
        prov = read_json(p.with_suffix(".json"), "the table's sidecar")["provenance"]
    except (DamagedFile, KeyError, TypeError, IndexError):
        prov = None
    return prov if isinstance(prov, dict) else provenance.collect()


def plot_convergence(table: str | Path, x: str = "h", y: str | Sequence[str] = "err_pre_theta_max,err_impact1_t",
                     group: str = "label", out: str | Path | None = None) -> list[Path]:
    """Convergence: error against h (log–log) of a sweep table, one panel per ``y`` column,
    the measured order of each line in its legend; the files."""
    p = Path(table)
    df = read_table(p)
    ys = _ys(y)
    stem = Path(out) if out else p.with_name(f"{p.stem}-order-{'+'.join(ys)}")
    _writable_stem(stem)
    try:
        return plots.convergence(df, x, ys, group, stem, _table_provenance(p),
                                 title=plots.sweep_title(df, "convergence"))[1]
    except KeyError as exc:
        raise ParamError(str(exc.args[0])) from None


def plot_histories(files: Sequence[str | Path], out: str | Path | None = None,
                   modal: bool = True) -> list[Path]:
    """θ, energy residual and constraint residuals against t from history files written by
    `daebench run`, one line per run (and the modal participation W_i(t) when present);
    written to the stem ``out`` (default results/figures/history)."""
    out = Path(out) if out else results_dir() / "figures" / "history"
    _writable_stem(out)
    hists = {}
    for f in files:
        h = read_history(f)
        hists[history_label(f, set(hists))] = h
    prov = provenance.collect()
    try:
        written = plots.history(hists, out, prov)[1]
        if modal and any(c.startswith("W") and c[1:].isdigit() for h in hists.values() for c in h.columns):
            written += plots.modal_participation(hists, f"{out}-modal", prov)[1]
    except OSError as exc:
        raise ParamError(f"cannot write the figure at {out}: {exc.strerror or exc}") from None
    return written
