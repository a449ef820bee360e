"""Many runs: a sweep (`daebench bench`), a case's comparison (`daebench compare`), the
survey of every case and its page (`daebench survey`, `daebench report`), what each effect
costs (`daebench effects`) and the largest stable step (`daebench stability`)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import pandas as pd

from daebench.api.catalogue import SceneLike, load_scene
from daebench.api.peers import peer_sources
from daebench.harness.analysis import costs
from daebench.harness.files import OutputWriteError
from daebench.harness.scoring import glossary, pipeline
from daebench.harness.sweeps import sweep
from daebench.harness.sweeps.options import Execution, Plan, SweepOptions, from_keywords
from daebench.core.params import ParamError
from daebench.workflows import compare as _compare
from daebench.workflows import converge as _converge

#: compare's default budget [s] for extending its series (the workflows' constant, for the CLI's help)
COMPARE_BUDGET_S = _converge.DEFAULT_BUDGET_S
from daebench.workflows import effects as _effects
from daebench.workflows import report as _report
from daebench.workflows import stability as _stability
from daebench.workflows import survey as _survey
from daebench.workflows.score import Source

Overrides = Iterable[str] | dict[str, Any] | None


def bench(scene: SceneLike, integrators: Sequence[str] | str | None = None, *, overrides: Overrides = None,
          plan: Plan | None = None, options: SweepOptions | None = None, **keywords: Any) -> pd.DataFrame:
    """Sweep integrators × grid × steps (or tolerances) on a scene; one scored row per run.

    What to run is a :class:`~daebench.harness.sweeps.options.Plan` (``plan``), how to run
    it a :class:`~daebench.harness.sweeps.options.SweepOptions` (``options``: reference
    mode, timing, execution, storage); or, for convenience, these keyword arguments
    (mapped onto them by :func:`daebench.harness.sweeps.options.from_keywords`; ``timing``,
    ``storage`` and ``execution`` may also be given as values):

    Parameters
    ----------
    scene, overrides : as for :func:`daebench.run`
    integrators : names, or one comma-separated string (``"hht,newmark"``)
    steps, tols : fixed steps h [s], or tolerances (adaptive runs: rtol = tol, atol = tol/100)
    grid : {key: values}: an integrator setting or a scene key
    options : integrator settings fixed for every run that has them (a dict; a
        :class:`SweepOptions` value is the run options above)
    reference : 'auto' (score if a reference is cached), 'compute', 'require', 'none'; a
        model with an exact solution is scored against it
    force : allow runs beyond the step-count limit
    jobs : worker processes (a crashing run costs only its own row)
    scheduler : Dask scheduler address, 'local', or a Client
    executor : 'process' (default), 'inline' (this process, no isolation) or 'dask'
    no_workers_timeout : seconds a Dask cluster may have no worker while runs wait before
        the sweep stops with :class:`daebench.api.ClusterLost` (default 60); a lost
        scheduler stops it so too, its runs in flight interrupted (``resume`` runs them)
    progress : progress bars on stderr (default False)
    name, folder, write, resume, overwrite : the table results/bench/<name>.parquet (unique
        name by default; ``folder`` instead of results/bench; rows stored as they finish;
        ``resume`` completes an interrupted sweep)
    run_cap : wall-time cap of one run [s]; a run over it is a 'timeout' row
    repeats : timed runs (minimum taken) after a warm-up run, made while a run takes
        under a second (:data:`daebench.harness.running.timing.REPEATS`); 1: one cold run, no warm-up

    Returns
    -------
    pandas.DataFrame
        One row per run: label, settings, status, verdict, wall_s, counters, errors
        (``err_<observable>_{final,max,l2}``), energy and constraint residuals.
    """
    sc = load_scene(scene, overrides)
    if options is not None and not isinstance(options, SweepOptions):   # integrator settings, by the keyword's name
        keywords["options"], options = options, None
    given = dict(plan=plan, options=options, **{k: keywords.pop(k) for k in ("timing", "storage", "execution")
                                                if k in keywords})
    return sweep.run_sweep(sc, *from_keywords(integrators, keywords, given))


def compare(scene: SceneLike, options: SweepOptions | None = None, *, overrides: Overrides = None,
            out: str | Path | None = None, report: bool = False,
            protocol: _compare.Protocol | None = None, include: Sequence[Any] = (),
            budget: float | None = None, peers: Sequence[str] = (),
            peer_steps: Sequence[float] | None = None) -> _compare.CompareResult:
    """Every applicable integrator at the case's protocol, scored against the reference;
    the table, the work–precision figure and (``report``) one HTML page in ``out``
    (default results/compare/<case>-<hash>). ``options``: as
    :data:`daebench.workflows.compare.DEFAULT_OPTIONS` (two workers, the reference computed
    when missing) unless given. ``include``: other codes' trajectories (paths, DataFrames or
    :class:`daebench.workflows.score.Source` values, as :func:`daebench.score` takes them),
    scored beside the runs and marked external; refused before any run when their data are.
    ``peers``: peer codes (:func:`daebench.api.peers.peer_names`) run on the case first, in
    this same call, at ``peer_steps`` [s] (default: each peer's own steps for the case), their
    files included as ``include`` is.
    The result's ``ok`` is the exit rule: every run gave a verdict and every history equals
    the previous comparison's (``changed`` says which did not). ``budget``: wall time [s]
    for extending each series until its targets are decided (default
    :data:`daebench.workflows.converge.DEFAULT_BUDGET_S`; 0: the protocol's runs only)."""
    sc = load_scene(scene, overrides)
    if isinstance(include, (str, Path, Source, pd.DataFrame)):
        include = [include]
    sources = [s if isinstance(s, Source) else Source(s) for s in include]
    if budget is not None and not (isinstance(budget, (int, float)) and math.isfinite(budget) and budget >= 0):
        raise ParamError(f"budget must be a number of seconds ≥ 0 (0: the protocol's runs only), got {budget!r}")
    if peers:
        sources += peer_sources(sc, list(peers), peer_steps)
    res = _compare.run_compare(sc, options or _compare.DEFAULT_OPTIONS, out, protocol, sources,
                               _converge.DEFAULT_BUDGET_S if budget is None else float(budget))
    if report:
        try:
            res.page = _report.write_compare_report(res, sc, res.folder / "report.html")
        except OutputWriteError as exc:   # the comparison is done: it stays reachable
            exc.result = res
            raise
    return res


def survey(options: _survey.SurveyOptions | None = None, report: bool = False) -> _survey.SurveyResult:
    """Every case's protocol within a per-case budget (:class:`daebench.workflows.survey.SurveyOptions`):
    the cost to reach target errors, performance profiles and a recommendation per case,
    written under results/survey/<name>/; ``report``: also the HTML page."""
    res = _survey.run_survey(options or _survey.SurveyOptions())
    if report:
        res.files.append(_report.write_survey_report(res))
    return res


def report(name: str, out: str | Path | None = None, compact: bool = False) -> Path:
    """One self-contained HTML page of the survey ``name`` (results/survey/<name>/); its path."""
    return _report.write_survey_report(_report.load_survey(name), Path(out) if out else None, compact=compact)


def effects(scene: SceneLike, integrator: str = "hht", settings: dict[str, Any] | None = None, *,
            overrides: Overrides = None, out: str | Path | None = None,
            options: SweepOptions | None = None) -> _effects.EffectsResult:
    """The case with each switchable effect turned off in turn: the change of every
    observable and of the cost (:func:`daebench.workflows.effects.run_effects`)."""
    sc = load_scene(scene, overrides)
    return _effects.run_effects(sc, integrator, settings, Path(out) if out else None,
                                options or SweepOptions(execution=Execution(progress=False)))


def stability(scene: SceneLike, methods: Sequence[str] | None = None, n: str = "auto",
              search: _stability.Bisection | None = None, *, overrides: Overrides = None,
              out: str | Path | None = None, name: str | None = None,
              progress: Callable[[str], None] | None = None, overwrite: bool = False) -> _stability.StabilityResult:
    """The largest stable fixed step per integrator setting and N, measured by bisection
    on whole runs beside the linear prediction
    (:func:`daebench.workflows.stability.run_stability`; ``methods`` default to
    :data:`daebench.workflows.stability.DEFAULT_METHODS`; ``search.mark_h``: a step drawn
    as a line; ``overwrite``: replace the files of an earlier map of the same name)."""
    sc = load_scene(scene, overrides)
    return _stability.run_stability(sc, methods or _stability.DEFAULT_METHODS, n, search or _stability.Bisection(),
                                    Path(out) if out is not None else None, name, progress, overwrite)


def error_columns(scene: SceneLike) -> list[str]:
    """The max-error columns `daebench bench` prints for ``scene``: each observable and
    point its model declares to be scored around impacts, else its headline observable."""
    sc = load_scene(scene)
    obs, pos = pipeline.declared(sc.model).windowed(list(sc.get("output.observables") or []))
    return [f"err_{d.score_name}_max" for d in (*obs, *pos)] or [f"err_{pipeline.headline(sc).score_name}_max"]


def parse_targets(spec: Iterable[str]) -> dict[str, list[float]] | None:
    """``["MEASURE=v1,v2", …]`` (the survey's --target) as {measure: targets}; None when empty."""
    return costs.parse_targets(spec) or None


def describe_measure(column: str, model: str | None = None) -> glossary.Measure:
    """What a scored column means, for people: display name with unit, a short header and
    a one-line definition (:func:`daebench.harness.scoring.glossary.describe`)."""
    return glossary.describe(column, model)
