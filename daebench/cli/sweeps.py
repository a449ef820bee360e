"""The commands of many runs (:mod:`daebench.api.sweeps`): `daebench bench` (a sweep),
`compare` (every applicable integrator at a case's protocol), `survey` (every case within
a budget), `report` (a survey's HTML page), `effects` (what each switchable effect costs)
and `stability` (the largest stable step, measured and predicted)."""

from __future__ import annotations

import shlex
import sys
import time
from typing import Any, Optional

import typer

from daebench.cli import textout
from daebench.cli.common import fail, floats, load_scene_or_exit, out, print_table, refusals
from daebench.api.sweeps import COMPARE_BUDGET_S as DEFAULT_BUDGET_S


def register(app: typer.Typer) -> None:
    """Add `daebench bench`, `compare`, `survey`, `report`, `effects` and `stability` to ``app``."""
    for name, fn in (("bench", bench), ("compare", compare), ("survey", survey), ("report", report),
                     ("effects", effects), ("stability", stability)):
        app.command(name)(fn)


def _again(name: Optional[str], resume: bool, exc: Any) -> str:
    """The command that continues an interrupted sweep."""
    return shlex.join(["daebench", *sys.argv[1:]] + ([] if name else ["--name", exc.name or "?"])
                      + ([] if resume else ["--resume"]))


#: --no-workers-timeout: its default (None: the executor's, a minute) and help (bench and survey)
NO_WORKERS_HELP = (None, "seconds a Dask cluster may have no worker while runs wait (default 60); then the "
                         "sweep stops, its runs in flight interrupted (--resume runs them)")


def _no_workers(seconds: Optional[float]) -> dict[str, float]:
    return {} if seconds is None else {"no_workers_timeout": seconds}


def _cluster_lost(exc: Any, name: Optional[str], resume: bool) -> None:
    """A lost Dask scheduler or a cluster without workers: one line, what was kept, how to go on; exit 1."""
    table = exc.table
    kept = ""
    if table is not None and len(table):
        done = int((table["status"] != "interrupted").sum())
        kept = f"; {done} of {len(table)} runs finished" + (f", their rows are in {exc.path}" if exc.path else "")
    sys.stderr.write(f"{exc}{kept}\ncontinue with: {_again(name, resume, exc)}\n")
    raise typer.Exit(1)


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
          no_workers_timeout: Optional[float] = typer.Option(
              NO_WORKERS_HELP[0], "--no-workers-timeout", help=NO_WORKERS_HELP[1]),
          ref_mode: str = typer.Option("require", "--reference",
                                       help="require (error if missing) | compute | auto (score if cached) | none "
                                            "(no reference: runs are scored only against a model's exact solution)"),
          repeats: int = typer.Option(3, "--repeats", help="timed runs after a warm-up, for runs under 1 s "
                                      "(min taken; 1: one cold run, no warm-up)"),
          name: Optional[str] = typer.Option(None, "--name", help="table name under results/bench/ (default: unique)"),
          resume: bool = typer.Option(False, "--resume", help="complete the interrupted sweep --name (same arguments)"),
          overwrite: bool = typer.Option(False, "--overwrite", help="replace the existing table --name"),
          run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of one run [s]"),
          force: bool = typer.Option(False, "--force", help="allow runs beyond the step-count limit"),
          show_traceback: bool = typer.Option(False, "--traceback", help="print where each 'error' row's exception "
                                              "was raised (the integrator's frames included) on stderr")) -> None:
    """Sweep integrators × grid × steps/tols on a scene; one scored row per run, stored as it finishes."""
    from daebench import api

    sc = load_scene_or_exit(scene, set_)
    try:
        with refusals():
            settings = api.parse_pairs(opt, "--opt", "h_contact=1e-6") if opt else {}
            plan = api.Plan(integrators, steps=floats(steps, "--steps"), tols=floats(tols, "--tols"), grid=_grid(grid),
                            options=settings, force=force)
            options = api.SweepOptions(reference=ref_mode, timing=api.Timing.for_repeats(repeats, run_cap),
                                       storage=api.Storage(name=name, resume=resume, overwrite=overwrite),
                                       execution=api.Execution(jobs=jobs, scheduler=scheduler, progress=True,
                                                               **_no_workers(no_workers_timeout)))
            try:
                df = api.bench(sc, plan=plan, options=options)
            except api.ClusterLost as exc:
                _cluster_lost(exc, name, resume)
    except api.SweepInterrupted as exc:
        done = int((exc.table["status"] != "interrupted").sum())
        sys.stderr.write(f"interrupted: {done} of {len(exc.table)} runs finished; their rows are in {exc.path}\n"
                         f"continue with: {_again(name, resume, exc)}\n")
        raise typer.Exit(130)
    _bench_report(df, sc, api.error_columns(sc))
    bad = df[df["status"].isin(api.HARNESS_FAILURES)]
    if len(bad):
        if show_traceback and "traceback" in bad:
            for _, r in bad[bad["traceback"].notna()].iterrows():
                sys.stderr.write(f"run {r['run']} ({r['label']}):\n{r['traceback']}")
        sys.stderr.write(f"{len(bad)} run(s) gave no verdict ({', '.join(sorted(set(bad['status'])))}); "
                         f"see the 'message' column" + ("" if show_traceback else " (and `--traceback`)") + "\n")
        raise typer.Exit(1)


