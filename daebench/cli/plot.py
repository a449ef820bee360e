"""`daebench plot …`: figures from sweep tables and run histories (:mod:`daebench.api.figures`)."""

from __future__ import annotations

from typing import Optional

import typer

from daebench.cli.common import refusals

plot_app = typer.Typer(no_args_is_help=True, help="Figures from sweep tables and run histories.")


def register(app: typer.Typer) -> None:
    """Add `daebench plot wp|order|history` to ``app``."""
    plot_app.command("wp")(plot_wp)
    plot_app.command("order")(plot_order)
    plot_app.command("history")(plot_history)
    app.add_typer(plot_app, name="plot")


def plot_wp(table: str = typer.Argument(..., help="a sweep table (.parquet or .csv)"),
            x: str = typer.Option("cpu_s", "--x", help="cost column (cpu_s, wall_s, steps, ...)"),
            y: str = typer.Option("err_theta_max_trusted", "--y",
                                  help="error column(s), comma-separated for one panel each: err_theta_max_trusted "
                                       "(over the reference's trusted span [0, trust_t]), err_theta_max (whole "
                                       "run), err_pre_theta_max (before the 1st impact), err_impact1_t, "
                                       "err_win_theta_max (re-synchronised windows), impact_loss_dev_max, "
                                       "energy_resid_max, …"),
            group: str = typer.Option("label", "--group", help="one line per value of this column"),
            out: Optional[str] = typer.Option(None, "--out", help="output stem (default: next to the table)")) -> None:
    """Draw a work–precision diagram of a sweep table as PNG and SVG.

    Log–log, the Pareto front marked, one panel per --y column (the error measures every sweep
    row stores: see daebench/harness/scoring/impact_metrics.py)."""
    from daebench import api

    with refusals():
        files = api.plot_work_precision(table, x, y, group, out)
    typer.echo("wrote " + ", ".join(map(str, files)))


def plot_order(table: str = typer.Argument(..., help="a sweep table (.parquet or .csv) over --steps or --tols"),
               x: str = typer.Option("h", "--x", help="h (fixed steps) or tol"),
               y: str = typer.Option("err_pre_theta_max,err_impact1_t", "--y",
                                     help="error column(s), comma-separated for one panel each"),
               group: str = typer.Option("label", "--group", help="one line per value of this column"),
               out: Optional[str] = typer.Option(None, "--out", help="output stem (default: next to the table)")) -> None:
    """Draw the convergence of a sweep table: error against h, with the measured orders.

    Log–log, one panel per --y column, the measured order of each line in its legend, a
    slope-2 guide."""
    from daebench import api

    with refusals():
        files = api.plot_convergence(table, x, y, group, out)
    typer.echo("wrote " + ", ".join(map(str, files)))


def plot_history(files: list[str] = typer.Argument(..., help="history files written by `daebench run`"),
                 out: Optional[str] = typer.Option(None, "--out", help="output stem (default results/figures/history)"),
                 modal: bool = typer.Option(True, "--modal/--no-modal", help="also W_i(t) if present")) -> None:
    """Draw run histories: θ, energy residual and constraint residuals against t.

    One panel each for θ, the energy residual, |C|, |Ċ|, |C̈| (and the modal participation),
    one line per run labelled by integrator and settings."""
    from daebench import api

    with refusals():
        written = api.plot_histories(files, out, modal)
    typer.echo("wrote " + ", ".join(map(str, written)))
