"""A sweep: planned runs (:mod:`.plan`) → one tidy, scored table that loses nothing.

* :func:`prepare_references` — before any run, the reference of every scene variant is
  checked (and computed or repaired when asked).
* :func:`run_specs` / :func:`run_sweep` — run the plan on an executor (:mod:`.executors`),
  one row per run (:func:`daebench.harness.sweeps.row.execute`), storing each row on disk
  as it arrives (:mod:`.store`); interrupted, a sweep keeps its finished rows and can be
  resumed. What to run, how to time, where to store and how to execute are one value each
  (:mod:`.options`).

Statuses: ``completed``, ``diverged``, ``failed`` are the integrator's verdict (the
driver's); ``skipped`` a run that does not apply; ``error``, ``timeout``, ``crashed``
(:data:`HARNESS_FAILURES`) a run that could not give a verdict; ``interrupted`` a run
the sweep did not finish (never stored: ``resume`` runs it).
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any, Callable, Sequence

import pandas as pd

from daebench.core.scene import Scene
from daebench.harness.files import results_dir
from daebench.harness.references.reference import (REF_MARGIN, ReferenceMissing, compute_reference,
                                                   load_reference, reference_tolerances)
from daebench.harness.running.deadline import check_run_cap
from daebench.harness.running.progress import SweepProgress, run_progress_factory
from daebench.harness.sweeps import dask_cluster, executors
from daebench.harness.sweeps.options import Plan, SweepError, SweepOptions
from daebench.harness.sweeps.plan import RunSpec, plan_sweep
from daebench.harness.sweeps.row import execute, outcome_row
from daebench.harness.sweeps.store import SweepStore, assemble, interrupted_rows, unique_name, write_table
from daebench.integrators import registry as integrator_registry
from daebench.integrators.compiled import code_owner

HARNESS_FAILURES = ("error", "timeout", "crashed")
TIMING_COLUMNS = ("wall_s", "cpu_s", "cpu_spread", "repeats")   # the only columns that differ between identical runs
MAX_JOBS = 512


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM, :func:`daebench.harness.sweeps.executors.sigterm_as_interrupt`) during a
    sweep. ``table`` holds every finished row plus an ``interrupted``
    row per unfinished run; ``path`` is the table written (None without a store)."""

    def __init__(self, table: pd.DataFrame, path: Path | None, name: str | None) -> None:
        super().__init__("sweep interrupted")
        self.table, self.path, self.name = table, path, name


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
            raise ReferenceFailed(f"the reference could not be computed: {exc}") from None
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
                raise ReferenceFailed(f"the reference could not be computed: {exc}") from None
        if tight is not None and ref.rtol > tight / REF_MARGIN:
            raise SweepError(
                f"the cached reference of '{sc.name}' (rtol {ref.rtol:g}) is not {REF_MARGIN:g}× tighter than "
                f"the tightest scored rtol {tight:g}; run `daebench reference {sc.name} --force "
                f"--rtol {tight / REF_MARGIN:g}`")


class ReferenceFailed(SweepError):
    """The reference run itself did not complete: the input was fine, the work failed (the
    command line exits 1, not 2)."""

    exit_code = 1