def _bench_report(df: Any, sc: Any, errs: list[str]) -> None:
    """The sweep's table on stdout: the max error of each observable and point the model
    declares to be scored around impacts (else of its headline observable), energy and
    constraint residuals."""
    cols = [c for c in ("label", "h", "tol", "status", "wall_s", "steps", *errs, "energy_resid_max", "Cdot_max")
            if c in df.columns]
    print_table(cols, [[r[c] for c in cols] for _, r in df.iterrows()], f"{sc.name}: {len(df)} runs")
    if "path" in df.attrs:
        out(f"table: {df.attrs['path']}")


def compare(case: str = typer.Argument(..., help="scene name or path to a .toml file"),
            set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
            jobs: int = typer.Option(2, "--jobs", "-j", help="worker processes"),
            reference: str = typer.Option("compute", "--reference",
                                          help="compute (when missing, with a progress bar) | require | auto | none "
                                               "(no reference: runs are scored only against a model's exact solution)"),
            run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of one run [s]"),
            out_dir: Optional[str] = typer.Option(None, "--out",
                                                  help="output folder (default `results/compare/<case>-<hash>`)"),
            json_out: bool = typer.Option(False, "--json", help="print the table as JSON records only"),
            report_page: bool = typer.Option(False, "--report",
                                             help="also write report.html (one self-contained page) in the folder"),
            include: list[str] = typer.Option([], "--include",
                                              help="another code's trajectory (CSV/Parquet, as for `daebench score`), "
                                                   "scored beside the runs and marked external; repeatable"),
            budget: float = typer.Option(DEFAULT_BUDGET_S, "--budget",
                                         help="wall time [s] for extending each method's series (h/2, tol/10) until "
                                              f"every target is decided; default {DEFAULT_BUDGET_S:g} s; 0: the "
                                              "protocol's runs only"),
            peers: Optional[str] = typer.Option(None, "--peers",
                                                help="peer codes run on the case in this same run and included, "
                                                     "comma-separated: siconos-mj, siconos-ed, exudyn-ga "
                                                     "(`daebench peer`)"),
            peer_steps: Optional[str] = typer.Option(None, "--peer-steps",
                                                     help="the peers' fixed steps [s], comma-separated (default: "
                                                          "each peer's own for the case)")) -> None:
    """Run every applicable integrator at the case's protocol and score each run against the reference.

    The protocol is the case's own (its scene file's [compare] table), else one run each at the defaults. Prints one
    table of the runs and the recommendation per target, and writes the table and the work-precision
    figure."""
    from daebench import api

    sc = load_scene_or_exit(case, set_)
    t0 = time.perf_counter()
    try:
        options = api.SweepOptions(reference=reference, timing=api.Timing(run_cap=run_cap),
                                   execution=api.Execution(jobs=jobs, progress=True))
        res = api.compare(sc, options, out=out_dir, report=report_page, include=include, budget=budget,
                          peers=[x.strip() for x in (peers or "").split(",") if x.strip()],
                          peer_steps=floats(peer_steps, "--peer-steps"))
    except KeyboardInterrupt as exc:  # during the runs, or after them (scoring, figures): said, never silent
        done = exc.table if isinstance(exc, api.SweepInterrupted) else None
        kept = (f"{int((done['status'] != 'interrupted').sum())} of {len(done)} runs had finished; "
                if done is not None else "")
        fail(f"interrupted (Ctrl-C or SIGTERM); {kept}the comparison's table and figures were not written: "
             f"run the command again", 130)
    except api.OutputWriteError as exc:  # the work is done: show it, say what was not saved, exit 1
        if exc.result is not None:
            _compare_table(exc.result, sc)
        fail(str(exc), 1)
    except api.ParamError as exc:
        fail(str(exc))
    except api.PeerFailed as exc:   # a peer's process failed before the runs: its own words
        fail(str(exc), 1)
    if json_out:
        sys.stdout.write(res.as_json() + "\n")
    else:
        _compare_table(res, sc)
        for line in res.summary_lines():
            out(line)
        out(f"written: {', '.join(str(p) for p in res.files if p.suffix in ('.png', '.csv'))}")
    if res.page is not None:
        (sys.stderr.write if json_out else out)(f"report page: {res.page}" + ("\n" if json_out else ""))
    if not json_out:
        out(f"wall time of the comparison: {time.perf_counter() - t0:.1f} s")
    for line in res.changed:   # a run whose history differs from its last time
        sys.stderr.write(line + "\n")
    if len(res.failures):
        sys.stderr.write(f"{len(res.failures)} run(s) gave no verdict; see the 'message' column\n")
    if not res.ok:
        raise typer.Exit(1)


