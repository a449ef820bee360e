"""`daebench verify INTEGRATOR`: what an integrator declares, measured — one pass/fail line
per property with the numbers (:mod:`daebench.api.verify`)."""

from __future__ import annotations

import sys
from typing import Optional

import typer

from daebench.cli.common import fail, out


def register(app: typer.Typer) -> None:
    """Add `daebench verify` to ``app``."""
    app.command("verify")(verify)


def verify(integrator: str = typer.Argument(..., help="integrator name (see `daebench list`)"),
           opt: list[str] = typer.Option([], "--opt", help="integrator setting: name=value (the cases set the step)"),
           only: Optional[str] = typer.Option(None, "--only",
                                              help="comma-separated properties: order, drift, energy, contract, contact"),
           as_json: bool = typer.Option(False, "--json", help="print one JSON record (stdout holds nothing else)"),
           run_cap: Optional[float] = typer.Option(None, "--run-cap",
                                                   help="wall-time cap of each property [s] (default 10 min); a "
                                                        "property over it fails")) -> None:
    """Measure what an integrator declares on cases with exact solutions; PASS/FAIL per property.

    Order, constraint index, energy, the step contract and contact handling, one
    PASS/FAIL/N/A line per property. Exit 1 if one fails."""
    from daebench import api

    try:
        settings = api.parse_pairs(opt, "--opt", "alpha=-0.1")
        props = [p.strip() for p in only.split(",") if p.strip()] if only else None
        res = api.verify(integrator, settings, properties=props, **({} if run_cap is None else {"run_cap": run_cap}),
                         progress=None if as_json else (lambda p: sys.stderr.write(f"measuring {p} …\n")))
    except api.ParamError as exc:
        fail(str(exc))
    if as_json:
        sys.stdout.write(res.as_json() + "\n")
    else:
        out(f"{res.integrator}: declares order {res.declared['order']}, "
            + (f"index {res.declared['index']}" if res.declared["constraints"] else "ODE only")
            + (", resolves contacts" if res.declared["contacts"] else "")
            + (", friction" if res.declared["friction"] else ""))
        for line in res.lines():
            out(line)
        bad = res.failed
        out(f"{'every property holds' if not bad else f'{len(bad)} propert' + ('y fails' if len(bad) == 1 else 'ies fail')}"
            + f" ({sum(c.status == 'n/a' for c in res.checks)} not measurable here)")
    if not res.ok:
        raise typer.Exit(1)
