"""`daebench survey`: the protocol of every case, within a per-case budget, one table of
the cost to reach a few target errors, performance profiles and a recommendation.

**Protocols.** An integrator that declares runs for a case (its ``protocol``, as `daebench
compare` reads it) runs them; every other integrator runs at its default settings and two halvings
(:func:`halvings`: h, h/2, h/4 for a fixed-step method; an adaptive-only method at its
default rtol, /10, /100 — halving a tolerance moves the error by less than its
run-to-run scatter, a decade is the adaptive analogue of a halving). Integrators the case
refuses are listed with their reason, as in `compare`.

**Budget.** A case's runs go in rounds of refinement: round k holds the k-th step (or
tolerance) of every setting. The first round always runs; a later round runs only if the
time spent on the case so far plus :data:`ROUND_GROWTH` × the last round's wall time (a
halved step costs about twice as much) fits the budget. The runs of rounds left out are
rows with status ``skipped-budget`` (not stored; a resume counts the rounds' times already
spent, ``<store>.rounds.json``, so it runs no more of them: the survey is the one planned,
and a larger ``--budget`` is a new survey). The time to compute a missing reference is not counted. A single run is
capped (``timeout`` row) at ``run_cap``, by default the budget but at least
:data:`MIN_RUN_CAP_S` (a cold numba compile takes 30–90 s, minutes on a loaded machine;
a worker killed while compiling leaves nothing in the cache, so the next run compiles again).

**Workers.** One set of workers serves the whole survey (:func:`workers`): the same
``jobs`` worker processes run every case and every round, so a worker loads each kernel
once (``workers_started`` in ``survey.json``: ``jobs`` unless a worker crashed or was
killed); under ``--scheduler`` one Dask client and its workers.

**Resumable.** Each case's rows go to its own row store
(``results/survey/<name>/runs/<name>--<case>.rows.sqlite``,
:class:`daebench.harness.sweeps.store.SweepStore`) as they finish; ``resume`` with the same
name runs only the missing rows, and only as the survey was planned: ``--resume`` with other
cases, integrators, budget, targets or reference mode is refused naming the difference
(:mod:`daebench.workflows.survey_plan`). A target of a measure no case is scored on is
refused before anything runs; a survey in which no run completed fails (``ok`` is False).

**Determinism.** Where rows carry a history ``digest`` (:mod:`daebench.harness.sweeps.digest`),
the cheapest completed run of each case is repeated in this process and its digest
compared with the worker's; a mismatch is reported and kept in ``survey.json``.
"""

from __future__ import annotations

import json
import math
import time
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import Scene, scene_names, tagged
from daebench.harness.analysis import costs, evidence, profiles, recommend
from daebench.harness.files import atomic_write, jsonable, results_dir
from daebench.harness.references import fingerprints
from daebench.harness.references.reference import load_reference
from daebench.harness.running import provenance
from daebench.integrators import registry as integrator_registry
from daebench.harness.running.progress import run_progress_factory
from daebench.harness.sweeps import dask_cluster, executors, sweep
from daebench.harness.sweeps.row import execute, outcome_row
from daebench.harness.sweeps.options import Execution, SweepOptions, Timing
from daebench.harness.sweeps.plan import RunSpec
from daebench.harness.sweeps.store import StoreError, SweepStore, assemble, check_name, unique_name
from daebench.workflows import compare, survey_plan
from daebench.workflows.survey_protocol import (FALLBACK_SUFFIX, LEVELS, QUICK_LEVELS, QUICK_T_END,  # noqa: F401
                                                case_measures, case_scene, halvings, rounds, survey_protocol)
from daebench.workflows.compare import Protocol

DEFAULT_BUDGET_S = 300.0   # per case
QUICK_BUDGET_S = 30.0
QUICK_REPEATS = 1          # --quick: one timed run after the warm-up (the full survey: the sweep's rule)
MIN_RUN_CAP_S = 600.0     # default cap of one run: the budget, at least this (a cold compile: 30-90 s, minutes under load)
ROUND_GROWTH = 2.0         # predicted cost of the next round of halved steps / the last round's
SKIPPED = "skipped-budget"