def _compare_table(res: Any, sc: Any) -> None:
    """The runs as one table, then the recommendation as a small one."""
    for line in textout.kv_lines([("compare", res.heading(sc.name))]):
        out(line)
    cols, rows = res.table_rows()
    for line in textout.rich_lines(cols, rows):
        out(line)
    if any("*" in str(r[-2]) for r in rows):
        for line in textout.kv_lines([("order", "observed order of the first measure against the next coarser "
                                       "run; * outside the asymptotic regime (errors not falling, or far from "
                                       "the declared order)")]):
            out(line)
    cols, rows = res.recommendation_rows()
    if not rows:
        out("recommendation: none (no run was scored on the protocol's measures)")
        return
    out("")
    for line in textout.kv_lines([("recommendation", "cost = CPU time to reach the target; a setting qualifies "
                                   "when it and its finer runs reach it, none failed, and the observed order is "
                                   "positive")]):
        out(line)
    for line in textout.rich_lines(cols, rows, prose={"target": 14, "pick": 14, "runner-up": 12, "why": 28}):
        out(line)


def _print_survey(res: Any) -> None:
    for r in res.cases:
        st = r.table["status"].value_counts().to_dict() if len(r.table) else {}
        out(f"{r.case}: {len(r.table)} runs ({', '.join(f'{v} {k}' for k, v in st.items())}), "
            f"{r.rounds_run}/{r.rounds} rounds, {r.wall_s:.1f} s" + (f"; {r.note}" if r.note else ""))
    if len(res.profile):
        from daebench import api  # lazy: the API loads the harness; only when a survey is printed

        cols = ["measure", "target", "setting", "cases", "ρ(1)", "ρ(4)", "ρ(∞)"]
        rows = [[api.describe_measure(x["measure"]).name, x["target"], x["setting"], x["cases"], x["rho_1"],
                 x["rho_4"], x["rho_inf"]] for _, x in res.profile.iterrows()]
        out("performance profiles (CPU time at which a setting qualifies): ρ(1) the cheapest, ρ(4) within 4×, "
            "ρ(∞) qualifies at all")
        for line in textout.rich_lines(cols, rows, prose={"measure": 24}):
            out(line)
    out("")
    for p in res.paragraphs.values():
        out(p)
        out("")
    for m in res.mismatches():
        sys.stderr.write(f"DETERMINISM: {m['case']} run {m['run']} ({m['label']}): digest {m['digest'][:12]} in the "
                         f"sweep, {str(m['repeat'])[:12]} when repeated\n")


