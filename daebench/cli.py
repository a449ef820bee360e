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
err = Console(stderr=True, soft_wrap=True)  # never wrap an error: keys in it get copied


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
        if cap.contacts:
            cons += ", resolves contacts"
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
    t.add_column("key", no_wrap=True)  # keys are copied into --set: never truncate them
    for col in ("value",) + (("type / range", "meaning") if keys else ()):
        t.add_column(col, overflow="fold")
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


# ---- harness: references, sweeps, figures, the paper ------------------------------------
def _floats(text: str | None, what: str) -> list[float] | None:
    if not text:
        return None
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        fail(f"{what} must be comma-separated numbers, e.g. 1e-3,5e-4; got '{text}'")
    return None


def _grid(items: list[str]) -> dict[str, list[str]]:
    grid: dict[str, list[str]] = {}
    for it in items:
        if "=" not in it:
            fail(f"--grid needs key=v1,v2,... (e.g. --grid alpha=0,-0.15); got '{it}'")
        k, v = it.split("=", 1)
        vals = [x.strip() for x in v.split(",") if x.strip()]
        if not vals:
            fail(f"--grid {k.strip()} has no values")
        grid[k.strip()] = vals
    return grid


@app.command()
def reference(scene: str = typer.Argument(..., help="scene name or path to a .toml file"),
              set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
              rtol: Optional[float] = typer.Option(None, "--rtol", help="IDA rtol (default 1e-11)"),
              atol: Optional[float] = typer.Option(None, "--atol", help="IDA atol (default rtol·1e-2)"),
              force: bool = typer.Option(False, "--force", help="recompute even if cached")) -> None:
    """Compute (or show) the cached IDA reference of a scene, checked against a 10× looser run."""
    from daebench import bench

    sc = _load(scene, set_)
    if not force:
        try:
            ref = bench.load_reference(sc)
            console.print(f"cached: {ref.path} (rtol {ref.rtol:g}); use --force to recompute")
            console.print_json(json.dumps(ref.meta.get("agreement", {})))
            return
        except bench.ReferenceMissing:
            pass
    try:
        ref = bench.compute_reference(sc, rtol=rtol, atol=atol)
    except (ParamError, RuntimeError) as exc:
        fail(str(exc))
    console.print(f"reference: {ref.path}  (IDA rtol {ref.rtol:g}, {ref.meta['wall_s']:.3g} s, "
                  f"{len(ref.impacts)} impacts)")
    agr = ref.meta.get("agreement", {})
    worst = {k: v for k, v in agr.items() if k.startswith("err_") and k.endswith("_max")}
    console.print("agreement with the 10× looser check run: "
                  + ", ".join(f"{k} {v:.2e}" for k, v in worst.items() if v == v))


