"""The `daebench` command: a thin layer over :mod:`daebench.api`.

Exit codes: 0 done; 1 a run did not complete (diverged, failed, timed out) or a sweep
has rows that failed for a reason other than the integrator's verdict (error, timeout,
crashed); 2 the input was refused (nothing ran, the message says what to change);
130 interrupted (finished sweep rows are kept). Results go to stdout (``--json``:
machine-only), progress and errors to stderr; no line is wrapped inside a number.
"""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path
from typing import Any, Optional

import typer

from daebench.cli import textout
from daebench.cli.common import load_scene_or_exit, print_table, fail, out
from daebench.core.params import ParamError

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Benchmark time integrators for constrained mechanical systems with impact.")


@app.command("list")
def list_cmd() -> None:
    """Cases (scene files) and integrators (built-in and plugins)."""
    from daebench import api
    from daebench.core.scene import list_scenes

    try:
        cases = list_scenes()
    except ParamError as exc:  # DAEBENCH_CASES pointing nowhere
        fail(str(exc))
    print_table(["case", "description"], [[n, d] for n, d in cases], "cases")
    out()
    rows = []
    for name, info in api.integrator_infos().items():
        if info.capabilities is None:
            rows.append([name, "", "", "", info.distribution, f"cannot be loaded: {info.error}"])
            continue
        cap = info.capabilities
        steps = "/".join(x for x, ok in (("fixed", cap.fixed_step), ("adaptive", cap.adaptive)) if ok)
        cons = f"index {cap.index}" if cap.constraints else "ODE only"
        if cap.contacts:
            cons += ", resolves contacts"
        rows.append([name, cap.order, steps, cons, info.distribution, info.description])
    print_table(["name", "order", "steps", "constraints", "from", "description"], rows, "integrators")
    out("settings of an integrator: daebench show NAME")


def _show_integrator(name: str) -> None:
    from daebench import api

    info = api.integrator_info(name)
    out(f"{info.name} — {info.description} (from {info.distribution})")
    cap = info.capabilities
    if cap is None:
        fail(f"integrator '{info.name}' cannot be loaded: {info.error}")
    steps = ", ".join(x for x, ok in (("fixed", cap.fixed_step), ("adaptive", cap.adaptive)) if ok)
    out(f"capabilities: order {cap.order}; steps: {steps}; "
        + (f"constraints at index {cap.index}" if cap.constraints else "ODE only (no constraints)")
        + ("; resolves contacts itself" if cap.contacts else "")
        + ("; own dense output" if cap.dense_output else ""))
    print_table(["setting", "type / range", "default", "meaning"],
                 [[p.name, p.describe(), repr(p.default), p.doc] for p in info.settings], "settings (--opt name=value)")


@app.command()
def show(name: str = typer.Argument(..., help="an integrator, a case name or a path to a .toml file"),
         set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
         keys: bool = typer.Option(False, "--keys", help="list every valid key with its type and range")) -> None:
    """An integrator's settings and capabilities, or a scene's resolved parameters, effects and size."""
    from daebench import api
    from daebench.harness.running import checks as guards
    from daebench.integrators.base import IntegratorError
    from daebench.models import build_system
    from daebench.core.params import did_you_mean
    from daebench.core.scene import SceneError, UnknownScene, list_scenes
    from daebench.models.scenes import load_scene

    try:
        guards.resolve_integrator(name)
        is_integrator = not set_ and not keys and name.lower() not in {n.lower() for n, _ in list_scenes()}
    except IntegratorError:
        is_integrator = False
    if is_integrator:
        try:
            return _show_integrator(name)
        except ParamError as exc:
            fail(str(exc))
    try:
        sc = load_scene(name, set_)
    except SceneError as exc:
        if isinstance(exc, UnknownScene):  # not 'unknown scene key' of a --set
            known = list(api.integrator_infos()) + [n for n, _ in list_scenes()]
            fail(f"'{name}' is neither an integrator nor a scene{did_you_mean(name.lower(), known)} "
                 f"Integrators and cases: `daebench list`.")
        fail(str(exc))
    out(f"{sc.name} — {sc.description}  (model {sc.model}, hash {sc.hash})")
    eff = sc.effects()
    if eff:
        out("effects: " + ", ".join(f"{k} {'on' if v else 'off'}" for k, v in eff.items()))
    rows = []
    for k, v in sc.values.items():
        if k.startswith("effects."):
            continue
        p = sc.schema[k]
        rows.append([k, repr(v)] + ([p.describe(), f"{p.doc}{f' [{p.unit}]' if p.unit else ''}"] if keys else []))
    print_table(["key", "value"] + (["type / range", "meaning"] if keys else []), rows)
    try:
        system = build_system(sc)
    except ParamError as exc:
        fail(str(exc))
    out(f"size: n = {system.n} coordinates, {system.n_bilateral} bilateral constraints, "
        f"{system.n_contacts} contact point(s)"
        + (f", contact law {system.contact_law.name}" if system.contact_law else ""))


