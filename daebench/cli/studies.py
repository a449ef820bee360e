"""The studies' commands (:mod:`daebench.api.studies`): the reproduced papers — `daebench
paper` (HHT-α beam impact), `daebench averaged-gap` (the time-averaged-gap LCP; `seed003`
is its deprecated old name) and `daebench interactive-mode` (flexible bodies in contact) —
and `daebench capture` (event-capturing against event-driven contact)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Optional

import typer

from daebench.cli.common import fail, out, refusals

capture_app = typer.Typer(no_args_is_help=True, help="Event-capturing (moreau, nsgenalpha) vs event-driven "
                                                     "(hht, ida) contact: comparison page and per-step cost.")
averaged_gap_app = typer.Typer(no_args_is_help=True, help="The time-averaged-gap LCP (lcp-avg) beside continuous "
                                                          "contact laws and the event-driven driver: the chain and "
                                                          "the flexible double pendulum of its paper.")
#: the old name of `averaged-gap`, kept for one release: a note on stderr, then the same commands
seed003_app = typer.Typer(no_args_is_help=True, hidden=True, help="Deprecated: `daebench averaged-gap`.",
                          callback=lambda: sys.stderr.write("note: `daebench seed003` is deprecated; it is now "
                                                            "`daebench averaged-gap` (same subcommands)\n"))


def register(app: typer.Typer) -> None:
    """Add `daebench paper`, `averaged-gap` (and its old name `seed003`), `interactive-mode`
    and `capture` to ``app``."""
    app.command("paper")(paper)
    app.command("interactive-mode")(interactive_mode)
    for sub in (averaged_gap_app, seed003_app):
        sub.command("chain")(chain)
        sub.command("pendulum")(pendulum)
    app.add_typer(averaged_gap_app, name="averaged-gap")
    app.add_typer(seed003_app, name="seed003")
    capture_app.command("page")(page)
    capture_app.command("rates")(rates)
    app.add_typer(capture_app, name="capture")


def paper(quick: bool = typer.Option(False, "--quick", help="reduced grid for CI (N=3, t_end 0.5 s, h_contact 1e-5)"),
          jobs: int = typer.Option(1, "--jobs", "-j", help="worker processes"),
          out_dir: Optional[str] = typer.Option(None, "--out", help="output folder (default results/paper)"),
          run_cap: Optional[float] = typer.Option(None, "--run-cap",
                                                  help="wall-time cap of one run [s] (default 60 with --quick)"),
          variant: str = typer.Option("both", "--variant",
                                      help="published (beam-impact, h = 1e-4 s) | calibrated (beam-impact-hub, "
                                           "h = 2.5e-5 s) | both")) -> None:
    """Reproduce the beam-impact paper (HHT-α vs Baumgarte): Table 1 and a verdict per claim.

    Table 1 beside the published seconds, one figure and one computed verdict per claim, for
    the published setting and for the calibrated variant (hub inertia and step at which this
    model shows the paper's stability pattern; see cases/beam-impact-hub.toml)."""
    from daebench import api

    with refusals():
        done = api.hht_beam_impact(variant, quick=quick, jobs=jobs, out=out_dir, run_cap=run_cap)
    for heading, res in done:
        out(f"== {heading} ==")
        out(res.table_md)
        for v in res.verdicts:
            out(v)
        out(f"outputs in {res.folder}")


def interactive_mode(part: str = typer.Argument("rodwall", help="rodwall | slider | rodplate | cost | figure"),
                     out_dir: Optional[str] = typer.Option(None, "--out",
                                                           help="folder for the JSON rows (default results/flexcontact)")
                     ) -> None:
    """Reproduce one table or figure of the interactive-mode paper (flexible bodies in contact).

    The runs behind one of its tables — ACM, PFM and IMM on rod-wall, slider-slot or
    rod-plate, their cost — or the slider figure."""
    from daebench import api

    with refusals():
        folder = api.interactive_mode(part, out_dir)
    out(f"written: {folder}")


def _floats(text: str) -> tuple[float, ...]:
    from daebench import api

    try:
        return api.numbers(text)
    except api.ParamError as exc:
        fail(str(exc))


def _emit(res) -> None:
    typer.echo(res.table.to_string(index=False, float_format=lambda x: f"{x:.5g}"))
    for f in res.files:
        typer.echo(f"wrote {f}")


def chain(windows: str = typer.Option("1e-4,5e-4,1e-3,2e-3", help="lcp-avg windows h_avg [s], comma-separated"),
          restitutions: str = typer.Option("0.1,0.2,0.3,0.5,0.8,1", help="Flores restitutions"),
          out_dir: Optional[str] = typer.Option(None, "--out",
                                                help="folder for the CSV table (default results/averaged-gap)")) -> None:
    """Run lcp-avg on chain-impact at several windows beside Hertz–Flores under IDA.

    The Hertz law with Flores' and Lankarani–Nikravesh's damping (unclipped Flores force)."""
    from daebench import api

    with refusals():
        res = api.averaged_gap_chain(_floats(windows), _floats(restitutions), out_dir)
    _emit(res)


def pendulum(windows: str = typer.Option("1e-3,1e-2", help="lcp-avg windows h_avg [s]"),
             hertz: bool = typer.Option(True, "--hertz/--no-hertz", help="also the Hertz law under IDA"),
             out_dir: Optional[str] = typer.Option(None, "--out", help="folder for the CSV table and the figure "
                                                                       "(default results/averaged-gap)")) -> None:
    """Run the flexible double pendulum under lcp-avg, event-driven IDA and Hertz.

    Prints the outcome table and writes the tip gap and tip force figure."""
    from daebench import api

    with refusals():
        res = api.averaged_gap_pendulum(_floats(windows), hertz=hertz, out=out_dir)
    _emit(res)


def _numbers(text: str, what: str) -> list[float]:
    """Comma-separated positive finite numbers (the package's one number rule)."""
    from daebench import api

    vals = [x.strip() for x in text.split(",") if x.strip()]
    if not vals:
        raise api.ParamError(f"--{what} must be comma-separated numbers, e.g. 2e-4,1e-4; got '{text}'")
    p = api.Param(what, float, 1e-4, f"--{what} values", low=1e-14, high=1e5)
    return [p.validate(v, "a value of") for v in vals]


def _finite(value: float | None, what: str, low: float, high: float) -> float | None:
    """A number option checked by the one rule: finite (NaN passes typer's ranges), in range."""
    from daebench import api

    return None if value is None else api.Param(what, float, low, what, low=low, high=high).validate(value, "option")


def page(scene: str = typer.Argument("beam-impact", help="a case with contacts (constraint law)"),
         restitution: float = typer.Option(0.3, "--restitution", "-e", help="contact.restitution, in [0, 1]"),
         steps: str = typer.Option("4e-4,2e-4,1e-4,5e-5,2.5e-5", "--steps", help="fixed steps of hht, moreau, nsgenalpha"),
         tols: str = typer.Option("1e-5,1e-6,1e-7,1e-8", "--tols", help="tolerances of ida"),
         h: float = typer.Option(1e-4, "--h", help="step of the penetration/energy history runs [s]"),
         t_end: Optional[float] = typer.Option(None, "--t-end", help="override the scene's end time [s]"),
         jobs: int = typer.Option(1, "--jobs", "-j", min=1, help="worker processes"),
         repeats: int = typer.Option(3, "--repeats", min=1, help="timed runs per point (minimum kept)"),
         out_dir: Optional[str] = typer.Option(None, "--out", help="folder for the figures (default results/capture)"),
         resume: bool = typer.Option(False, "--resume", help="complete the interrupted sweeps of this page"),
         overwrite: bool = typer.Option(False, "--overwrite", help="replace the sweep tables of an earlier page")) -> None:
    """Write the page of event-capturing beside event-driven contact on a case.

    Sweeps hht, moreau (projection off/on), nsgenalpha at --steps and ida at --tols against
    the IDA reference; writes one work–precision figure per error measure and a figure of
    penetration and energy over time (one run each at --h). Progress goes to stderr; the
    sweep tables are `results/bench/<scene>-capture-e…-{fixed,ida}`: run the page again with
    --resume (after an interruption) or --overwrite (to replace them)."""
    from daebench import api

    with refusals():
        e, h, t_end = (_finite(restitution, "--restitution", 0.0, 1.0), _finite(h, "--h", 1e-12, 1.0),
                       _finite(t_end, "--t-end", 1e-9, 1e5))
        spec = api.CapturePage(scene, e, tuple(_numbers(steps, "steps")), tuple(_numbers(tols, "tols")), h, t_end, jobs,
                               repeats, resume, overwrite)
        summary, files = api.capture_page(spec, Path(out_dir) if out_dir is not None else None)
    typer.echo(summary.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    typer.echo("wrote " + ", ".join(map(str, files)))


def rates(n: int = typer.Option(5, "--n", min=1, help="beam modes"),
          h: float = typer.Option(1e-4, "--h", min=1e-12, help="fixed step [s]"),
          repeats: int = typer.Option(3, "--repeats", min=1, help="timed rounds (minimum kept)")) -> None:
    """Steps per second of moreau, nsgenalpha and hht on beam-impact, measured in one process."""
    from daebench import api

    typer.echo(api.capture_rates(n_modes=n, h=h, repeats=repeats).to_string(index=False,
                                                                            float_format=lambda v: f"{v:.4g}"))
