"""One run of a sweep → one scored row (:func:`execute`), and the row of a run that could
not report itself (:func:`outcome_row`). A row never raises out of here: an exception is
an ``error`` row, a run over its wall-time cap a ``timeout`` row."""

from __future__ import annotations

import json
import math
import traceback
from pathlib import Path
from typing import Any

from daebench.core.scene import Scene
from daebench.harness.references.reference import Reference, ReferenceMissing, load_reference
from daebench.core.interrupt import RunTimeout
from daebench.harness.running.isolated import RunCrashed
from daebench.harness.running.history_io import keep_history
from daebench.harness.running.runner import run_scene
from daebench.harness.running.timing import WARMUP_CAP_S, time_call
from daebench.harness.scoring import metrics, pipeline
from daebench.harness.sweeps.digest import history_digest
from daebench.harness.sweeps.options import Timing
from daebench.integrators import registry as integrator_registry
from daebench.models import build_system


def nan_errors(row: dict[str, Any]) -> None:
    for k in list(row):
        if k.startswith("err_"):
            row[k] = math.nan


def _reference(scene: Scene, reference_mode: str) -> Reference | None:
    """The cached reference under ``reference_mode`` ('none': None; 'auto': None when
    missing; 'require'/'compute': :class:`ReferenceMissing` when missing)."""
    if reference_mode == "none":
        return None
    try:
        return load_reference(scene, mode="auto" if reference_mode == "auto" else "require")
    except ReferenceMissing:
        if reference_mode != "auto":
            raise
        return None


def base_row(spec: Any, scene: Scene) -> dict[str, Any]:
    """The columns every row has, whatever happened to the run."""
    return {"run": spec.index, "case": scene.name, "integrator": spec.integrator, "label": spec.label,
            **spec.varied, "settings": json.dumps(spec.options, sort_keys=True, default=str),
            "overrides": json.dumps(spec.scene_overrides, sort_keys=True, default=str),
            "scene_set": json.dumps(scene.changes(), sort_keys=True, default=str)}


def outcome_row(spec: Any, scene: Scene, status: str, message: str) -> dict[str, Any]:
    """The row of a run that gave no verdict (error, timeout, crashed, interrupted)."""
    return {**base_row(spec, scene), "status": status, "message": message, "verdict": status,
            "verdict_reason": message}


_WARMED: set[tuple] = set()   # (integrator, model, code-selecting settings) warmed in this process


def execute(spec: Any, scene: Scene, reference_mode: str = "auto", timing: Timing = Timing(),
            history_dir: str | Path | None = None) -> dict[str, Any]:
    """Run one spec and score it (:func:`daebench.harness.scoring.pipeline.score`: against the
    model's exact solution where it has one, else the reference); never raises for a
    failure of the run — an exception is an 'error' row, a run over ``timing.run_cap``
    seconds a 'timeout' row.

    Timing follows :data:`daebench.harness.running.timing.REPEATS`' rule (a warm-up stopped after
    WARMUP_CAP_S — once per integrator, model and process —, then up to ``timing.repeats``
    timed runs while a run is shorter than SHORT_RUN_S; ``Timing(repeats=1, warmup=False)``
    times one cold run).
    ``reference_mode``: 'auto' (score if a valid cached reference exists), 'require' or
    'compute' (the caller made sure it exists: :func:`prepare_references`), 'none'. With
    ``history_dir`` the history is kept as ``<history_dir>/<run>-<integrator>.parquet``
    and its path is the row's ``history``.
    """
    row = base_row(spec, scene)
    run_cap = timing.run_cap
    try:
        sc = scene.with_overrides(spec.scene_overrides) if spec.scene_overrides else scene
        row["scene_hash"] = sc.hash
        if spec.skip:
            row.update(status="skipped", message=spec.skip, verdict="skipped", verdict_reason=spec.skip)
            return row
        cls = integrator_registry.get_integrator(spec.integrator)  # entry-point loading stays out of the timing

        def one_run(cap: float | None = run_cap):
            return run_scene(sc, cls(**spec.options), write=False, force=True, run_cap=cap)

        def warm_up() -> None:  # loads what the run uses; stopped after WARMUP_CAP_S (daebench.harness.running.timing's rule)
            try:
                one_run(min(WARMUP_CAP_S, run_cap or math.inf))
            except RunTimeout:
                pass

        # one warm-up per code path and process: what it loads stays loaded for the next run of
        # the same integrator on the same model (bool/str settings can select other code)
        path = (spec.integrator, sc.model, tuple(sorted((k, v) for k, v in spec.options.items()
                                                         if isinstance(v, (bool, str)))))
        warm = timing.warmup and path not in _WARMED
        tm = time_call(one_run, repeats=timing.repeats, warmup=warm, time_cap=timing.time_cap, warmup_fn=warm_up)
        if timing.warmup:
            _WARMED.add(path)
        rec, res = tm.result
        row.update(status=res.status, message=res.message, wall_s=tm.wall_s, cpu_s=tm.cpu_s,
                   cpu_spread=tm.cpu_spread, repeats=tm.repeats, t_final=res.t_final, refused=res.refused,
                   settings=json.dumps(rec.settings, default=str))
        row.update(res.counters)
        if res.traceback:   # the exception that ended the run, the integrator's frames included
            row["traceback"] = res.traceback
        if rec.warnings:   # e.g. a step beyond the method's stability limit (harness.running.checks.check_step)
            row["warning"] = "; ".join(rec.warnings)
        row.update(metrics.stability_verdict(res.status, res.message, res.t_final, sc.t_end))
        hist = res.history
        row["digest"] = history_digest(hist)   # bitwise: equal for a repeat, under -j N and on Dask
        impacts = [float(i.t) for i in res.impacts]
        row["impact_times"] = json.dumps(impacts)
        if history_dir is not None and len(hist):
            row["history"] = str(keep_history(hist, history_dir, f"{spec.index:04d}-{spec.integrator}"))
        if len(hist):
            row.update(metrics.energy_balance(hist))
        row.update({f"{k}_max": float(v) for k, v in res.constraint_max.items()})
        run = pipeline.Run(sc, build_system(sc), hist, res.impacts, pipeline.declared(sc.model))
        row.update(pipeline.score(run, pipeline.truth(run, lambda: _reference(sc, reference_mode))))
        if res.status != "completed":
            nan_errors(row)
    except RunTimeout as exc:
        row.update(outcome_row(spec, scene, "timeout", str(exc) or "run exceeded its wall-time cap"))
        nan_errors(row)
    except RunCrashed as exc:   # its isolated process died: as a crashed worker process is
        row.update(outcome_row(spec, scene, "crashed", str(exc)))
        nan_errors(row)
    except Exception as exc:  # never lose a row
        row.update(outcome_row(spec, scene, "error", f"{type(exc).__name__}: {exc}"))
        row["traceback"] = traceback.format_exc()   # whole: the integrator's own frames are the innermost
        nan_errors(row)
    return row