def _names(text: Optional[str]) -> tuple[str, ...]:
    return tuple(x.strip() for x in text.split(",") if x.strip()) if text else ()


def survey(cases: Optional[str] = typer.Option(None, "--cases", help="comma-separated case names (default: all)"),
           integrators: Optional[str] = typer.Option(None, "--integrators", "-i",
                                                     help="only these integrators (default: every registered one)"),
           quick: bool = typer.Option(False, "--quick",
                                      help="reduced protocol for CI: pendulum, ball, spring-wall; t_end ≤ 0.5 s; "
                                           "each integrator at its default step and one halving"),
           budget: Optional[float] = typer.Option(None, "--budget",
                                                  help="seconds per case (default 300, 30 with --quick); rounds "
                                                       "of halved steps beyond it are 'skipped-budget' rows"),
           jobs: int = typer.Option(2, "--jobs", "-j", help="worker processes (or Dask workers)"),
           scheduler: Optional[str] = typer.Option(None, "--scheduler", help="run on Dask: 'local' or tcp://host:8786"),
           no_workers_timeout: Optional[float] = typer.Option(
               NO_WORKERS_HELP[0], "--no-workers-timeout", help=NO_WORKERS_HELP[1]),
           target: list[str] = typer.Option([], "--target",
                                            help="MEASURE=v1,v2: target errors in the measure's units "
                                                 "(default: decades of the errors reached)"),
           name: Optional[str] = typer.Option(None, "--name", help="survey name (default: unique)"),
           resume: bool = typer.Option(False, "--resume", help="complete the survey --name (same arguments)"),
           overwrite: bool = typer.Option(False, "--overwrite", help="replace the survey --name"),
           run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of one run [s]"),
           reference: str = typer.Option("compute", "--reference",
                                         help="compute | require | auto | none (no reference: runs are scored only "
                                              "against a model's exact solution)"),
           report_page: bool = typer.Option(False, "--report", help="also write the HTML report page")) -> None:
    """Run the protocol of every case within a budget; print profiles and recommendations.

    Prints the performance profiles and a recommendation per case; writes
    `results/survey/<name>/` (table, reach = cost to reach each target, profiles,
    recommendations)."""
    from daebench import api

    t0 = time.perf_counter()
    try:
        with refusals():
            opts = api.SurveyOptions(cases=_names(cases), integrators=_names(integrators), quick=quick,
                                     budget_s=budget, jobs=jobs, scheduler=scheduler, name=name, resume=resume,
                                     overwrite=overwrite, run_cap=run_cap, targets=api.parse_targets(target),
                                     reference=reference, no_workers_timeout=no_workers_timeout)
            try:
                res = api.survey(opts, report=report_page)
            except api.ClusterLost as exc:
                _cluster_lost(exc, name, resume)
    except api.SweepInterrupted as exc:
        sys.stderr.write(f"interrupted; the finished rows are stored. continue with: {_again(name, resume, exc)}\n")
        raise typer.Exit(130)
    _print_survey(res)
    out(f"written: {res.folder} ({', '.join(p.name for p in res.files)})")
    pool = f"; {res.workers_started} worker process(es) for every case and round" \
        if res.workers_started is not None else ""
    out(f"wall time of the survey: {time.perf_counter() - t0:.1f} s (name {res.name}; "
        f"resume with --resume --name {res.name}{pool})")
    if not res.completed:
        sys.stderr.write(f"no run of the survey completed ({len(res.table)} runs): nothing was judged"
                         + (f"; see the 'message' column of {res.folder / 'table.csv'}" if len(res.table) else "")
                         + "\n")
    if not res.ok:
        raise typer.Exit(1)


def report(name: str = typer.Argument(..., help="a survey name (`results/survey/<name>/`)"),
           out_path: Optional[str] = typer.Option(None, "--out", help="the HTML file (default: in the survey)"),
           compact: bool = typer.Option(False, "--compact",
                                        help="a small page: no per-case work–precision figures, the profile "
                                             "figure scaled down, tables without digests and messages")) -> None:
    """Write one self-contained HTML page of a survey.

    Recommendations, sortable tables, figures, the reference's trusted span where known,
    provenance."""
    from daebench import api

    with refusals():
        path = api.report(name, out_path, compact=compact)
    out(f"written: {path} ({path.stat().st_size / 1e3:.0f} kB)")


