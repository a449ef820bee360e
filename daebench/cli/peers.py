"""`daebench peer CASE --code NAME`: a peer code (Siconos, Exudyn) runs the case in its own
process and its files are scored (:func:`daebench.api.peer`)."""

from __future__ import annotations

import math
import sys
from typing import Optional

import typer

from daebench.cli.common import fail, floats, load_scene_or_exit, out, print_table


def register(app: typer.Typer) -> None:
    """Add `daebench peer` to ``app``."""
    app.command("peer")(peer)


def peer(case: str = typer.Argument(..., help="scene name or path to a .toml file"),
         code: str = typer.Option(..., "--code", help="the peer: siconos-mj | siconos-ed | exudyn-ga"),
         steps: Optional[str] = typer.Option(None, "--steps", help="fixed steps [s], comma-separated, each dividing "
                                                                   "t_end (default: the peer's own for the case)"),
         set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
         reference: str = typer.Option("compute", "--reference",
                                       help="without an exact solution: compute (when missing) | require"),
         out_dir: Optional[str] = typer.Option(None, "--out", help="folder of the peer's files "
                                                                   "(default `results/peers/<case>-<hash>`)"),
         as_json: bool = typer.Option(False, "--json", help="print the scored rows as JSON only")) -> None:
    """Run a peer code on a case in its own process and score its files.

    The peer builds the case from `daebench export`'s description, writes the observables, its
    impacts (`<file>-impacts.csv`) and the CPU time of its run; each file is scored as
    `daebench score` scores it. A peer that is not installed is refused with its install command."""
    from daebench import api

    sc = load_scene_or_exit(case, set_)
    try:
        res = api.peer(sc, code, floats(steps, "--steps"), reference=reference, progress=not as_json, out=out_dir)
    except api.ParamError as exc:
        fail(str(exc))
    except api.OutputWriteError as exc:
        fail(str(exc), 1)
    except api.PeerFailed as exc:   # the peer's process failed: its own words
        fail(str(exc), 1)
    if as_json:
        sys.stdout.write(res.as_json() + "\n")
        return
    measures = [k for k in res.rows()[0] if k.startswith("err_") and k.endswith("_max_trusted")
                and not any(w in k for w in ("impact", "pre_", "win"))]
    orders = {m: res.orders(m) for m in measures}
    rows = []
    for i, (r, row) in enumerate(zip(res.runs, res.rows())):
        rows.append([f"{r.h:.4g}", r.steps, f"{r.cpu_s:.4g}",
                     *[f"{row.get(m, math.nan):.3e}" for m in measures],
                     *[_order(orders[m][0][i]) for m in measures[:1]],
                     _impacts(row)])
    head = ["h [s]", "steps", "CPU [s]", *[m.removeprefix("err_") for m in measures],
            *[f"order ({measures[0].removeprefix('err_')})" for _ in measures[:1]], "impacts matched/truth"]
    print_table(head, rows, title=f"{res.peer} on {sc.name}: {res.runs[0].code}, {res.runs[0].method.split(',')[0]}")
    if measures and len(res.runs) > 1:
        out(f"fitted order of {measures[0].removeprefix('err_')}: {_order(orders[measures[0]][1])}")
    out(f"CPU time: the simulation loop in the peer's process; files in {res.runs[0].file.parent}")


def _order(p: float) -> str:
    return f"{p:.2f}" if math.isfinite(p) else "-"


def _impacts(row: dict) -> str:
    m, n = row.get("impacts_matched"), row.get("impacts_ref")
    ok = all(isinstance(x, (int, float)) and math.isfinite(float(x)) for x in (m, n))
    return f"{int(m)}/{int(n)}" if ok else "-"
