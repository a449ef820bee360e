"""The `daebench` command."""

from __future__ import annotations

import json
import sys
from typing import Optional

import typer
from rich.console import Console
from rich.table import Table

from daebench.params import ParamError

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Benchmark time integrators for constrained mechanical systems with impact.")
console = Console()
err = Console(stderr=True)


def fail(msg: str, code: int = 2) -> None:
    err.print(f"[bold red]error:[/] {msg}", highlight=False)
    raise typer.Exit(code)


def _load(scene: str, sets: list[str]):
    from daebench.scene import load_scene

    try:
        return load_scene(scene, sets)
    except ParamError as exc:
        fail(str(exc))


@app.command("list")
def list_cmd() -> None:
    """Cases (scene files) and integrators (built-in and plugins)."""
    from daebench.integrators.base import registry
    from daebench.scene import list_scenes

    t = Table(title="cases", show_lines=False)
    t.add_column("scene")
    t.add_column("description")
    for name, desc in list_scenes():
        t.add_row(name, desc)
    console.print(t)
    t = Table(title="integrators")
    for col in ("name", "order", "steps", "constraints", "from", "description"):
        t.add_column(col)
    for name, reg in registry().items():
        if reg.cls is None:
            t.add_row(name, "", "", "", reg.distribution, f"[red]cannot be loaded: {reg.error}[/]")
            continue
        cap = reg.cls.capabilities
        steps = "/".join(x for x, ok in (("fixed", cap.fixed_step), ("adaptive", cap.adaptive)) if ok)
        cons = f"index {cap.index}" if cap.constraints else "ODE only"
        t.add_row(name, str(cap.order), steps, cons, reg.distribution, reg.cls.description)
    console.print(t)


@app.command()
def show(scene: str = typer.Argument(..., help="scene name or path to a .toml file"),
         set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
         keys: bool = typer.Option(False, "--keys", help="list every valid key with its type and range")) -> None:
    """Resolved parameters of a scene, the effects on/off and the problem size."""
    from daebench.models import build_system

    sc = _load(scene, set_)
    console.print(f"[bold]{sc.name}[/] — {sc.description}  (model {sc.model}, hash {sc.hash})")
    eff = sc.effects()
    if eff:
        console.print("effects: " + ", ".join(f"{k} [{'green' if v else 'dim'}]{'on' if v else 'off'}[/]"
                                               for k, v in eff.items()))
    t = Table()
    for col in ("key", "value") + (("type / range", "meaning") if keys else ()):
        t.add_column(col)
    for k, v in sc.values.items():
        if k.startswith("effects."):
            continue
        row = [k, repr(v)]
        if keys:
            p = sc.schema[k]
            row += [p.describe(), f"{p.doc}{f' [{p.unit}]' if p.unit else ''}"]
        t.add_row(*row)
    console.print(t)
    try:
        system = build_system(sc)
    except ParamError as exc:
        fail(str(exc))
    console.print(f"size: n = {system.n} coordinates, {system.n_bilateral} bilateral constraints, "
                  f"{system.n_contacts} contact point(s)"
                  + (f", contact law {system.contact_law.name}" if system.contact_law else ""))


@app.command()
def run(scene: str = typer.Argument(..., help="scene name or path to a .toml file"),
        integrator: str = typer.Option("ida", "--integrator", "-i", help="integrator name (see `daebench list`)"),
        set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
        opt: list[str] = typer.Option([], "--opt", help="integrator setting: name=value (e.g. h=1e-4)"),
        out: Optional[str] = typer.Option(None, "--out", help="folder for the history file (default results/runs)"),
        as_json: bool = typer.Option(False, "--json", help="print one JSON record")) -> None:
    """Run a scene with one integrator; write the time history; print a summary."""
    from daebench.runner import make_integrator, run_scene

    sc = _load(scene, set_)
    try:
        integ = make_integrator(integrator, opt)
        rec, _ = run_scene(sc, integ, out_dir=out)
    except ParamError as exc:
        fail(str(exc))
    if as_json:
        sys.stdout.write(rec.to_json() + "\n")
    else:
        colour = {"completed": "green", "diverged": "red", "failed": "red"}[rec.status]
        console.print(f"[bold]{rec.scene}[/] with [bold]{rec.integrator}[/]: [{colour}]{rec.status}[/] "
                      f"{rec.message} in {rec.wall_s:.3g} s")
        o = rec.observables
        shown = {k: o[k] for k in ("t", "theta_deg", "tip_w2", "tip_y") if k in o}
        console.print("final: " + ", ".join(f"{k} = {v:.10g}" for k, v in shown.items()))
        console.print(f"energy residual (max |.|): {rec.energy_residual:.3e} J")
        if rec.impacts:
            console.print(f"impacts: {len(rec.impacts)}; first at t = {rec.impacts[0]['t']:.12g} s")
        if any(rec.constraint_max.values()):
            c = rec.constraint_max
            console.print(f"max while closed: |C| {c['C']:.2e}, |Ċ| {c['Cdot']:.2e}, |C̈| {c['Cddot']:.2e}")
        console.print("counters: " + ", ".join(f"{k} {v}" for k, v in rec.counters.items()))
        console.print(f"history: {rec.history}")
    if rec.status != "completed":
        raise typer.Exit(1)


def main() -> None:  # pragma: no cover
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