# ==== running ===================================================================================
def _int_at_least_1(value: Any, what: str, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= high:
        raise SweepError(f"{what} must be a whole number from 1 to {high}, got {value!r}")
    return value


def compile_order(specs: Sequence[RunSpec]) -> list[RunSpec]:
    """The order in which parallel workers take the runs: the first run of each compiled loop
    (:func:`daebench.integrators.compiled.code_owner`) first, then the others in plan order.

    On an empty kernel cache the first run of a loop compiles it; in plan order two workers
    took two runs of one integrator and compiled the same loop twice at once, so every
    family's compile cost the wall time of one core. Rows are keyed on their plan index, so
    the table does not depend on this order."""
    firsts, rest, seen = [], [], set()
    for spec in specs:
        owner = code_owner(integrator_registry.get_integrator(spec.integrator))  # the plan checked the name
        (rest if owner in seen else firsts).append(spec)
        seen.add(owner)
    return firsts + rest


def run_specs(specs: Sequence[RunSpec], scene: Scene, options: SweepOptions = SweepOptions(),
              store: SweepStore | None = None, description: str = "runs") -> pd.DataFrame:
    """Execute planned runs; one row each, in plan order.

    ``options.execution``: 'process' (``jobs`` worker processes; a crash costs one row),
    'inline' (this process), or 'dask' (or any ``scheduler``); ``options.timing`` as
    :class:`daebench.harness.sweeps.options.Timing`; each run scored under
    ``options.reference``. With a ``store`` every row is on disk as soon as it exists, and
    runs that already have a row there are not run again; with
    ``options.storage.history_dir`` each run's history is kept there.

    Raises
    ------
    SweepInterrupted
        On Ctrl-C, after every finished row is stored; it carries the partial table.
    """
    execution, timing = options.execution, options.timing
    jobs, executor, scheduler, progress = execution.jobs, execution.executor, execution.scheduler, execution.progress
    jobs = _int_at_least_1(jobs, "jobs", MAX_JOBS)
    repeats = _int_at_least_1(timing.repeats, "repeats", 1000)
    run_cap = check_run_cap(timing.run_cap)
    if executor not in ("process", "inline", "dask"):
        raise SweepError(f"unknown executor '{executor}' (process, inline or dask)")
    use_dask = executor == "dask" or scheduler is not None
    client, release = dask_cluster.connect_dask(scheduler, jobs) if use_dask else (None, lambda: None)
    rows: dict[int, dict[str, Any]] = dict(store.finished()) if store is not None else {}
    todo = [s for s in specs if s.index not in rows]
    fn = partial(execute, scene=scene, reference_mode=options.reference, timing=timing,
                 history_dir=options.storage.history_dir)
    make_row = partial(_make_row, scene=scene)
    calls = repeats + (1 if timing.warmup else 0)
    backstop = run_cap * calls + executors.BACKSTOP_GRACE_S if run_cap else None
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
            dask_cluster.run_dask(compile_order(todo), fn, client, on_row, make_row, on_running, backstop,
                                  execution.no_workers_timeout)
        elif executor == "inline":
            executors.run_inline(todo, fn, on_row, on_running)
        else:
            executors.run_processes(compile_order(todo), fn, jobs, on_row, make_row, on_running, backstop)
    except KeyboardInterrupt:
        df = assemble(list(rows.values()) + interrupted_rows(
            specs, set(rows), scene, "the sweep was interrupted (Ctrl-C or SIGTERM) before this run finished"))
        raise SweepInterrupted(df, None, store.name if store is not None else None) from None
    except dask_cluster.ClusterLost as exc:   # the runs in flight get no row: a resume runs them
        exc.table = assemble(list(rows.values()) + interrupted_rows(specs, set(rows), scene, str(exc)))
        exc.name = store.name if store is not None else None
        raise
    finally:
        if bar is not None:
            bar.stop()
        release()
    return assemble(rows.values())


def _make_row(spec: RunSpec, status: str, message: str, scene: Scene) -> dict[str, Any]:
    return outcome_row(spec, scene, status, message)


def manifest(scene: Scene, specs: Sequence[RunSpec], reference_mode: str, repeats: int) -> dict[str, Any]:
    """What a resumed sweep must share with the original: scene, plan, scoring, timing."""
    return {"scene": scene.name, "scene_hash": scene.hash, "reference_mode": reference_mode, "repeats": repeats,
            "observables": list(scene["output.observables"]),  # scored, yet outside the scene's hash
            "plan": [[s.index, s.integrator, s.options, s.scene_overrides, s.skip] for s in specs]}


def run_sweep(scene: Scene, plan: Plan, options: SweepOptions = SweepOptions()) -> pd.DataFrame:
    """Plan, run and score a sweep; one tidy row per run.

    Parameters
    ----------
    scene : Scene
    plan : what to run (:class:`daebench.harness.sweeps.options.Plan`)
    options : what to score against, and ``execution`` (worker processes, in-process or
        Dask, progress bars), ``timing`` (warm-up, repeats, caps; by default a warm-up run
        stopped after 1 s and the minimum of 3 timed runs for runs under a second, one for
        longer runs: :data:`daebench.harness.running.timing.REPEATS`), ``storage`` (table
        name and folder, default results/bench/<scene>-<time>-<hex>; resume, overwrite, or
        memory only) (:class:`daebench.harness.sweeps.options.SweepOptions`)

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
    execution, storage = options.execution, options.storage
    if execution.executor not in ("process", "inline", "dask"):
        raise SweepError(f"unknown executor '{execution.executor}' (process, inline or dask)")
    client, release = (None, lambda: None)
    if execution.executor == "dask" or execution.scheduler is not None:  # unreachable: fails before any reference
        client, release = dask_cluster.connect_dask(execution.scheduler,
                                                 _int_at_least_1(execution.jobs, "jobs", MAX_JOBS))
        options = replace(options, execution=replace(execution, scheduler=client))
    store, new = None, False
    try:
        # every option a refusal can come from is checked before the store exists
        _int_at_least_1(execution.jobs, "jobs", MAX_JOBS)
        _int_at_least_1(options.timing.repeats, "repeats", 1000)
        check_run_cap(options.timing.run_cap)
        if storage.write:
            folder = Path(storage.folder) if storage.folder is not None else results_dir() / "bench"
            name = storage.name if storage.name is not None else unique_name(scene.name)
            new = not storage.resume
            store = SweepStore.open(folder, name, manifest(scene, specs, options.reference, options.timing.repeats),
                                    storage.resume, storage.overwrite)
        elif storage.resume or storage.overwrite:
            raise SweepError("resume and overwrite need a stored sweep (write=True)")
        try:
            prepare_references(specs, scene, options.reference, run_progress_factory(execution.progress))
        except BaseException:
            if store is not None and new:  # refused before any run: the store made for it goes again
                store.discard()
                store = None
            raise
        try:
            df = run_specs(specs, scene, options, store, description=scene.name)
        except (SweepInterrupted, dask_cluster.ClusterLost) as exc:
            if store is not None:
                exc.path = write_table(exc.table, store.name, [scene], store.folder, complete=False)
            raise
        if store is not None:
            df.attrs["path"] = write_table(df, store.name, [scene], store.folder, complete=True)
        return df
    except Exception as exc:   # refused before any run (a missing reference, bad options): nothing is left behind
        if store is not None and not isinstance(exc, dask_cluster.ClusterLost):
            store.discard()
        raise
    finally:
        if store is not None:
            store.close()
        release()