@dataclass(frozen=True)
class SurveyOptions:
    """What a survey runs and how (defaults: every case, 2 workers, 300 s a case)."""

    cases: tuple[str, ...] = ()
    integrators: tuple[str, ...] = ()       # only these (default: every registered one)
    quick: bool = False
    budget_s: float | None = None
    jobs: int = 2
    scheduler: Any = None
    name: str | None = None
    resume: bool = False
    overwrite: bool = False
    run_cap: float | None = None
    targets: Mapping[str, Sequence[float]] | None = None
    reference: str = "compute"
    progress: bool = True
    repeat_check: bool = True
    folder: Path | None = None
    no_workers_timeout: float | None = None   # s a Dask cluster may have no worker (None: the executor's default)

    @property
    def repeats(self) -> int | None:
        """Timed runs after the warm-up: :data:`QUICK_REPEATS` under ``quick``, else the sweep's rule."""
        return QUICK_REPEATS if self.quick else None

    def sweep_options(self, reference: str, run_cap: float | None) -> SweepOptions:
        """The options of a case's sweep: scored under ``reference``, each run capped at ``run_cap``."""
        timing = Timing(run_cap=run_cap) if self.repeats is None else Timing(repeats=self.repeats, run_cap=run_cap)
        wait = {} if self.no_workers_timeout is None else {"no_workers_timeout": self.no_workers_timeout}
        return SweepOptions(reference=reference, timing=timing,
                            execution=Execution(jobs=self.jobs, scheduler=self.scheduler, progress=self.progress,
                                                **wait))

    @property
    def budget(self) -> float:
        b = self.budget_s if self.budget_s is not None else (QUICK_BUDGET_S if self.quick else DEFAULT_BUDGET_S)
        if not (isinstance(b, (int, float)) and math.isfinite(b) and b > 0):
            raise ParamError(f"--budget must be a positive number of seconds per case, got {b!r}")
        return float(b)


@dataclass
class CaseResult:
    """One case: its rows (stored and skipped), the refused integrators, the measures."""

    case: str
    table: pd.DataFrame
    refused: dict[str, str]
    measures: list[str]
    wall_s: float
    rounds_run: int
    rounds: int
    note: str = ""
    repeat: dict[str, Any] = field(default_factory=dict)


@dataclass
class SurveyResult:
    name: str
    folder: Path
    table: pd.DataFrame
    reach: pd.DataFrame
    profile: pd.DataFrame
    paragraphs: dict[str, str]
    cases: list[CaseResult]
    wall_s: float
    files: list[Path] = field(default_factory=list)
    workers_started: int | None = None   # worker processes started over the survey (None: on Dask)
    records: dict[str, list[dict[str, Any]]] = field(default_factory=dict)   # the recommendations per case

    @property
    def failures(self) -> pd.DataFrame:
        """The rows of runs that gave no verdict for a reason of their own (error, crashed)."""
        return self.table[self.table["status"].isin(("error", "crashed"))] if len(self.table) else self.table

    @property
    def completed(self) -> int:
        """How many runs completed (a survey without one has judged nothing)."""
        return int((self.table["status"] == "completed").sum()) if len(self.table) else 0

    @property
    def ok(self) -> bool:
        """At least one run completed, none failed that way and every repeat check matched
        (the exit rule)."""
        return self.completed > 0 and not len(self.failures) and not mismatches(self)

    def mismatches(self) -> list[dict[str, Any]]:
        """The repeat checks whose digests differ (:func:`mismatches`)."""
        return mismatches(self)


# ---- running ---------------------------------------------------------------------------------
def execute_one(spec: RunSpec, scene: Scene) -> dict[str, Any]:
    """One run in this process, unscored, one cold timed call (for the repeat check)."""
    return execute(spec, scene, reference_mode="none", timing=Timing(repeats=1, warmup=False))


def _skipped_row(spec: RunSpec, scene: Scene, why: str) -> dict[str, Any]:
    row = outcome_row(spec, scene, SKIPPED, why)
    row["verdict"] = SKIPPED
    return row


def _open_store(folder: Path, name: str, scene: Scene, specs: Sequence[RunSpec], opts: SurveyOptions,
                ref_mode: str) -> SweepStore:
    store_name = f"{name}--{scene.name}"
    exists = (folder / f"{store_name}.rows.sqlite").exists()
    return SweepStore.open(folder, store_name, sweep.manifest(scene, specs, ref_mode, opts.repeats or 0),
                           resume=opts.resume and exists, overwrite=opts.overwrite)


