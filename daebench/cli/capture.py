"""`daebench capture …`: event-capturing against event-driven contact on one case — the
comparison page (work–precision per error measure, penetration and energy over time) and
the per-step cost. Wired into the CLI with :func:`register`."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from daebench.core.params import ParamError
from daebench.harness.files import OutputWriteError, describe_os_error, ensure_writable_dir

capture_app = typer.Typer(no_args_is_help=True, help="Event-capturing (moreau, nsgenalpha) vs event-driven "
                                                     "(hht, ida) contact: comparison page and per-step cost.")


def _numbers(text: str, what: str) -> list[float]:
    """Comma-separated positive finite numbers (the package's one number rule, :class:`Param`)."""
    from daebench.core.params import Param

    vals = [x.strip() for x in text.split(",") if x.strip()]
    if not vals:
        raise ParamError(f"--{what} must be comma-separated numbers, e.g. 2e-4,1e-4; got '{text}'")
    p = Param(what, float, 1e-4, f"--{what} values", low=1e-14, high=1e5)
    return [p.validate(v, "a value of") for v in vals]


def _finite(value: float | None, what: str, low: float, high: float) -> float | None:
    """A number option checked by the one rule: finite (NaN passes typer's ranges), in range."""
    from daebench.core.params import Param

    return None if value is None else Param(what, float, low, what, low=low, high=high).validate(value, "option")


@capture_app.command("page")
def page(scene: str = typer.Argument("beam-impact", help="a case with contacts (constraint law)"),
         restitution: float = typer.Option(0.3, "--restitution", "-e", help="contact.restitution, in [0, 1]"),
         steps: str = typer.Option("4e-4,2e-4,1e-4,5e-5,2.5e-5", "--steps", help="fixed steps of hht, moreau, nsgenalpha"),
         tols: str = typer.Option("1e-5,1e-6,1e-7,1e-8", "--tols", help="tolerances of ida"),
         h: float = typer.Option(1e-4, "--h", help="step of the penetration/energy history runs [s]"),
         t_end: Optional[float] = typer.Option(None, "--t-end", help="override the scene's end time [s]"),
         jobs: int = typer.Option(1, "--jobs", "-j", min=1, help="worker processes"),
         repeats: int = typer.Option(3, "--repeats", min=1, help="timed runs per point (minimum kept)"),
         out: str = typer.Option("results/capture", "--out", help="folder for the figures"),
         resume: bool = typer.Option(False, "--resume", help="complete the interrupted sweeps of this page"),
         overwrite: bool = typer.Option(False, "--overwrite", help="replace the sweep tables of an earlier page")) -> None:
    """Sweep hht, moreau (projection off/on), nsgenalpha at --steps and ida at --tols against
    the IDA reference; write one work–precision figure per error measure and a figure of
    penetration and energy over time (one run each at --h). Progress goes to stderr; the
    sweep tables are results/bench/<scene>-capture-e…-{fixed,ida}: run the page again with
    --resume (after an interruption) or --overwrite (to replace them)."""
    from daebench.cli.common import fail
    from daebench.harness.running import checks as guards
    from daebench.studies import eventcapture as ec

    folder = Path(out)
    try:
        restitution = _finite(restitution, "--restitution", 0.0, 1.0)
        h = _finite(h, "--h", 1e-12, 1.0)
        t_end = _finite(t_end, "--t-end", 1e-9, 1e5)
        step_list, tol_list = _numbers(steps, "steps"), _numbers(tols, "tols")
        ensure_writable_dir(folder, "--out folder")
        ov = {} if t_end is None else {"t_end": t_end}
        df = ec.compare(scene, restitution, step_list, tol_list, overrides=ov, jobs=jobs, repeats=repeats,
                        progress=True, resume=resume, overwrite=overwrite)
        title = f"{scene}, e = {restitution:g}"
        files = ec.work_precision_figures(df, folder / ec.tag(restitution), title=title)
        hists = ec.capture_histories(scene, restitution, h, overrides=ov, progress=True)
        files += ec.penetration_energy_figure(hists, folder / f"penetration-energy-{ec.tag(restitution)}", title)[1]
    except OutputWriteError as exc:
        fail(str(exc), 1)
    except ParamError as exc:
        fail(str(exc))
    except OSError as exc:
        fail(f"cannot write to '{folder}': {describe_os_error(exc)}; the sweep tables are kept in "
             f"results/bench/ (run again with --resume to redraw without running)", 1)
    typer.echo(ec.summary(df).to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    typer.echo("wrote " + ", ".join(map(str, files)))


@capture_app.command("rates")
def rates(n: int = typer.Option(5, "--n", min=1, help="beam modes"),
          h: float = typer.Option(1e-4, "--h", min=1e-12, help="fixed step [s]"),
          repeats: int = typer.Option(3, "--repeats", min=1, help="timed rounds (minimum kept)")) -> None:
    """Steps per second of moreau, nsgenalpha and hht on beam-impact, measured in one process."""
    from daebench.studies import eventcapture as ec

    df = ec.step_rates(n_modes=n, h=h, repeats=repeats)
    typer.echo(df.to_string(index=False, float_format=lambda v: f"{v:.4g}"))


def register(app: typer.Typer) -> None:
    """Add `daebench capture page|rates` to the CLI."""
    app.add_typer(capture_app, name="capture")
