"""`daebench score` (another code's trajectory of a case, scored as a daebench run is) and
`daebench export` (what another code needs to set a case up) (:mod:`daebench.api.external`)."""

from __future__ import annotations

import sys
from typing import Optional

import typer

from daebench.cli import textout
from daebench.cli.common import fail, load_scene_or_exit, out


def register(app: typer.Typer) -> None:
    """Add `daebench score` and `daebench export` to ``app``."""
    app.command("score")(score)
    app.command("export")(export)


def score(case: str = typer.Argument(..., help="scene name or path to a .toml file"),
          file: str = typer.Argument(..., help="CSV or Parquet file: a column t [s] and any of the case's observables "
                                               "(`daebench show CASE` lists them with their units)"),
          impacts: Optional[str] = typer.Option(None, "--impacts",
                                                help="CSV/Parquet file of the impacts: columns t and contact "
                                                     "(default: FILE's stem + '-impacts.csv' beside it, else from "
                                                     "the gap column, else rows written twice)"),
          set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
          label: Optional[str] = typer.Option(None, "--label", help="the row's name (default: the file's "
                                                                     "'# label:' line, else its name)"),
          cost_s: Optional[float] = typer.Option(None, "--cost-s", help="the external run's cost [s] (places it on "
                                                                        "work-precision figures)"),
          steps: Optional[int] = typer.Option(None, "--steps", help="the external run's number of steps"),
          allow_start: bool = typer.Option(False, "--allow-start-mismatch",
                                           help="score a file whose values at t = 0 differ from the case's start "
                                                "(a note in the row instead of a refusal)"),
          reference: str = typer.Option("compute", "--reference",
                                        help="without an exact solution: compute (when missing) | require"),
          out_dir: Optional[str] = typer.Option(None, "--out",
                                                help="folder for the scored row (default `results/score/<case>-<hash>`)"),
          as_json: bool = typer.Option(False, "--json", help="print one JSON record, with a sweep row's keys")) -> None:
    """Score another code's trajectory of a case as a daebench run is scored.

    The trajectory is held to the case's exact solution or reference with every measure of a
    daebench run, and judged by a run's rules (exit 1 when it diverged or failed); the scored
    row is written and a summary printed."""
    from daebench import api

    sc = load_scene_or_exit(case, set_)
    try:
        res = api.score(sc, file, impacts=impacts, label=label, cost_s=cost_s, steps=steps, reference=reference,
                        progress=not as_json, out=out_dir, allow_start_mismatch=allow_start)
    except api.OutputWriteError as exc:
        fail(str(exc), 1)
    except api.ParamError as exc:
        fail(str(exc))
    except KeyboardInterrupt:
        fail("interrupted; nothing was written", 130)
    except Exception as exc:  # e.g. a reference computation that failed: say so, no traceback
        fail(f"scoring {file} raised {type(exc).__name__}: {exc}", 1)
    if as_json:
        sys.stdout.write(res.as_json() + "\n")
    else:
        for line in textout.kv_lines(res.summary()):
            out(line)
    if res.row["status"] != "completed":   # as `daebench run`: a file whose physics broke exits 1
        raise typer.Exit(1)


def export(case: str = typer.Argument(..., help="scene name or path to a .toml file"),
           set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
           out_dir: Optional[str] = typer.Option(None, "--out",
                                                 help="folder for `<case>.json` and `<case>.md` "
                                                      "(default `results/export/<case>-<hash>`)"),
           as_json: bool = typer.Option(False, "--json", help="print the JSON sheet (stdout holds nothing else)")
           ) -> None:
    """Write what another code needs to set a case up, as JSON and a Markdown sheet.

    Every parameter with its unit, the initial state, the contact law, the observables'
    definitions, t_end and the output times."""
    from daebench import api

    sc = load_scene_or_exit(case, set_)
    try:
        res = api.export_case(sc, out=out_dir)
    except api.OutputWriteError as exc:
        fail(str(exc), 1)
    except api.ParamError as exc:
        fail(str(exc))
    if as_json:
        sys.stdout.write(res.as_json() + "\n")
        return
    out(f"{sc.name}: {len(res.sheet['parameters'])} parameters, {len(res.sheet['observables'])} observables, "
        f"scored against {res.sheet['scoring']['truth']}")
    out(f"written: {', '.join(str(p) for p in res.files)}")
