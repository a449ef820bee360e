"""`daebench plot …`: figures from sweep tables and run histories."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from daebench.core.params import ParamError
from daebench.harness.running.history_io import history_label, read_history

plot_app = typer.Typer(no_args_is_help=True, help="Figures from sweep tables and run histories.")


def _fail(msg: str) -> None:
    from daebench.cli.common import fail

    fail(msg)


@plot_app.command("wp")
def plot_wp(table: str = typer.Argument(..., help="a sweep table (.parquet or .csv)"),
            x: str = typer.Option("wall_s", "--x", help="cost column (wall_s, cpu_s, steps, ...)"),
            y: str = typer.Option("err_theta_max_trusted", "--y",
                                  help="error column(s), comma-separated for one panel each: err_theta_max_trusted "
                                       "(over the reference's trusted span [0, trust_t]), err_theta_max (whole "
                                       "run), err_pre_theta_max (before the 1st impact), err_impact1_t, "
                                       "err_win_theta_max (re-synchronised windows), impact_loss_dev_max, "
                                       "energy_resid_max, …"),
            group: str = typer.Option("label", "--group", help="one line per value of this column"),
            out: Optional[str] = typer.Option(None, "--out", help="output stem (default: next to the table)")) -> None:
    """Work-precision diagram (log–log, Pareto front marked) as PNG and SVG; one panel per
    --y column (the error measures every sweep row stores: see daebench/harness/impact_metrics.py)."""
    from daebench.harness.analysis import plots
    from daebench.harness.running import provenance
    from daebench.harness.sweeps.store import read_table

    p = Path(table)
    try:
        df = read_table(p)
    except ParamError as exc:
        _fail(str(exc))
    if "label" not in df.columns or "status" not in df.columns:
        _fail(f"'{p}' is not a sweep table (no 'label'/'status' columns); `daebench plot history` plots run histories")
    side = p.with_suffix(".json")
    try:
        prov = json.loads(side.read_text())["provenance"]
    except (OSError, ValueError, KeyError, TypeError):
        prov = provenance.collect()
    ys = [c.strip() for c in y.split(",") if c.strip()]
    stem = Path(out) if out else p.with_name(f"{p.stem}-wp-{'+'.join(ys)}-vs-{x}")
    try:
        _, files = plots.work_precision(df, x, ys, group, stem, prov, title=plots.sweep_title(df))
    except KeyError as exc:
        _fail(str(exc.args[0]))
    except OSError as exc:
        _fail(f"cannot write the figure at {stem}: {exc.strerror or exc}")
    typer.echo("wrote " + ", ".join(map(str, files)))


@plot_app.command("order")
def plot_order(table: str = typer.Argument(..., help="a sweep table (.parquet or .csv) over --steps or --tols"),
               x: str = typer.Option("h", "--x", help="h (fixed steps) or tol"),
               y: str = typer.Option("err_pre_theta_max,err_impact1_t", "--y",
                                     help="error column(s), comma-separated for one panel each"),
               group: str = typer.Option("label", "--group", help="one line per value of this column"),
               out: Optional[str] = typer.Option(None, "--out", help="output stem (default: next to the table)")) -> None:
    """Convergence: error against h (log–log), one panel per --y column, the measured order of
    each line in its legend, a slope-2 guide."""
    from daebench.harness.analysis import plots
    from daebench.harness.running import provenance
    from daebench.harness.sweeps.store import read_table

    p = Path(table)
    try:
        df = read_table(p)
    except ParamError as exc:
        _fail(str(exc))
    ys = [c.strip() for c in y.split(",") if c.strip()]
    stem = Path(out) if out else p.with_name(f"{p.stem}-order-{'+'.join(ys)}")
    try:
        _, files = plots.convergence(df, x, ys, group, stem, provenance.collect(),
                                     title=plots.sweep_title(df, "convergence"))
    except KeyError as exc:
        _fail(str(exc.args[0]))
    typer.echo("wrote " + ", ".join(map(str, files)))


@plot_app.command("history")
def plot_history(files: list[str] = typer.Argument(..., help="history files written by `daebench run`"),
                 out: str = typer.Option("results/figures/history", "--out", help="output stem"),
                 modal: bool = typer.Option(True, "--modal/--no-modal", help="also W_i(t) if present")) -> None:
    """θ, energy residual and constraint residuals |C|, |Ċ|, |C̈| against t, one panel each
    (and modal participation), one line per run labelled by integrator and settings."""
    from daebench.harness.analysis import plots
    from daebench.harness.running import provenance

    try:
        hists = {}
        for f in files:
            h = read_history(f)
            hists[history_label(f, set(hists))] = h
    except ParamError as exc:
        _fail(str(exc))
    prov = provenance.collect()
    try:
        written = plots.history(hists, out, prov)[1]
        if modal and any(c.startswith("W") and c[1:].isdigit() for h in hists.values() for c in h.columns):
            written += plots.modal_participation(hists, f"{out}-modal", prov)[1]
    except OSError as exc:
        _fail(f"cannot write the figure at {out}: {exc.strerror or exc}")
    typer.echo("wrote " + ", ".join(map(str, written)))
