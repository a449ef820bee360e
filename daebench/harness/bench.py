"""Sweeps: many runs → one tidy, scored table that loses nothing.

* :func:`plan_sweep` — the Cartesian product of integrators × grid × steps/tols, every
  run checked (settings, grid keys, observables, size) before anything runs.
* :func:`execute` — one run, scored against the cached reference; never raises: an
  exception is a row with status ``error``, a run over its wall-time cap ``timeout``.
* :func:`run_specs` / :func:`run_sweep` — run the plan on an executor
  (:mod:`daebench.harness.executors`), storing each row on disk as it arrives
  (:mod:`daebench.harness.sweepstore`); interrupted, a sweep keeps its finished rows and can be
  resumed. What to run, how to time, where to store and how to execute are one value each
  (:mod:`daebench.harness.options`).

Statuses: ``completed``, ``diverged``, ``failed`` are the integrator's verdict (the
driver's); ``skipped`` a run that does not apply; ``error``, ``timeout``, ``crashed``
(:data:`HARNESS_FAILURES`) a run that could not give a verdict; ``interrupted`` a run
the sweep did not finish (never stored: ``resume`` runs it).

References live in :mod:`daebench.harness.references` and tables in :mod:`daebench.harness.sweepstore`;
both are re-exported here.
"""

from __future__ import annotations

import itertools
import json
import sys
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any, Callable, Sequence

import pandas as pd

from daebench.harness import executors, guards, sweepstore
from daebench.harness.guards import RunTimeout, deadline  # noqa: F401  (re-exported: studies use them)
from daebench.integrators import base
from daebench.integrators.base import IntegratorError
from daebench.models import build_system
from daebench.core.params import ParamError, did_you_mean
from daebench.harness.options import Execution, Plan, Storage, SweepError, Timing  # noqa: F401  (re-exported)
from daebench.harness.references import (  # noqa: F401  (re-exported)
    CHECK_FACTOR, REF_ATOL, REF_INTEGRATOR, REF_MARGIN, REF_RTOL, Reference, ReferenceDamaged, ReferenceMissing,
    compute_reference, load_reference, reference_path, reference_tolerances)
from daebench.harness.runner import results_dir, run_scene  # noqa: F401
from daebench.core.scene import Scene
from daebench.harness.sweeprun import base_row, execute, outcome_row  # noqa: F401  (re-exported)
from daebench.harness.sweepstore import SweepStore, read_table, write_table  # noqa: F401