def _reference(scene: Scene, specs: Sequence[RunSpec], opts: SurveyOptions) -> tuple[str, str]:
    """Prepare the reference (computed when missing under 'compute'); the mode the runs are
    scored with and a note when they cannot be."""
    if opts.reference == "none":
        return "none", "not scored (--reference none)"
    try:
        sweep.prepare_references(specs, scene, opts.reference, run_progress_factory(opts.progress))
        ref = load_reference(scene, mode="require")
        fingerprints.check(scene, ref)
    except (ParamError, RuntimeError) as exc:
        return "none", f"not scored: no usable reference ({str(exc)[:200]})"
    return "require", ""


def run_case(scene: Scene, opts: SurveyOptions, name: str, folder: Path) -> CaseResult:
    """Plan, run (in rounds, within the budget) and store one case; see the module docstring."""
    proto = survey_protocol(scene, opts.quick)
    if opts.integrators:
        proto = Protocol(tuple(e for e in proto.entries if e.integrator in opts.integrators), proto.measures, proto.why)
    specs, refused = compare.plan(scene, proto)
    if not specs:
        return CaseResult(scene.name, pd.DataFrame(), refused, [], 0.0, 0, 0, "no integrator applies")
    ref_mode, note = _reference(scene, specs, opts)
    budget = opts.budget
    cap = opts.run_cap if opts.run_cap is not None else max(budget, MIN_RUN_CAP_S)
    sweep_opts = opts.sweep_options(ref_mode, cap)
    store = _open_store(folder, name, scene, specs, opts, ref_mode)
    skipped: list[dict[str, Any]] = []
    groups = rounds(specs)
    log = folder / f"{name}--{scene.name}.rounds.json"   # wall time of each round run: a resume goes on from there
    past = [float(x) for x in json.loads(log.read_text())] if opts.resume and log.exists() else []
    t0, last, ran = time.perf_counter() - sum(past), 0.0, 0
    try:
        for k, group in enumerate(groups):
            spent, last = time.perf_counter() - t0, past[k - 1] if 0 < k <= len(past) else last
            done = store.finished()
            todo = [s for s in group if s.index not in done]
            if k > 0 and todo and spent + ROUND_GROWTH * last > budget:
                why = (f"over the case budget of {budget:g} s: {spent:.1f} s spent, the next round of halved steps "
                       f"predicted at {ROUND_GROWTH:g} × {last:.1f} s")
                skipped += [_skipped_row(s, scene, why) for g in groups[k:] for s in g if s.index not in done]
                break
            r0 = time.perf_counter()
            if todo:  # the finished rows of earlier rounds are in the store: the bar counts them as done
                sweep.run_specs([s for g in groups[:k + 1] for s in g], scene, sweep_opts, store,
                                description=f"survey {scene.name} round {k + 1}")
            last, ran = (time.perf_counter() - r0 if todo else past[k] if k < len(past) else 0.0), k + 1
            past[k:k + 1] = [last]
            log.write_text(json.dumps(past))
        rows = list(store.finished().values())
    finally:
        store.close()
    df = assemble(rows + skipped)
    if len(df) and "status" in df:
        gone = df.apply(compare._refused_at_start, axis=1)
        for _, r in df[gone].iterrows():
            refused.setdefault(r["integrator"], str(r["message"]))
        df = df[~gone & ~df["integrator"].isin(list(refused))].reset_index(drop=True)   # its skipped rows too
    res = CaseResult(scene.name, df, refused, case_measures(df, proto) if len(df) else [],
                     time.perf_counter() - t0, ran, len(groups), note)
    if opts.repeat_check:
        res.repeat = repeat_check(df, specs, scene, ref_mode)
    return res


def repeat_check(df: pd.DataFrame, specs: Sequence[RunSpec], scene: Scene, ref_mode: str) -> dict[str, Any]:
    """Repeat the cheapest completed run of a case in this process and compare the history
    digests; {} when the rows carry no digest."""
    if "digest" not in df or not len(df):
        return {}
    ok = df[(df["status"] == "completed") & df["digest"].notna()]
    if not len(ok):
        return {}
    r = ok.loc[pd.to_numeric(ok["wall_s"], errors="coerce").idxmin()]
    spec = next(s for s in specs if s.index == int(r["run"]))
    again = execute_one(spec, scene)
    return {"run": int(r["run"]), "label": str(r["label"]), "digest": str(r["digest"]),
            "repeat": str(again.get("digest")), "match": again.get("digest") == r["digest"]}


