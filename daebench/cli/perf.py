"""`daebench perf` (the speed figures, all or one section) and `daebench compile-report`
(what a cold run of a command compiles) (:mod:`daebench.api.studies`)."""

from __future__ import annotations

from typing import Optional

import typer

from daebench.cli.common import fail, out, refusals


def register(app: typer.Typer) -> None:
    """Add `daebench perf` and `daebench compile-report` to ``app``."""
    app.command("perf")(perf)
    app.command("compile-report",
                context_settings={"allow_extra_args": True, "ignore_unknown_options": True})(compile_report)


def perf(quick: bool = typer.Option(False, "--quick", help="tiny sizes (smoke test), no Table 1 grid"),
         jobs: int = typer.Option(2, "--jobs", "-j", help="worker processes for the Table 1 grid"),
         table: bool = typer.Option(True, "--table/--no-table", help="time the 24-run Table 1 grid"),
         exudyn: bool = typer.Option(True, "--exudyn/--no-exudyn", help="compare with Exudyn when installed"),
         section: Optional[str] = typer.Option(None, "--section",
                                               help="one measurement alone: model-floor (the floor under steps/s), "
                                                    "structure (rod-wall banded scaling), new-model (a new model's "
                                                    "compile cost), cold-start (first commands on an empty cache), "
                                                    "friction (stick/slip per step against μ = 0), compile (what the main "
                                                    "job compiles, per function, from an empty cache), pendulum-peer "
                                                    "(hht and genalpha per step against Exudyn)"),
         out_dir: Optional[str] = typer.Option(None, "--out", help="output folder (default results/perf)")) -> None:
    """Measure the speed figures in one run and write them to results/perf/.

    Table 1's grid beside the published seconds, per-step scaling in N, Exudyn side by side,
    adaptive steps, and steps per second of every integrator."""
    from daebench import api

    s = api.PerfSettings.quick() if quick else api.PerfSettings(jobs=jobs)
    if not table:
        s.table = False
    s.exudyn = exudyn
    with refusals():
        text, res = api.perf(s, out_dir, section)
    out(text)
    if res is not None:
        out(f"written: {res['folder']}/perf.json, perf.md")


def compile_report(ctx: typer.Context,
                   opt: Optional[int] = typer.Option(None, "--opt", min=0, max=3,
                                                     help="NUMBA_OPT for the command (default: the environment's)"),
                   top: int = typer.Option(20, "--top", min=1, help="rows of the function table"),
                   out_dir: Optional[str] = typer.Option(None, "--out", help="folder (default results/perf)")) -> None:
    """List what a daebench command compiles on a cold start, with each function's compile time.

    The command runs twice in a fresh process, first from an empty kernel cache. Example:
    `daebench compile-report -- run beam-impact --integrator hht`."""
    from daebench import api

    args = list(ctx.args)
    root = ctx.find_root()
    if args and not args[0].startswith("-") and root.command.get_command(root, args[0]) is None:
        fail(f"'{args[0]}' is not a daebench command; give one after `--`, e.g. "
             f"`daebench compile-report -- run beam-impact --integrator hht` (`daebench --help` lists them)")
    if args and args[0] != "compile-report":
        out(f"running `daebench {' '.join(args)}` twice in a fresh process (empty kernel cache, then warm); "
            f"a cold run takes minutes")
    try:
        with refusals():
            text, path = api.compile_report(args, opt, top, out_dir)
    except RuntimeError as exc:
        fail(str(exc), code=1)
    out(text)
    out(f"written: {path}")