def effects(case: str = typer.Argument(..., help="scene name or path to a .toml file"),
            integrator: str = typer.Option("hht", "--integrator", "-i", help="integrator of every run"),
            opt: list[str] = typer.Option([], "--opt", help="integrator setting name=value"),
            set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
            out_dir: Optional[str] = typer.Option(None, "--out", help="output folder (default results/effects)")) -> None:
    """Run a case with each switchable effect turned off in turn and report what changes.

    Each effect that is on (effects.* = true) is switched off once: the change of every
    observable (max |Δ| against the all-on run) and of the cost (wall time, steps)."""
    from daebench import api

    sc = load_scene_or_exit(case, set_)
    with refusals():
        settings = api.parse_pairs(opt, "--opt", "h=1e-4") if opt else {}
        res = api.effects(sc, integrator, settings, out=out_dir, options=api.SweepOptions())
    cols, rows = res.table_rows()
    print_table(cols, rows, f"{sc.name}: each effect off in turn ({integrator})")
    out(f"written: {', '.join(str(p) for p in res.files)}")


def stability(case: str = typer.Argument(..., help="scene name or path to a .toml file"),
              method: Optional[list[str]] = typer.Option(None, "--method", "-m",
                                                         help="integrator:setting=value,... (repeat for each; "
                                                              "default: the beam-impact paper's settings and four "
                                                              "Newmark-family members)"),
              n: str = typer.Option("auto", "--n",
                                    help="values of --n-key, comma-separated; '' = the scene's own; auto = "
                                         "3,5,7,9 if the scene has --n-key"),
              n_key: str = typer.Option("discretization.n", "--n-key", help="the scene key N stands for"),
              set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
              t_end: float = typer.Option(0.0, "--t-end",
                                          help="run length of each trial, s (0: --periods of the fastest mode, "
                                               "capped at the scene's t_end)"),
              periods: float = typer.Option(80.0, "--periods",
                                            help="trial length in periods of the fastest mode (with --t-end 0)"),
              h_min: float = typer.Option(1e-6, "--h-min", help="lower bisection bound, s"),
              h_max: float = typer.Option(1e-2, "--h-max", help="upper bisection bound, s"),
              tol: float = typer.Option(0.02, "--tol", help="relative width of the final bracket"),
              jobs: int = typer.Option(1, "--jobs", "-j", help="worker processes"),
              run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of one run, s"),
              mark_h: float = typer.Option(0.0, "--mark-h", help="draw this step as a line, s (0: none)"),
              whole_run: bool = typer.Option(True, "--whole-run/--trials-only",
                                             help="bisect a second time on runs over the scene's whole horizon"),
              out_dir: Optional[str] = typer.Option(None, "--out", help="output folder (default results/stability)"),
              name: Optional[str] = typer.Option(None, "--name", help="file stem (default `<case>-stability`)"),
              overwrite: bool = typer.Option(False, "--overwrite",
                                             help="replace the files of an earlier map of the same --name")) -> None:
    """Measure the largest stable fixed step per integrator setting and N beside its prediction.

    Bisection on trial runs (completed, energy balance within the divergence threshold),
    and again on runs over the scene's whole horizon, each beside its linear prediction
    (start frequencies × the method's computed stability interval)."""
    from daebench import api

    with refusals():
        sc = api.load_scene(case, set_)
        search = api.Bisection(n_key, t_end if t_end != 0.0 else None, periods, h_min, h_max, tol, jobs, run_cap,
                               mark_h or None, whole_run)
        res = api.stability(sc, method or None, n, search, out=out_dir, name=name,
                            progress=lambda line: sys.stderr.write(line + "\n"), overwrite=overwrite)
    typer.echo(res.markdown)
    typer.echo(f"\n{res.summary}")
    typer.echo("wrote " + ", ".join(map(str, res.files)))