def select_cases(opts: SurveyOptions) -> list[str]:
    """The cases of the survey: ``opts.cases``, else the cases tagged ``quick`` (under
    ``quick``) or ``survey`` in their ``[compare]`` table (:func:`daebench.core.scene.tagged`)."""
    names = scene_names()
    want = list(opts.cases) or tagged("quick" if opts.quick else "survey")
    unknown = [c for c in want if c not in names]
    if unknown:
        raise ParamError(f"unknown case(s) {', '.join(unknown)}; `daebench list` shows the cases")
    return want


@contextmanager
def workers(opts: SurveyOptions) -> Iterator[tuple[SurveyOptions, executors.WorkerPool | None]]:
    """One set of workers for the whole survey (every case, every round), so that each
    worker loads a kernel once: ``opts.jobs`` worker processes
    (:func:`daebench.harness.sweeps.executors.shared_pool`), or one Dask client for
    ``opts.scheduler`` (the options handed back carry it); released at the end."""
    if opts.scheduler is None:
        with executors.shared_pool(opts.jobs) as pool:
            yield opts, pool
        return
    client, release = dask_cluster.connect_dask(opts.scheduler, opts.jobs)
    try:
        yield replace(opts, scheduler=client), None
    finally:
        release()


def run_survey(opts: SurveyOptions) -> SurveyResult:
    """Run every case, then score: the reach table (cost to reach each target), profiles and
    the recommendation per case; written under results/survey/<name>/.

    Raises
    ------
    ParamError
        Before anything runs: unknown case, bad budget, a table name in use (without
        resume/overwrite).
    sweep.SweepInterrupted
        On Ctrl-C, after the finished rows are stored (``name`` in its ``name``).
    """
    cases = select_cases(opts)
    for i in opts.integrators:
        integrator_registry.resolve_name(i)   # an unknown name is refused (with did-you-mean) before anything runs
    opts.budget  # noqa: B018  (validated before anything runs)
    name = check_name(opts.name) if opts.name else unique_name("survey" + ("-quick" if opts.quick else ""))
    folder = Path(opts.folder) if opts.folder is not None else results_dir() / "survey" / name
    started = (folder / "survey.json").exists() or (folder / survey_plan.PLAN_FILE).exists()
    if started and not (opts.resume or opts.overwrite):
        raise StoreError(f"survey '{name}' exists in {folder}; pass --resume to complete it, "
                                    f"--overwrite to replace it, or choose another --name")
    scenes = [case_scene(c, opts.quick) for c in cases]
    survey_plan.check_targets(opts.targets, survey_plan.target_measures(
        scenes, lambda sc: survey_protocol(sc, opts.quick).measures))
    plan = survey_plan.plan_of(opts, cases)
    if opts.resume:
        survey_plan.check_resume(folder, name, plan)
    runs = folder / "runs"
    survey_plan.record(folder, plan)
    t0 = time.perf_counter()
    results = []
    with workers(opts) as (run_opts, pool):
        for sc in scenes:
            try:
                results.append(run_case(sc, run_opts, name, runs))
            except (sweep.SweepInterrupted, dask_cluster.ClusterLost) as exc:
                exc.name = name
                if isinstance(exc, dask_cluster.ClusterLost):
                    exc.table = None   # one case's table: not the survey's
                raise
    res = score(results, opts.targets)
    res.name, res.folder, res.wall_s = name, folder, time.perf_counter() - t0
    res.workers_started = pool.started if pool is not None else None
    res.files = write(res, opts)
    return res