def _settings_text(settings: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in settings.items())


def run_summary(r: Any) -> list[tuple[str, str]]:
    """(label, text) lines of a run's summary: what ran, how it ended, what the numbers mean."""
    pairs = [("run", f"{r.scene.name} with integrator {r.integrator}"),
             ("settings", _settings_text(r.settings) or "(none)"),
             ("status", f"{r.status}{' — ' + r.message if r.message else ''} ({r.wall_s:.3g} s wall)")]
    from daebench.harness.scoring import pipeline as scoring

    declared = scoring.declared(r.scene.model)
    obs = r.record.observables
    finals = [("t", "s")] + [(o.name, o.unit) for o in declared.declared if o.summary]
    for k, unit in finals:
        if k in obs:
            pairs.append((f"final {k}" + (f" [{unit}]" if unit else ""), f"{obs[k]:.10g}"))
    pairs.append(("energy balance", f"max |E − E0 − W_nc + D_impacts| = {r.energy_residual:.3e} J "
                                    f"(bookkeeping error of the run; 0 is exact)"))
    if r.impacts:
        law = getattr(r.record, "impact_law", "")
        pairs.append(("impacts", f"{len(r.impacts)}; first at t = {r.impacts[0]['t']:.12g} s"
                                 + (f"; impact law: {law}" if law else "")))
    c = r.constraint_max
    if any(c.values()):
        pairs.append(("constraints", f"max while closed |C| {c['C']:.2e} m, |Ċ| {c['Cdot']:.2e} m/s, "
                                     f"|C̈| {c['Cddot']:.2e} m/s²"))
    pairs.append(("work", ", ".join(f"{k} {v}" for k, v in r.counters.items())))
    if r.error.get("against"):
        names = [k.removeprefix("err_").removesuffix("_max") for k in r.error
                 if k.startswith("err_") and k.endswith("_max")]
        points = [p for p in declared.positions if p.score_name in names]
        parts = {c for p in points for c in (declared.get(p.x).score_name, declared.get(p.y).score_name)}
        names = [n for n in names if n not in parts]  # a point's coordinates: its one error says it
        errs = [f"{n} {r.error[f'err_{n}_max']:.3e}" for n in names]
        units = _units_text(declared, names)
        pairs.append((f"error vs {r.error['against']} (max over the run{'; ' + units if units else ''})",
                      ", ".join(errs)))
    else:
        pairs.append(("error", f"no exact solution, and {r.error.get('why') or 'no cached reference'}"))
    absent = [o for o in r.scene.get("output.observables") or [] if o not in r.observables.columns]
    if absent:
        pairs.append(("not recorded", f"{', '.join(absent)} (scored observables of the scene that an effect "
                                      f"switched off removes)"))
    if r.history_path:
        pairs.append(("history", r.history_path))
    return pairs


def _units_text(declared: Any, names: list[str]) -> str:
    """'theta in deg, x, y, pos in m': the declared units of the scored names, grouped."""
    by_unit: dict[str, list[str]] = {}
    for n in names:
        d = declared.by_score_name(n)
        if d is not None and d.unit:
            by_unit.setdefault(d.unit, []).append(n)
    return ", ".join(f"{', '.join(ns)} in {u}" for u, ns in by_unit.items())