@app.command()
def bench(scene: str = typer.Argument(..., help="scene name or path to a .toml file"),
          integrators: str = typer.Option(..., "--integrators", "-i", help="comma-separated names, e.g. hht,baumgarte"),
          grid: list[str] = typer.Option([], "--grid", help="key=v1,v2,...: an integrator setting or a scene key"),
          steps: Optional[str] = typer.Option(None, "--steps", help="fixed steps h, e.g. 1e-3,5e-4"),
          tols: Optional[str] = typer.Option(None, "--tols", help="tolerances (adaptive runs), e.g. 1e-4,1e-6"),
          opt: list[str] = typer.Option([], "--opt", help="fixed integrator setting name=value for every run"),
          set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
          jobs: int = typer.Option(1, "--jobs", "-j", help="local worker processes"),
          scheduler: Optional[str] = typer.Option(
              None, "--scheduler",
              help="run on Dask: a scheduler address (tcp://host:8786), or 'local' for a local cluster of --jobs workers"),
          ref_mode: str = typer.Option("require", "--reference",
                                       help="require (error if missing) | compute | auto (score if cached) | none"),
          repeats: int = typer.Option(1, "--repeats", help="timed repeats (min taken; > 1 adds a warm-up run)"),
          name: Optional[str] = typer.Option(None, "--name", help="table name under results/bench/"),
          run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of one run [s]")) -> None:
    """Sweep integrators × grid × steps/tols on a scene; one scored row per run."""
    from daebench import bench as B
    from daebench.params import parse_pairs

    sc = _load(scene, set_)
    try:
        options = parse_pairs(opt, "--opt", "h_contact=1e-6") if opt else {}
        names = [x.strip() for x in integrators.split(",") if x.strip()]
        df = B.run_sweep(sc, names, _grid(grid), _floats(steps, "--steps"), _floats(tols, "--tols"),
                         jobs=jobs, scheduler=scheduler, options=options, name=name,
                         reference_mode=ref_mode, repeats=repeats, warmup=repeats > 1, run_cap=run_cap)
    except (ParamError, B.ReferenceMissing) as exc:
        fail(str(exc))
    cols = [c for c in ("label", "h", "tol", "status", "wall_s", "steps", "err_theta_max", "err_tip_max",
                        "energy_resid_max", "Cdot_max") if c in df.columns]
    t = Table(title=f"{sc.name} ({len(df)} runs)")
    for c in cols:
        t.add_column(c)
    for _, r in df.iterrows():
        t.add_row(*[f"{r[c]:.3g}" if isinstance(r[c], float) else str(r[c]) for c in cols])
    console.print(t)
    console.print(f"table: {B.results_dir() / 'bench' / ((name or f'{sc.name}-{sc.hash[:8]}') + '.parquet')}")


plot_app = typer.Typer(no_args_is_help=True, help="Figures from sweep tables and run histories.")
app.add_typer(plot_app, name="plot")


@plot_app.command("wp")
def plot_wp(table: str = typer.Argument(..., help="a sweep table (.parquet or .csv)"),
            x: str = typer.Option("wall_s", "--x", help="cost column (wall_s, cpu_s, steps, ...)"),
            y: str = typer.Option("err_theta_max", "--y", help="error column"),
            group: str = typer.Option("label", "--group", help="one line per value of this column"),
            out: Optional[str] = typer.Option(None, "--out", help="output stem (default: next to the table)")) -> None:
    """Work-precision diagram (log–log, Pareto front marked) as PNG and SVG."""
    from pathlib import Path

    from daebench import bench as B
    from daebench import plots, provenance

    p = Path(table)
    if not p.exists():
        fail(f"table '{table}' does not exist (sweeps write results/bench/<name>.parquet)")
    df = B.read_table(p)
    side = p.with_suffix(".json")
    prov = json.loads(side.read_text())["provenance"] if side.exists() else provenance.collect()
    stem = Path(out) if out else p.with_name(f"{p.stem}-wp-{y}-vs-{x}")
    try:
        _, files = plots.work_precision(df, x, y, group, stem, prov, title=p.stem)
    except KeyError as exc:
        fail(str(exc.args[0]))
    console.print("wrote " + ", ".join(map(str, files)))


@plot_app.command("history")
def plot_history(files: list[str] = typer.Argument(..., help="history files written by `daebench run`"),
                 out: str = typer.Option("results/figures/history", "--out", help="output stem"),
                 modal: bool = typer.Option(True, "--modal/--no-modal", help="also W_i(t) if present")) -> None:
    """θ, energy residual and constraint residuals against t (and modal participation)."""
    from pathlib import Path

    from daebench import plots, provenance

    try:
        hists = {Path(f).stem: plots.read_history(f) for f in files}
    except FileNotFoundError as exc:
        fail(str(exc))
    prov = provenance.collect()
    written = plots.history(hists, out, prov)[1]
    if modal and any(c.startswith("W") and c[1:].isdigit() for h in hists.values() for c in h.columns):
        written += plots.modal_participation(hists, f"{out}-modal", prov)[1]
    console.print("wrote " + ", ".join(map(str, written)))


@app.command()
def paper(quick: bool = typer.Option(False, "--quick", help="reduced grid for CI (N=3, t_end 0.5 s, h_contact 1e-5)"),
          jobs: int = typer.Option(1, "--jobs", "-j", help="local worker processes"),
          out: Optional[str] = typer.Option(None, "--out", help="output folder (default results/paper)"),
          run_cap: Optional[float] = typer.Option(None, "--run-cap",
                                                  help="wall-time cap of one run [s] (default 60 with --quick)")) -> None:
    """Regenerate the beam-impact study: Table 1 beside the published seconds, one figure
    and one computed verdict per claim (CASES.md)."""
    from daebench.studies import paper as P

    res = P.run_paper(quick=quick, jobs=jobs, out=out, run_cap=run_cap)
    console.print(res.table_md)
    for v in res.verdicts:
        console.print(v)
    console.print(f"outputs in {res.folder}")


@app.command()
def perf(quick: bool = typer.Option(False, "--quick", help="tiny sizes (smoke test), no Table 1 grid"),
         jobs: int = typer.Option(2, "--jobs", "-j", help="worker processes for the Table 1 grid"),
         table: bool = typer.Option(True, "--table/--no-table", help="time the 24-run Table 1 grid"),
         exudyn: bool = typer.Option(True, "--exudyn/--no-exudyn", help="compare with Exudyn when installed"),
         out: Optional[str] = typer.Option(None, "--out", help="output folder (default results/perf)")) -> None:
    """Speed figures in one run (Table 1 grid vs the published seconds, per-step scaling in N,
    Exudyn side by side, adaptive steps), steps/s per integrator; writes results/perf/."""
    from daebench.studies import perf as P

    s = P.PerfSettings.quick() if quick else P.PerfSettings(jobs=jobs)
    if not table:
        s.table = False
    s.exudyn = exudyn
    res = P.run_perf(s, out)
    console.print(P.markdown(res), highlight=False, markup=False)
    console.print(f"written: {res['folder']}/perf.json, perf.md")


def main() -> None:  # pragma: no cover
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