def score(results: Sequence[CaseResult], targets: Mapping[str, Sequence[float]] | None = None,
          most: int = 3) -> SurveyResult:
    """The survey's tables from its cases: all rows, the verdict table over the measures of
    each case (:func:`daebench.harness.analysis.evidence.verdict_table`: the CPU time at which
    each setting qualifies for each target; targets given, else the case's own (its
    ``[compare] targets``, :mod:`daebench.core.comparison`) and, for a measure it declares
    none of, :func:`daebench.harness.analysis.costs.decade_targets` of the errors pooled over
    the cases), the profile table (CPU time) and the recommendation per case."""
    frames = [r.table for r in results if len(r.table)]
    table = pd.concat(frames, ignore_index=True, sort=False) if frames else pd.DataFrame()
    measures = list(dict.fromkeys(m for r in results for m in r.measures))
    tg = {m: list(v) for m, v in targets.items()} if targets else recommend.default_targets(table, measures, most)
    parts = []
    for r in results:
        own = tg if targets else {**tg, **declared_targets(r.case)}
        mine = {m: v for m, v in own.items() if m in r.measures}
        if mine and len(r.table):
            parts.append(evidence.verdict_table(r.table, mine))
    reach = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
    prof = profiles.profile_table(reach, cost=evidence.COST) if len(reach) else pd.DataFrame()
    records, paras = recommend.by_case(reach, table, model_of)
    return SurveyResult("", Path("."), table, reach, prof, paras, list(results), 0.0, records=records)


def declared_targets(case: str) -> dict[str, list[float]]:
    """The target errors a case of the library declares (``[compare] targets``; empty for
    one that declares none, or a name that is not a case)."""
    try:
        comparison = case_scene(case).comparison
    except ParamError:
        return {}
    return {m: list(v) for m, v in comparison.targets.items()}


def model_of(case: str) -> str | None:
    """The model of a case of the library (None for a name that is not one)."""
    try:
        return case_scene(case).model
    except ParamError:
        return None


#: the profile figure's file stem in a survey's folder
PROFILE_FIGURE = "profile-cpu"


def write(res: SurveyResult, opts: SurveyOptions | None = None) -> list[Path]:
    """table (all rows), reach (cost to reach each target), profiles (table and figure),
    recommendations.md and survey.json (options, cases, refusals, skipped, determinism,
    provenance) under ``res.folder``."""
    f = res.folder
    f.mkdir(parents=True, exist_ok=True)
    files = []
    for stem, df in (("table", res.table), ("reach", res.reach), ("profiles", res.profile)):
        if len(df):
            df.to_csv(f / f"{stem}.csv", index=False)
            files.append(f / f"{stem}.csv")
    if len(res.table):
        atomic_write(f / "table.parquet", lambda p: res.table.to_parquet(p, index=False), "the survey's table")
    prov = provenance.collect(scene_hashes(res.table))
    if len(res.reach) and res.reach["qualified"].any():
        files += profiles.figure(res.reach, f / PROFILE_FIGURE, cost=evidence.COST, prov=prov, cost_label="CPU time")
    md = [f"# Survey {res.name}", ""] + [p + "\n" for p in res.paragraphs.values()]
    (f / "recommendations.md").write_text("\n".join(md) + provenance.markdown_footer(prov))
    (f / "recommendations.json").write_text(json.dumps(jsonable(res.records), indent=1))
    files += [f / "recommendations.md", f / "recommendations.json"]
    side = {"name": res.name, "wall_s": res.wall_s, "workers_started": res.workers_started,
            "options": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(opts).items()
                        if k != "scheduler"} if opts else {},
            "rules": {"budget": f"per case; a round of halved steps runs if spent + {ROUND_GROWTH:g} × the last "
                                f"round fits; others are '{SKIPPED}' rows", "targets": costs.decade_targets.__doc__},
            "cases": [{"case": r.case, "wall_s": r.wall_s, "rounds_run": r.rounds_run, "rounds": r.rounds,
                       "runs": len(r.table), "measures": r.measures, "note": r.note, "not_applicable": r.refused,
                       "skipped_budget": int((r.table["status"] == SKIPPED).sum()) if len(r.table) else 0,
                       "repeat_check": r.repeat} for r in res.cases]}
    files.append(provenance.write_sidecar(f / "survey.json", prov, **side))
    return files


def scene_hashes(table: pd.DataFrame) -> list[tuple[str, str]]:
    """(case, scene hash) of every scene variant a table ran."""
    if not len(table) or "scene_hash" not in table:
        return []
    pairs = table[["case", "scene_hash"]].dropna().drop_duplicates()
    return [(str(c), str(h)) for c, h in pairs.itertuples(index=False)]


def mismatches(res: SurveyResult) -> list[dict[str, Any]]:
    """The repeat checks whose digests differ."""
    return [dict(case=r.case, **r.repeat) for r in res.cases if r.repeat and not r.repeat.get("match")]