@app.command()
def run(scene: str = typer.Argument(..., help="scene name or path to a .toml file"),
        integrator: str = typer.Option("ida", "--integrator", "-i",
                                       help="integrator name (see `daebench list`; settings: `daebench show NAME`)"),
        set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
        opt: list[str] = typer.Option([], "--opt", help="integrator setting: name=value (e.g. h=1e-4)"),
        out_dir: Optional[str] = typer.Option(None, "--out", help="folder for the history file (default results/runs)"),
        as_json: bool = typer.Option(False, "--json", help="print one JSON record (stdout holds nothing else)"),
        run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of the run [s]"),
        force: bool = typer.Option(False, "--force", help="run even beyond the step-count / history-size limits")) -> None:
    """Run a scene with one integrator; write the time history; print a summary."""
    from daebench.harness.running.progress import RunProgress

    # the reporter starts first: loading the modules and kernels of a first run is not silent
    with RunProgress(scene, None) as bar:
        from daebench import api
        from daebench.harness.files import OutputWriteError
        from daebench.harness.running.checks import resolve_integrator
        from daebench.harness.running.deadline import RunTimeout, check_run_cap
        from daebench.core.params import parse_pairs

        sc = load_scene_or_exit(scene, set_)
        try:
            settings = parse_pairs(opt, "--opt", "h=1e-4")
            check_run_cap(run_cap)
            bar.retarget(f"{sc.name} with {resolve_integrator(integrator)}", sc.t_end)
            r = api.run(sc, integrator, settings=settings, write=True, out_dir=out_dir, run_cap=run_cap,
                        force=force, progress=bar)
        except OutputWriteError as exc:  # the run finished; its file could not be written
            fail(str(exc), 1)
        except ParamError as exc:
            fail(str(exc))
        except RunTimeout as exc:
            fail(f"{exc}; nothing was written (raise --run-cap, or use a larger step)", 1)
        except KeyboardInterrupt:
            fail("interrupted; nothing was written", 130)
        except Exception as exc:  # a plugin's bug during the run: say so, no traceback
            fail(f"the run raised {type(exc).__name__}: {exc} (a bug in integrator '{integrator}' or the model?)", 1)
    if as_json:
        sys.stdout.write(r.record.to_json() + "\n")
    else:
        for line in textout.kv_lines(run_summary(r)):
            out(line)
    if r.status != "completed":
        raise typer.Exit(1)


# ---- harness: references, sweeps, the paper ------------------------------------------------
def _floats(text: str | None, what: str) -> list[str] | None:
    if text is None:
        return None
    vals = [x.strip() for x in text.split(",") if x.strip()]
    if not vals:
        fail(f"{what} needs comma-separated numbers, e.g. {what} 1e-3,5e-4; got '{text}'")
    return vals


def _grid(items: list[str]) -> dict[str, list[str]]:
    grid: dict[str, list[str]] = {}
    for it in items:
        if "=" not in it:
            fail(f"--grid needs key=v1,v2,... (e.g. --grid alpha=0,-0.15); got '{it}'")
        k, v = it.split("=", 1)
        vals = [x.strip() for x in v.split(",") if x.strip()]
        if not vals:
            fail(f"--grid {k.strip()} has no values")
        if k.strip() in grid:
            fail(f"--grid {k.strip()} is given twice; put all its values in one --grid")
        grid[k.strip()] = vals
    return grid


@app.command()
def reference(scene: str = typer.Argument(..., help="scene name or path to a .toml file"),
              set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
              rtol: Optional[float] = typer.Option(None, "--rtol", help="IDA rtol (default 1e-11)"),
              atol: Optional[float] = typer.Option(None, "--atol", help="IDA atol (default rtol·1e-2)"),
              force: bool = typer.Option(False, "--force", help="recompute even if cached")) -> None:
    """Compute (or show) the cached reference of a scene: its trusted span, digits and check run."""
    from daebench import api
    from daebench.harness.files import OutputWriteError

    sc = load_scene_or_exit(scene, set_)
    try:
        ref = api.reference(sc, rtol=rtol, atol=atol, force=force, progress=True)
    except OutputWriteError as exc:
        fail(str(exc), 1)
    except ParamError as exc:
        fail(str(exc))
    except RuntimeError as exc:
        fail(str(exc), 1)
    out(f"reference: {ref.path}")
    out(f"{ref.describe()}, {ref.meta['wall_s']:.3g} s, {len(ref.impacts)} impacts"
        + (f" — a fine event-capturing run: {ref.meta.get('why')}" if ref.kind == "capturing" else ""))
    agr = ref.meta.get("agreement", {})
    worst = [f"{k} {v:.2e}" for k, v in agr.items() if k.startswith("err_") and k.endswith("_max") and v == v]
    if worst:
        out(f"agreement with the 10× looser check run ({agr.get('check', '')}): " + ", ".join(worst))
    from daebench.harness.references import accuracy

    for line in accuracy.summary_lines(ref.meta, ref.impacts, sc.t_end):
        out(line)
    from daebench.studies import ivptest

    if sc.model in ivptest.REFERENCES and abs(sc.t_end - ivptest.REFERENCES[sc.model].t_end) < 1e-12:
        dig = ivptest.reference_digits(sc.model, ref.history)
        out("digits at t_end against the IVP test set's published solution: "
            + ", ".join(f"{k} {v:.2f}" for k, v in dig.items()))