TOL_ATOL_RATIO = 1e-2   # --tols t sets rtol = t, atol = t · this
HARNESS_FAILURES = ("error", "timeout", "crashed")
TIMING_COLUMNS = ("wall_s", "cpu_s", "repeats")   # the only columns that differ between identical runs
MAX_JOBS = 512


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM, :func:`daebench.harness.executors.sigterm_as_interrupt`) during a
    sweep. ``table`` holds every finished row plus an ``interrupted``
    row per unfinished run; ``path`` is the table written (None without a store)."""

    def __init__(self, table: pd.DataFrame, path: Path | None, name: str | None) -> None:
        super().__init__("sweep interrupted")
        self.table, self.path, self.name = table, path, name


# ==== planning ==========================================================================
@dataclass
class RunSpec:
    """One run of a sweep: which integrator with which settings on which scene variant."""

    index: int
    integrator: str
    options: dict[str, Any]
    scene_overrides: dict[str, Any]
    varied: dict[str, Any]                     # the keys this sweep varies, for labels/columns
    skip: str = ""                             # non-empty: do not run, this is the reason

    @property
    def label(self) -> str:
        parts = [f"{k}={_fmt(v)}" for k, v in self.varied.items() if k not in ("h", "rtol", "atol", "tol")]
        mode = " adaptive" if self.options.get("adaptive") else ""  # never one line with fixed steps
        return self.integrator + mode + (f" ({', '.join(parts)})" if parts else "")


def _fmt(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _integrator_classes(names: Sequence[str]) -> dict[str, type]:
    out = {}
    for n in names:
        try:
            name = guards.resolve_integrator(n)
            out[name] = base.get_integrator(name)
        except IntegratorError as exc:
            raise SweepError(f"{exc} (in --integrators)") from None
    if len(out) != len(names):
        raise SweepError(f"an integrator is named twice in --integrators: {', '.join(names)}")
    return out


def classify_grid(scene: Scene, classes: dict[str, type], grid: dict[str, Sequence[Any]]
                  ) -> tuple[dict[str, list], dict[str, list]]:
    """Split grid keys into integrator settings (checked first) and scene keys.

    Raises
    ------
    SweepError
        For a key that is neither, with the closest valid name.
    """
    settings = {s.name for c in classes.values() for s in c.settings_spec}
    integ_keys, scene_keys = {}, {}
    for k, vals in grid.items():
        vals = list(vals)
        if not vals:
            raise SweepError(f"grid key '{k}' has no values")
        if k in settings:
            integ_keys[k] = vals
        elif k in scene.schema:
            scene_keys[k] = vals
        else:
            raise SweepError(
                f"unknown grid key '{k}': not a setting of {', '.join(classes)} nor a key of scene "
                f"'{scene.name}'{did_you_mean(k, list(settings) + list(scene.schema))} "
                f"(settings: `daebench list`; scene keys: `daebench show {scene.name} --keys`)")
    return integ_keys, scene_keys


def plan_sweep(scene: Scene, integrators: Sequence[str], grid: dict[str, Sequence[Any]] | None = None,
               steps: Sequence[float] | None = None, tols: Sequence[float] | None = None,
               options: dict[str, Any] | None = None, force: bool = False) -> list[RunSpec]:
    """Every run of the sweep, validated before anything runs.

    Integrator settings in ``grid`` vary only for integrators that have them; scene
    keys vary for all. ``steps`` sets ``h``; ``tols`` sets rtol = tol, atol =
    TOL_ATOL_RATIO·tol and adaptive = true (a non-adaptive integrator gets a row that
    says it was skipped). ``options`` are fixed settings for every integrator that
    has them. Every run is checked as :func:`daebench.harness.runner.run_scene` would check it
    (settings, observables, contacts, and — unless ``force`` — its size).
    """
    if steps and tols:
        raise SweepError("give --steps or --tols, not both")
    if not integrators:
        raise SweepError("no integrators given (e.g. --integrators hht,baumgarte)")
    classes = _integrator_classes(integrators)
    integ_keys, scene_keys = classify_grid(scene, classes, dict(grid or {}))
    options = dict(options or {})
    for k in options:
        if not any(k in {s.name for s in c.settings_spec} for c in classes.values()):
            raise SweepError(f"--opt '{k}' is not a setting of any of {', '.join(classes)}")
    # validate every scene variant now (bad values fail before running)
    scene_combos = [dict(zip(scene_keys, combo)) for combo in itertools.product(*scene_keys.values())]
    variants = {}
    for i, sc in enumerate(scene_combos):
        variants[i] = scene.with_overrides(sc)
        guards.check_observables(variants[i], build_system(variants[i]))
    specs: list[RunSpec] = []
    for name, cls in classes.items():
        spec_names = {s.name for s in cls.settings_spec}
        mine = {k: v for k, v in integ_keys.items() if k in spec_names}
        fixed = {k: v for k, v in options.items() if k in spec_names}
        if tols:
            modes = [{"tol": t} for t in tols]
        elif steps:
            modes = [{"h": float(h)} for h in steps]
        else:
            modes = [{}]
        for i, sc in enumerate(scene_combos):
            for combo in itertools.product(*mine.values()):
                for mode in modes:
                    opts = {**fixed, **dict(zip(mine, combo))}
                    skip = ""
                    if "tol" in mode:
                        if not cls.capabilities.adaptive:
                            skip = f"'{name}' has no adaptive step-size control; --tols does not apply"
                        else:
                            opts.update(adaptive=True, rtol=mode["tol"], atol=mode["tol"] * TOL_ATOL_RATIO)
                    elif "h" in mode:
                        if not cls.capabilities.fixed_step:
                            skip = f"'{name}' chooses its own steps; --steps does not apply"
                        else:
                            opts["h"] = mode["h"]
                    varied = {**sc, **dict(zip(mine, combo)), **mode}
                    if not skip:
                        try:
                            integ = cls(**opts)  # validate settings now
                            guards.check_contacts_fit(variants[i], cls)
                            if not force:
                                guards.check_size(variants[i], integ)
                        except ParamError as exc:
                            raise SweepError(str(exc)) from None
                        except Exception as exc:  # a plugin's constructor bug
                            raise SweepError(f"integrator '{name}' raised while being configured with {opts}: "
                                             f"{type(exc).__name__}: {exc}") from None
                    specs.append(RunSpec(len(specs), name, opts, dict(sc), varied, skip))
    return specs


# ==== references before the sweep ============================================================
def prepare_references(specs: Sequence[RunSpec], scene: Scene, reference_mode: str,
                       progress: Callable[[str, float], Any] | None = None) -> None:
    """Before any run: check (and under 'compute'/'auto' compute or repair) the reference of
    every scene variant, in this process with its own progress bar. A reference not
    REF_MARGIN tighter than the tightest scored rtol is recomputed that much tighter under
    'compute' (said on stderr; IDA's floor permitting) and refused otherwise.

    Raises
    ------
    SweepError, ReferenceMissing, ReferenceDamaged
    """
    if reference_mode not in ("auto", "require", "compute", "none"):
        raise SweepError(f"unknown reference mode '{reference_mode}' (auto, require, compute, none)")
    if reference_mode == "none":
        return
    tight = min((s.options["rtol"] for s in specs if "rtol" in s.options and not s.skip), default=None)
    for over in dict.fromkeys(json.dumps(s.scene_overrides, sort_keys=True) for s in specs):
        sc = scene.with_overrides(json.loads(over)) if over != "{}" else scene
        try:
            ref = load_reference(sc, mode=reference_mode, tightest_rtol=tight, progress=progress)
        except ReferenceMissing:
            if reference_mode == "auto":
                continue
            raise
        except RuntimeError as exc:
            raise SweepError(f"the reference could not be computed: {exc}") from None
        if (tight is not None and ref.rtol > tight / REF_MARGIN and reference_mode == "compute"
                and reference_tolerances(tight)[0] <= tight / REF_MARGIN):
            # asked to compute: a cached reference too loose for these runs is replaced by a tighter
            # one of the same scene (announced; a tighter reference serves every looser sweep too)
            sys.stderr.write(f"the cached reference of '{sc.name}' (rtol {ref.rtol:g}) is not {REF_MARGIN:g}× "
                             f"tighter than the tightest scored rtol {tight:g}: computing one at rtol "
                             f"{reference_tolerances(tight)[0]:g} in its place\n")
            try:
                ref = compute_reference(sc, tightest_rtol=tight, progress=progress)
            except RuntimeError as exc:
                raise SweepError(f"the reference could not be computed: {exc}") from None
        if tight is not None and ref.rtol > tight / REF_MARGIN:
            raise SweepError(
                f"the cached reference of '{sc.name}' (rtol {ref.rtol:g}) is not {REF_MARGIN:g}× tighter than "
                f"the tightest scored rtol {tight:g}; run `daebench reference {sc.name} --force "
                f"--rtol {tight / REF_MARGIN:g}`")


# ==== running ===================================================================================
def _int_at_least_1(value: Any, what: str, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= high:
        raise SweepError(f"{what} must be a whole number from 1 to {high}, got {value!r}")
    return value


def run_specs(specs: Sequence[RunSpec], scene: Scene, execution: Execution = Execution(),
              timing: Timing = Timing(), reference_mode: str = "auto", store: SweepStore | None = None,
              history_dir: str | Path | None = None, description: str = "runs") -> pd.DataFrame:
    """Execute planned runs; one row each, in plan order.

    ``execution``: 'process' (``jobs`` worker processes; a crash costs one row), 'inline'
    (this process), or 'dask' (or any ``scheduler``); ``timing`` as
    :class:`daebench.harness.options.Timing`. With a ``store`` every row is on disk as soon
    as it exists, and runs that already have a row there are not run again; with
    ``history_dir`` each run's history is kept there.

    Raises
    ------
    SweepInterrupted
        On Ctrl-C, after every finished row is stored; it carries the partial table.
    """
    jobs, executor, scheduler, progress = execution.jobs, execution.executor, execution.scheduler, execution.progress
    jobs = _int_at_least_1(jobs, "jobs", MAX_JOBS)
    repeats = _int_at_least_1(timing.repeats, "repeats", 1000)
    run_cap = guards.check_run_cap(timing.run_cap)
    if executor not in ("process", "inline", "dask"):
        raise SweepError(f"unknown executor '{executor}' (process, inline or dask)")
    use_dask = executor == "dask" or scheduler is not None
    client, release = executors.connect_dask(scheduler, jobs) if use_dask else (None, lambda: None)
    rows: dict[int, dict[str, Any]] = dict(store.finished()) if store is not None else {}
    todo = [s for s in specs if s.index not in rows]
    tm = Timing(repeats, timing.warmup, timing.time_cap, run_cap)
    fn = partial(execute, scene=scene, reference_mode=reference_mode, timing=tm, history_dir=history_dir)
    make_row = partial(_make_row, scene=scene)
    calls = repeats + (1 if timing.warmup else 0)
    backstop = run_cap * calls + executors.BACKSTOP_GRACE_S if run_cap else None
    from daebench.harness.progress import SweepProgress

    bar = SweepProgress(description, len(specs)) if progress else None

    def on_row(row: dict[str, Any]) -> None:
        if store is not None:
            store.append(row)
        rows[int(row["run"])] = row
        if bar is not None:
            bar.update(row)

    on_running = bar.running if bar is not None else None
    if bar is not None:
        bar.done = len(rows)
        bar.start()
    try:
        if use_dask:
            executors.run_dask(todo, fn, client, on_row, make_row, on_running, backstop)
        elif executor == "inline":
            executors.run_inline(todo, fn, on_row, on_running)
        else:
            executors.run_processes(todo, fn, jobs, on_row, make_row, on_running, backstop)
    except KeyboardInterrupt:
        df = sweepstore.assemble(list(rows.values()) + sweepstore.interrupted_rows(
            specs, set(rows), scene, "the sweep was interrupted (Ctrl-C or SIGTERM) before this run finished"))
        raise SweepInterrupted(df, None, store.name if store is not None else None) from None
    finally:
        if bar is not None:
            bar.stop()
        release()
    return sweepstore.assemble(rows.values())


def _make_row(spec: RunSpec, status: str, message: str, scene: Scene) -> dict[str, Any]:
    return outcome_row(spec, scene, status, message)


def manifest(scene: Scene, specs: Sequence[RunSpec], reference_mode: str, repeats: int) -> dict[str, Any]:
    """What a resumed sweep must share with the original: scene, plan, scoring, timing."""
    return {"scene": scene.name, "scene_hash": scene.hash, "reference_mode": reference_mode, "repeats": repeats,
            "plan": [[s.index, s.integrator, s.options, s.scene_overrides, s.skip] for s in specs]}


def run_sweep(scene: Scene, plan: Plan, execution: Execution = Execution(), timing: Timing = Timing(),
              storage: Storage = Storage()) -> pd.DataFrame:
    """Plan, run and score a sweep; one tidy row per run.

    Parameters
    ----------
    scene : Scene
    plan : what to run and what to score against (:class:`daebench.harness.options.Plan`)
    execution : worker processes, in-process or Dask, progress bars (``Execution``)
    timing : warm-up, repeats, caps (``Timing``; by default a warm-up run stopped after 1 s
        and the minimum of 3 timed runs for runs under a second, one for longer runs:
        :data:`daebench.harness.timing.REPEATS`)
    storage : table name and folder (default results/bench/<scene>-<time>-<hex>), resume,
        overwrite, or memory only (``Storage``)

    Returns
    -------
    pandas.DataFrame
        Its ``attrs['path']`` is the table written (results/bench/<name>.parquet, with
        .csv and a .json provenance sidecar), when ``storage.write``.

    Raises
    ------
    SweepError, StoreError, ReferenceMissing, ReferenceDamaged
        Before any run.
    SweepInterrupted
        On Ctrl-C: the partial table is written and carried by the exception.
    """
    specs = plan_sweep(scene, plan.integrators, plan.grid, plan.steps, plan.tols, plan.options, force=plan.force)
    from daebench.harness.progress import run_progress_factory

    if execution.executor not in ("process", "inline", "dask"):
        raise SweepError(f"unknown executor '{execution.executor}' (process, inline or dask)")
    client, release = (None, lambda: None)
    if execution.executor == "dask" or execution.scheduler is not None:  # unreachable: fails before any reference
        client, release = executors.connect_dask(execution.scheduler,
                                                 _int_at_least_1(execution.jobs, "jobs", MAX_JOBS))
        execution = replace(execution, scheduler=client)
    store = None
    try:
        if storage.write:
            folder = Path(storage.folder) if storage.folder is not None else results_dir() / "bench"
            name = storage.name if storage.name is not None else sweepstore.unique_name(scene.name)
            store = SweepStore.open(folder, name, manifest(scene, specs, plan.reference, timing.repeats),
                                    storage.resume, storage.overwrite)
        elif storage.resume or storage.overwrite:
            raise SweepError("resume and overwrite need a stored sweep (write=True)")
        prepare_references(specs, scene, plan.reference, run_progress_factory(execution.progress))
        try:
            df = run_specs(specs, scene, execution, timing, plan.reference, store, storage.history_dir,
                           description=scene.name)
        except SweepInterrupted as exc:
            if store is not None:
                exc.path = write_table(exc.table, store.name, [scene], store.folder, complete=False)
            raise
        if store is not None:
            df.attrs["path"] = write_table(df, store.name, [scene], store.folder, complete=True)
        return df
    finally:
        if store is not None:
            store.close()
        release()
