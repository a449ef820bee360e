"""`daebench compile-report -- COMMAND...`: what a cold run of a daebench command compiles
(:mod:`daebench.studies.compile_census`), written to results/perf/."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Optional

import typer

from daebench.cli.common import fail, out
from daebench.harness.files import atomic_write


def register(app: typer.Typer) -> None:
    """Add `daebench compile-report` to ``app``."""

    @app.command("compile-report", context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
    def compile_report(ctx: typer.Context,
                       opt: Optional[int] = typer.Option(None, "--opt", min=0, max=3,
                                                         help="NUMBA_OPT for the command (default: the environment's)"),
                       top: int = typer.Option(20, "--top", min=1, help="rows of the function table"),
                       out_dir: Optional[str] = typer.Option(None, "--out", help="folder (default results/perf)")) -> None:
        """Run a daebench command twice in a fresh process, first from an empty kernel cache,
        and list every function numba compiled with its own compile time. Example:
        `daebench compile-report -- run beam-impact --integrator hht`."""
        from daebench.harness.running import checks as guards
        from daebench.harness.files import results_dir
        from daebench.studies import compile_census as cc

        args = list(ctx.args)
        if not args:
            fail("give the command to measure after `--`, e.g. "
                 "`daebench compile-report -- run beam-impact --integrator hht`")
        if args[0] == "compile-report":
            fail("compile-report cannot measure itself; give another daebench command after `--`")
        out(f"running `daebench {' '.join(args)}` twice in a fresh process (empty kernel cache, then warm); "
            f"a cold run takes minutes")
        try:
            res = cc.census(args, opt=None if opt is None else str(opt))
        except RuntimeError as exc:
            fail(str(exc), code=1)
        text = cc.markdown(res, top=top)
        out(text)
        folder = Path(out_dir) if out_dir else results_dir() / "perf"
        stamp = time.strftime("%Y%m%dT%H%M%S", time.gmtime())
        name = ("compile-" + "-".join(a.strip("-") for a in args if a.strip("-"))[:80]
                + f"-opt{res.opt[0]}-{stamp}.md")  # a time stamp: an earlier report is never replaced
        path = folder / name
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write(path, lambda p: Path(p).write_text(text), "the compile report", "printed above")
        out(f"written: {path}")
