"""`daebench seed003 …`: the complementarity study of seed 003 reproduced (its chain and its
flexible double pendulum, with its own scheme ``lcp-avg`` beside the continuous laws and
the event-driven driver). The tables come from :mod:`daebench.studies.seed003`."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    """Add the ``seed003`` command group to the daebench CLI."""
    sub = typer.Typer(no_args_is_help=True, help="Seed 003: time-averaged-gap LCP vs continuous laws and events.")

    @sub.command("chain")
    def chain(windows: str = typer.Option("1e-4,5e-4,1e-3,2e-3", help="lcp-avg windows h_avg [s], comma-separated"),
              restitutions: str = typer.Option("0.1,0.2,0.3,0.5,0.8,1", help="Flores restitutions"),
              out: str = typer.Option("results/seed003", help="folder for the CSV table")) -> None:
        """chain-impact: lcp-avg at several h_avg beside Hertz–Flores/LN under IDA (unclipped Flores force)."""
        from daebench.studies.seed003 import chain_table

        df, _ = chain_table(_floats(windows), _floats(restitutions), progress=True)
        _emit(df, Path(out) / "chain.csv")

    @sub.command("pendulum")
    def pendulum(windows: str = typer.Option("1e-3,1e-2", help="lcp-avg windows h_avg [s]"),
                 hertz: bool = typer.Option(True, "--hertz/--no-hertz", help="also the Hertz law under IDA"),
                 out: str = typer.Option("results/seed003", help="folder for the CSV table and the figure")) -> None:
        """double-pendulum: event-driven IDA, lcp-avg and Hertz; outcome table and tip gap/force figure."""
        from daebench.studies.seed003 import pendulum_figure, pendulum_table

        df, runs = pendulum_table(_floats(windows), hertz=hertz, progress=True)
        folder = Path(out)
        _emit(df, folder / "pendulum.csv")
        pendulum_figure(runs, str(folder / "double-pendulum.png"))
        typer.echo(f"wrote {folder / 'double-pendulum.png'}")

    app.add_typer(sub, name="seed003")


def _floats(text: str) -> tuple[float, ...]:
    """Comma-separated finite numbers ≥ 0 (the package's one number rule); exit 2 otherwise."""
    from daebench.cli.common import fail
    from daebench.core.params import Param, ParamError

    vals = [x.strip() for x in text.split(",") if x.strip()]
    if not vals:
        fail(f"'{text}' is not a comma-separated list of numbers (e.g. 1e-3,1e-2)")
    try:
        return tuple(Param("value", float, 0.0, "a list value", low=0.0, high=1e5).validate(v, "a") for v in vals)
    except ParamError as exc:
        fail(f"{exc} (in '{text}')")
        raise


def _emit(df, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    df.to_csv(path, index=False)
    typer.echo(df.to_string(index=False, float_format=lambda x: f"{x:.5g}"))
    typer.echo(f"wrote {path}")