@app.command()
def bench(scene: str = typer.Argument(..., help="scene name or path to a .toml file"),
          integrators: str = typer.Option(..., "--integrators", "-i", help="comma-separated names, e.g. hht,baumgarte"),
          grid: list[str] = typer.Option([], "--grid", help="key=v1,v2,...: an integrator setting or a scene key"),
          steps: Optional[str] = typer.Option(None, "--steps", help="fixed steps h, e.g. 1e-3,5e-4"),
          tols: Optional[str] = typer.Option(None, "--tols", help="tolerances (adaptive runs), e.g. 1e-4,1e-6"),
          opt: list[str] = typer.Option([], "--opt", help="fixed integrator setting name=value for every run"),
          set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
          jobs: int = typer.Option(1, "--jobs", "-j", help="worker processes (a crashing run costs only its row)"),
          scheduler: Optional[str] = typer.Option(
              None, "--scheduler",
              help="run on Dask: a scheduler address (tcp://host:8786), or 'local' for a local cluster of --jobs workers"),
          ref_mode: str = typer.Option("require", "--reference",
                                       help="require (error if missing) | compute | auto (score if cached) | none"),
          repeats: int = typer.Option(3, "--repeats", help="timed runs after a warm-up, for runs under 1 s "
                                      "(min taken; 1: one cold run, no warm-up)"),
          name: Optional[str] = typer.Option(None, "--name", help="table name under results/bench/ (default: unique)"),
          resume: bool = typer.Option(False, "--resume", help="complete the interrupted sweep --name (same arguments)"),
          overwrite: bool = typer.Option(False, "--overwrite", help="replace the existing table --name"),
          run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of one run [s]"),
          force: bool = typer.Option(False, "--force", help="allow runs beyond the step-count limit")) -> None:
    """Sweep integrators × grid × steps/tols on a scene; one scored row per run, stored as it finishes."""
    from daebench import api
    from daebench.harness.sweeps import sweep as B
    from daebench.harness.files import OutputWriteError
    from daebench.harness.sweeps.options import Execution, Plan, Storage, Timing
    from daebench.core.params import parse_pairs

    sc = load_scene_or_exit(scene, set_)
    try:
        options = parse_pairs(opt, "--opt", "h_contact=1e-6") if opt else {}
        plan = Plan(integrators, steps=_floats(steps, "--steps"), tols=_floats(tols, "--tols"), grid=_grid(grid),
                    options=options, reference=ref_mode, force=force)
        df = api.bench(sc, plan=plan, timing=Timing.for_repeats(repeats, run_cap),
                       storage=Storage(name=name, resume=resume, overwrite=overwrite),
                       execution=Execution(jobs=jobs, scheduler=scheduler, progress=True))
    except OutputWriteError as exc:  # rows stored so far are kept; the message says how to finish
        fail(str(exc), 1)
    except ParamError as exc:
        fail(str(exc))
    except B.SweepInterrupted as exc:
        done = int((exc.table["status"] != "interrupted").sum())
        again = shlex.join(["daebench", *sys.argv[1:]] + ([] if name else ["--name", exc.name or "?"])
                           + ([] if resume else ["--resume"]))
        sys.stderr.write(f"interrupted: {done} of {len(exc.table)} runs finished; their rows are in {exc.path}\n"
                         f"continue with: {again}\n")
        raise typer.Exit(130)
    _bench_report(df, sc)
    bad = df[df["status"].isin(B.HARNESS_FAILURES)]
    if len(bad):
        sys.stderr.write(f"{len(bad)} run(s) gave no verdict ({', '.join(sorted(set(bad['status'])))}); "
                         f"see the 'message' column\n")
        raise typer.Exit(1)


