"""`daebench compare CASE`: every applicable integrator at the case's protocol, scored
against the reference, one table and the work-precision figure (:mod:`daebench.workflows.compare`)."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Optional

import typer

from daebench.core.params import ParamError


def register(app: typer.Typer) -> None:
    """Add `daebench compare` to ``app``."""

    @app.command("compare")
    def compare(case: str = typer.Argument(..., help="scene name or path to a .toml file"),
                set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
                jobs: int = typer.Option(2, "--jobs", "-j", help="worker processes"),
                reference: str = typer.Option("compute", "--reference",
                                              help="compute (when missing, with a progress bar) | require | auto"),
                run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of one run [s]"),
                out: Optional[str] = typer.Option(None, "--out",
                                                  help="output folder (default results/compare/<case>-<hash>)"),
                json_out: bool = typer.Option(False, "--json", help="print the table as JSON records only"),
                report_page: bool = typer.Option(False, "--report",
                                                 help="also write report.html (one self-contained page) in the folder")) -> None:
        """Run every applicable integrator at the case's protocol (daebench/harness/compare.py: PROTOCOLS),
        score each run against the reference, print one table and write the work-precision figure."""
        from daebench.workflows import compare as C
        from daebench.cli import textout
        from daebench.cli.common import load_scene_or_exit, fail, out as say
        from daebench.harness.analysis import recommend as Rec
        from daebench.harness.sweeps import digest as D
        from daebench.harness.files import OutputWriteError
        from daebench.harness.files import results_dir

        sc = load_scene_or_exit(case, set_)
        folder = Path(out) if out is not None else results_dir() / "compare" / f"{sc.name}-{sc.hash[:8]}"
        previous = D.previous_table(folder / "table.parquet")   # the last comparison: its digests
        t0 = time.perf_counter()
        try:
            res = C.run_compare(sc, jobs=jobs, out=folder, reference=reference, run_cap=run_cap, progress=True)
        except OutputWriteError as exc:  # the work is done: show it, say what was not saved, exit 1
            if getattr(exc, "result", None) is not None:
                cols, rows = C.table_rows(exc.result.table, exc.result.headline)
                for line in textout.table_lines(cols, rows, title=f"{sc.name}: {exc.result.protocol.why}"):
                    say(line)
            fail(str(exc), 1)
        except ParamError as exc:
            fail(str(exc))
        if json_out:
            sys.stdout.write(C.as_json(res) + "\n")
        else:
            cols, rows = C.table_rows(res.table, res.headline)
            for line in textout.table_lines(cols, rows, title=f"{sc.name}: {res.protocol.why}"):
                say(line)
            for line in C.summary_lines(res):
                say(line)
            for line in Rec.compare_lines(res.table, C.measures_present(res.table, res.protocol.measures)):
                say(line)
            say(f"written: {', '.join(str(p) for p in res.files if p.suffix in ('.png', '.csv'))}")
        if report_page:
            from daebench.workflows.report import write_compare_report

            try:
                page = write_compare_report(res, sc, folder / "report.html")
            except OutputWriteError as exc:
                fail(str(exc), 1)
            (sys.stderr.write if json_out else say)(f"report page: {page}" + ("\n" if json_out else ""))
        if not json_out:
            say(f"wall time of the comparison: {time.perf_counter() - t0:.1f} s")
        changed = D.mismatch_lines(previous, res.table)   # a run whose history differs from its last time
        for line in changed:
            sys.stderr.write(line + "\n")
        bad = res.table[res.table["status"].isin(("error", "timeout", "crashed"))]
        if len(bad):
            sys.stderr.write(f"{len(bad)} run(s) gave no verdict; see the 'message' column\n")
        if len(bad) or changed:
            raise typer.Exit(1)
