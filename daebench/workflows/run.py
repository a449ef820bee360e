"""One run of a scene as the user sees it (`daebench run`, :func:`daebench.run`): the run
record of :func:`daebench.harness.running.runner.run_scene` — the one result of a run —
with the integrator's arrays at the output times and the whole-run errors against the
case's exact solution or its cached reference; :class:`RunOutput` is a view of it."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import pandas as pd

from daebench.core.observables import Observables
from daebench.core.scene import Scene
from daebench.harness.references.reference import ReferenceDamaged, ReferenceMissing, load_reference
from daebench.harness.references.stored import why_no_reference
from daebench.harness.running.deadline import check_run_cap
from daebench.harness.running.inputs import mapping
from daebench.harness.running.progress import RunProgress
from daebench.harness.running.runner import RunRecord, make_integrator, run_scene
from daebench.harness.scoring import pipeline
from daebench.models import build_system


@dataclass
class RunOutput:
    """One run: its record (:class:`daebench.harness.running.runner.RunRecord`, what
    ``daebench run --json`` prints), the arrays at the output times and its errors.

    Attributes
    ----------
    record : the run record; ``integrator``, ``settings``, ``status``, ``message``,
        ``wall_s``, ``impacts``, ``counters``, ``energy_residual``, ``constraint_max`` and
        ``history_path`` read it
    t : (k,) output times [s]
    q, v : (k, n) generalized coordinates and velocities at the output times
    a : (k, n) accelerations at the output times (the integrator's own, dense output)
    lam : (k, m) the integrator's multipliers of the bilateral constraints at the output
        times (contact multipliers are the ``lambda_<i>`` observables while a contact is closed)
    observables : the history DataFrame (t, observables, energy terms, work, residuals)
    error : the whole-run errors against the case's exact solution or its cached reference,
        when one exists ({'against': ..., 'err_<observable>_{final,max,l2}': ...}), else
        {'against': None, 'why': ...}: no cached reference (with the command that makes one)
        or a damaged one (what failed, and the fix)
    traceback : for a run a step's exception ended (status failed), where it was raised,
        the integrator's own frames included; "" otherwise
    """

    record: RunRecord
    scene: Scene
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    observables: pd.DataFrame
    error: dict[str, Any] = field(default_factory=dict)
    traceback: str = ""     # where the exception that ended the run was raised (the integrator's frames)

    integrator = property(lambda self: self.record.integrator)
    settings = property(lambda self: self.record.settings)
    status = property(lambda self: self.record.status)
    message = property(lambda self: self.record.message)
    wall_s = property(lambda self: self.record.wall_s)
    impacts = property(lambda self: self.record.impacts, doc="impacts as dicts (t, contact, vn_minus, vn_plus, "
                                                                "energy_loss, closed)")
    counters = property(lambda self: self.record.counters, doc="steps, rejected, residual/Jacobian evaluations, "
                                                                  "LU factorizations, Newton iterations")
    energy_residual = property(lambda self: self.record.energy_residual,
                               doc="max ``|E − E0 − W_nc + D_impacts|`` over the run [J]")
    constraint_max = property(lambda self: self.record.constraint_max)
    history_path = property(lambda self: self.record.history)

    @property
    def verdict(self) -> str:
        return self.status

    @property
    def ok(self) -> bool:
        return self.status == "completed"

    @property
    def declared(self) -> Observables:
        """What the scene's model declares about its observables (names, units, scoring)."""
        return pipeline.declared(self.scene.model)


def errors(scene: Scene, hist: pd.DataFrame, impacts: Sequence[Any]) -> dict[str, Any]:
    """The whole-run errors of a history (:func:`daebench.harness.scoring.pipeline.score`)
    against the case's exact solution, else a valid cached reference, else {'against': None,
    'why': ...}."""

    def cached() -> Any:
        try:
            return load_reference(scene, mode="require")
        except (ReferenceMissing, ReferenceDamaged):
            return None

    run = pipeline.Run(scene, build_system(scene), hist, impacts, pipeline.declared(scene.model))
    truth = pipeline.truth(run, cached) if len(hist) else None
    if truth is None:
        return {"against": None, "why": why_no_reference(scene) if len(hist) else "the run wrote no output time"}
    scores = pipeline.score(run, truth, (pipeline.accuracy,))
    return {"against": truth.description, **{k: v for k, v in scores.items() if k.startswith("err_")}}


@dataclass(frozen=True)
class Writing:
    """Whether and where a run writes its history, and the limits it runs under: ``run_cap``
    (wall-time cap [s]), ``force`` (beyond the step-count and history-size limits)."""

    write: bool = False
    out_dir: str | Path | None = None
    run_cap: float | None = None
    force: bool = False


def run(scene: Scene, integrator: str, settings: dict[str, Any] | None = None, writing: Writing = Writing(),
        progress: bool | Any = False) -> RunOutput:
    """Run ``scene`` with ``integrator`` and its ``settings``; ``progress``: True for a bar
    on stderr, or a callable ``progress(t)``."""
    integ = make_integrator(integrator, mapping(settings, "settings", '{"h": 1e-3}'))
    check_run_cap(writing.run_cap)
    bar = RunProgress(f"{scene.name} with {integ.name}", scene.t_end) if progress is True else None
    cb = bar if bar is not None else (progress if callable(progress) else None)
    if bar is not None:
        bar.start()
    try:
        rec, res = run_scene(scene, integ, out_dir=writing.out_dir, write=writing.write, force=writing.force,
                             run_cap=writing.run_cap, progress=cb, record_states=True)
    finally:
        if bar is not None:
            bar.stop()
    st = res.states
    return RunOutput(rec, scene, st["t"], st["q"], st["v"], st["a"], st["lam"], res.history,
                     errors(scene, res.history, res.impacts), res.traceback)