def _bench_report(df: Any, sc: Any) -> None:
    """The sweep's table on stdout: the max error of each observable and point the model
    declares to be scored around impacts (else of its headline observable), energy and
    constraint residuals."""
    from daebench.harness.scoring import pipeline as scoring

    obs, pos = scoring.declared(sc.model).windowed(list(sc.get("output.observables") or []))
    errs = [f"err_{d.score_name}_max" for d in (*obs, *pos)] or [f"err_{scoring.headline(sc).score_name}_max"]
    cols = [c for c in ("label", "h", "tol", "status", "wall_s", "steps", *errs, "energy_resid_max", "Cdot_max")
            if c in df.columns]
    print_table(cols, [[r[c] for c in cols] for _, r in df.iterrows()], f"{sc.name}: {len(df)} runs")
    if "path" in df.attrs:
        out(f"table: {df.attrs['path']}")


@app.command()
def paper(quick: bool = typer.Option(False, "--quick", help="reduced grid for CI (N=3, t_end 0.5 s, h_contact 1e-5)"),
          jobs: int = typer.Option(1, "--jobs", "-j", help="worker processes"),
          out_dir: Optional[str] = typer.Option(None, "--out", help="output folder (default results/paper)"),
          run_cap: Optional[float] = typer.Option(None, "--run-cap",
                                                  help="wall-time cap of one run [s] (default 60 with --quick)"),
          variant: str = typer.Option("both", "--variant",
                                      help="published (beam-impact, h = 1e-4 s) | calibrated (beam-impact-hub, "
                                           "h = 2.5e-5 s) | both")) -> None:
    """Regenerate the beam-impact study (HHT-α vs Baumgarte, Acta Physica Sinica 2017): Table 1
    beside the published seconds, one figure and one computed verdict per claim, for the
    published setting and for the calibrated variant (hub inertia and step at which this
    model shows the paper's stability pattern; see cases/beam-impact-hub.toml)."""
    from daebench.studies import paper as P

    names = ["quick"] if quick else (list(P.VARIANTS) if variant == "both" else [variant])
    if not quick and any(v not in P.VARIANTS for v in names):
        fail(f"unknown --variant '{variant}'; choose one of {', '.join(P.VARIANTS)} or both")
    for name in names:
        folder = None if out_dir is None else (Path(out_dir) if len(names) == 1 else Path(out_dir) / name)
        try:
            res = P.run_paper(quick=quick, jobs=jobs, out=folder, run_cap=run_cap, variant=name)
        except ParamError as exc:
            fail(str(exc))
        out(f"== {name} variant: {P.VARIANTS[name]().setting() if name in P.VARIANTS else 'quick grid'} ==")
        out(res.table_md)
        for v in res.verdicts:
            out(v)
        out(f"outputs in {res.folder}")


@app.command()
def perf(quick: bool = typer.Option(False, "--quick", help="tiny sizes (smoke test), no Table 1 grid"),
         jobs: int = typer.Option(2, "--jobs", "-j", help="worker processes for the Table 1 grid"),
         table: bool = typer.Option(True, "--table/--no-table", help="time the 24-run Table 1 grid"),
         exudyn: bool = typer.Option(True, "--exudyn/--no-exudyn", help="compare with Exudyn when installed"),
         out_dir: Optional[str] = typer.Option(None, "--out", help="output folder (default results/perf)")) -> None:
    """Speed figures in one run (Table 1 grid vs the published seconds, per-step scaling in N,
    Exudyn side by side, adaptive steps), steps/s per integrator; writes results/perf/."""
    from daebench.studies import perf as P

    s = P.PerfSettings.quick() if quick else P.PerfSettings(jobs=jobs)
    if not table:
        s.table = False
    s.exudyn = exudyn
    res = P.run_perf(s, out_dir)
    out(P.markdown(res))
    out(f"written: {res['folder']}/perf.json, perf.md")


from daebench.cli import compare as cli_compare, capture as cli_eventcapture, plot as cli_plot, seed003 as cli_seed003, stability as cli_stability  # noqa: E402  (study commands)
from daebench.cli import survey as cli_survey  # noqa: E402  (survey, report, effects)
from daebench.cli import compile_report as cli_compile_report  # noqa: E402

app.add_typer(cli_plot.plot_app, name="plot")
cli_seed003.register(app)
cli_stability.register(app)
cli_compare.register(app)
cli_eventcapture.register(app)
cli_survey.register(app)
cli_compile_report.register(app)


def main() -> None:  # pragma: no cover
    try:
        app()
    except KeyboardInterrupt:
        sys.stderr.write("interrupted\n")
        sys.exit(130)


if __name__ == "__main__":  # pragma: no cover
    main()
