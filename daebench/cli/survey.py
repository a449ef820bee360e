"""`daebench survey` (every case's protocol within a budget: cost to reach targets,
performance profiles, recommendations), `daebench report NAME` (one HTML page) and
`daebench effects CASE` (what each switchable effect costs)."""

from __future__ import annotations

import shlex
import sys
import time
from pathlib import Path
from typing import Optional

import typer

from daebench.core.params import ParamError


def _print_survey(res) -> None:
    from daebench.cli.common import out, print_table
    from daebench.workflows import survey as S

    for r in res.cases:
        st = r.table["status"].value_counts().to_dict() if len(r.table) else {}
        out(f"{r.case}: {len(r.table)} runs ({', '.join(f'{v} {k}' for k, v in st.items())}), "
            f"{r.rounds_run}/{r.rounds} rounds, {r.wall_s:.1f} s" + (f"; {r.note}" if r.note else ""))
    if len(res.profile):
        cols = ["measure", "target", "setting", "cases", "rho_1", "rho_4", "rho_inf"]
        print_table(cols, [[x[c] for c in cols] for _, x in res.profile.iterrows()],
                    "performance profiles (wall time): ρ(1) cheapest, ρ(4) within 4×, ρ(∞) reached")
    out("")
    for p in res.paragraphs.values():
        out(p)
        out("")
    for m in S.mismatches(res):
        sys.stderr.write(f"DETERMINISM: {m['case']} run {m['run']} ({m['label']}): digest {m['digest'][:12]} in the "
                         f"sweep, {str(m['repeat'])[:12]} when repeated\n")


def register(app: typer.Typer) -> None:
    """Add `daebench survey`, `daebench report` and `daebench effects` to ``app``."""

    @app.command("survey")
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
               scheduler: Optional[str] = typer.Option(None, "--scheduler",
                                                       help="run on Dask: 'local' or tcp://host:8786"),
               target: list[str] = typer.Option([], "--target",
                                                help="MEASURE=v1,v2: target errors in the measure's units "
                                                     "(default: decades of the errors reached)"),
               name: Optional[str] = typer.Option(None, "--name", help="survey name (default: unique)"),
               resume: bool = typer.Option(False, "--resume", help="complete the survey --name (same arguments)"),
               overwrite: bool = typer.Option(False, "--overwrite", help="replace the survey --name"),
               run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of one run [s]"),
               reference: str = typer.Option("compute", "--reference", help="compute | require | auto | none"),
               report: bool = typer.Option(False, "--report", help="also write the HTML report page")) -> None:
        """Run the protocol of every case within a per-case budget; print the performance profiles and a
        recommendation per case; write results/survey/<name>/ (table, reach = cost to reach each target,
        profiles, recommendations)."""
        from daebench.cli.common import fail, out
        from daebench.harness.analysis import costs
        from daebench.harness.sweeps import sweep as B
        from daebench.workflows import survey as S

        t0 = time.perf_counter()
        try:
            opts = S.SurveyOptions(cases=tuple(c.strip() for c in cases.split(",") if c.strip()) if cases else (),
                                   integrators=tuple(i.strip() for i in integrators.split(",") if i.strip())
                                   if integrators else (), quick=quick, budget_s=budget, jobs=jobs, scheduler=scheduler,
                                   name=name, resume=resume, overwrite=overwrite, run_cap=run_cap,
                                   targets=costs.parse_targets(target) or None, reference=reference)
            res = S.run_survey(opts)
        except ParamError as exc:
            fail(str(exc))
        except B.SweepInterrupted as exc:
            again = shlex.join(["daebench", *sys.argv[1:]] + ([] if name else ["--name", exc.name or "?"])
                               + ([] if resume else ["--resume"]))
            sys.stderr.write(f"interrupted; the finished rows are stored. continue with: {again}\n")
            raise typer.Exit(130)
        _print_survey(res)
        if report:
            from daebench.workflows import report as R

            res.files.append(R.write_survey_report(res))
        out(f"written: {res.folder} ({', '.join(p.name for p in res.files)})")
        pool = f"; {res.workers_started} worker process(es) for every case and round" \
            if res.workers_started is not None else ""
        out(f"wall time of the survey: {time.perf_counter() - t0:.1f} s (name {res.name}; "
            f"resume with --resume --name {res.name}{pool})")
        bad = res.table[res.table["status"].isin(("error", "crashed"))] if len(res.table) else res.table
        if len(bad) or S.mismatches(res):
            raise typer.Exit(1)

    @app.command("report")
    def report(name: str = typer.Argument(..., help="a survey name (results/survey/<name>/)"),
               out_path: Optional[str] = typer.Option(None, "--out", help="the HTML file (default: in the survey)"),
               compact: bool = typer.Option(False, "--compact",
                                            help="a small page: no per-case work–precision figures, the profile "
                                                 "figure scaled down, tables without digests and messages")
               ) -> None:
        """Write one self-contained HTML page of a survey: recommendations, sortable tables, figures,
        the reference's trusted span where known, provenance."""
        from daebench.cli.common import fail, out
        from daebench.workflows import report as R

        try:
            res = R.load_survey(name)
            path = R.write_survey_report(res, Path(out_path) if out_path else None, compact=compact)
        except ParamError as exc:
            fail(str(exc))
        out(f"written: {path} ({path.stat().st_size / 1e3:.0f} kB)")

    @app.command("effects")
    def effects(case: str = typer.Argument(..., help="scene name or path to a .toml file"),
                integrator: str = typer.Option("hht", "--integrator", "-i", help="integrator of every run"),
                opt: list[str] = typer.Option([], "--opt", help="integrator setting name=value"),
                set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
                out_dir: Optional[str] = typer.Option(None, "--out", help="output folder (default results/effects)"),
                ) -> None:
        """Run the case with each switchable effect (effects.* = true) turned off in turn: the change of
        every observable (max |Δ| against the all-on run) and of the cost (wall time, steps)."""
        from daebench.cli.common import fail, load_scene_or_exit, out, print_table
        from daebench.core.params import parse_pairs
        from daebench.workflows import effects as E

        sc = load_scene_or_exit(case, set_)
        try:
            options = parse_pairs(opt, "--opt", "h=1e-4") if opt else {}
            res = E.run_effects(sc, integrator, options, Path(out_dir) if out_dir else None, progress=True)
        except ParamError as exc:
            fail(str(exc))
        cols, rows = E.table_rows(res.table)
        print_table(cols, rows, f"{sc.name}: each effect off in turn ({integrator})")
        out(f"written: {', '.join(str(p) for p in res.files)}")
