"""The Python API: what the command line does, as functions that return arrays and tables.

>>> import daebench
>>> r = daebench.run("pendulum", integrator="hht", h=1e-3)
>>> r.t.shape, r.q.shape, r.status                    # doctest: +SKIP
((1001,), (1001, 2), 'completed')
>>> r.error                                           # doctest: +SKIP
{'against': 'exact solution', 'err_theta_max': 2.3e-05, ...}
>>> df = daebench.bench("pendulum", ["hht", "newmark"], steps=[1e-2, 5e-3])   # doctest: +SKIP

Every function validates its arguments as the command line does and raises
:class:`daebench.core.params.ParamError` (or a subclass) with a message that says what to
change. The command line (:mod:`daebench.cli.app`) is a thin layer over these functions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np
import pandas as pd

from daebench.integrators.base import Capabilities
from daebench.models import build_system
from daebench.core.params import Param
from daebench.core.scene import Scene
from daebench.models.scenes import load_scene as _load_scene

SceneLike = str | Path | Scene


def load_scene(scene: SceneLike, overrides: Iterable[str] | dict[str, Any] | None = None) -> Scene:
    """A validated scene: a case name (``"beam-impact"``), a path to a TOML file, or a
    :class:`~daebench.core.scene.Scene`, with ``overrides`` ({key: value} or ["key=value"])."""
    if isinstance(scene, Scene):
        return scene.with_overrides(overrides) if overrides else scene
    return _load_scene(scene, overrides or ())


# ---- catalogues -----------------------------------------------------------------------------
@dataclass(frozen=True)
class IntegratorInfo:
    """What an integrator declares: settings (type, default, range, meaning) and capabilities."""

    name: str
    description: str
    distribution: str
    capabilities: Capabilities | None
    settings: tuple[Param, ...] = ()
    error: str = ""          # why a plugin could not be loaded (then capabilities is None)

    def settings_table(self) -> pd.DataFrame:
        """One row per setting: name, type/range, default, unit-bearing meaning."""
        return pd.DataFrame([{"setting": p.name, "type / range": p.describe(), "default": p.default,
                              "meaning": p.doc} for p in self.settings])


def integrator_infos() -> dict[str, IntegratorInfo]:
    """Every registered integrator (built-in and plugins), by name."""
    from daebench.integrators import base

    out = {}
    for name, reg in base.registry().items():
        cls = reg.cls
        out[name] = IntegratorInfo(name, cls.description if cls else "", reg.distribution,
                                   cls.capabilities if cls else None, tuple(cls.settings_spec) if cls else (),
                                   reg.error)
    return out


def integrator_info(name: str) -> IntegratorInfo:
    """One integrator's declaration; ``name`` is case-insensitive (did-you-mean on a typo)."""
    from daebench.harness.running import checks as guards

    return integrator_infos()[guards.resolve_integrator(name)]


def cases() -> pd.DataFrame:
    """The named scenes (``cases/``): name, model and description."""
    from daebench.core.scene import list_scenes

    rows = []
    for name, desc in list_scenes():
        rows.append({"case": name, "model": _load_scene(name).model, "description": desc})
    return pd.DataFrame(rows)


# ---- one run ----------------------------------------------------------------------------------
@dataclass
class RunOutput:
    """One run's arrays and verdict.

    Attributes
    ----------
    t : (k,) output times [s]
    q, v : (k, n) generalized coordinates and velocities at the output times
    a : (k, n) accelerations at the output times (the integrator's own, dense output)
    lam : (k, m) the integrator's multipliers of the bilateral constraints at the output
        times (contact multipliers are the ``lambda_<i>`` observables while a contact is closed)
    observables : the history DataFrame (t, observables, energy terms, work, residuals)
    impacts : impacts as dicts (t, contact, vn_minus, vn_plus, energy_loss, closed)
    counters : steps, rejected, residual/Jacobian evaluations, LU factorizations, Newton iterations
    energy_residual : max |E − E0 − W_nc + D_impacts| over the run [J]
    status, message : completed | diverged | failed, and why
    error : the whole-run errors against the case's exact solution or its cached reference,
        when one exists ({'against': ..., 'err_<observable>_{final,max,l2}': ...}), else
        {'against': None, 'why': ...}: no cached reference (with the command that makes one)
        or a damaged one (what failed, and the fix)
    """

    scene: Scene
    integrator: str
    settings: dict[str, Any]
    status: str
    message: str
    wall_s: float
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    observables: pd.DataFrame
    impacts: list[dict[str, Any]]
    counters: dict[str, int]
    energy_residual: float
    constraint_max: dict[str, float]
    history_path: str | None = None
    error: dict[str, Any] = field(default_factory=dict)
    record: Any = field(default=None, repr=False)

    @property
    def verdict(self) -> str:
        return self.status

    @property
    def ok(self) -> bool:
        return self.status == "completed"


def _error(scene: Scene, hist: pd.DataFrame, impacts: Sequence[Any]) -> dict[str, Any]:
    """The whole-run errors of a history (:func:`daebench.harness.scoring.pipeline.score`) against
    the case's exact solution, else a valid cached reference, else {}."""
    from daebench.harness.scoring import pipeline as scoring
    from daebench.harness.references.reference import ReferenceDamaged, ReferenceMissing, load_reference

    def cached() -> Any:
        try:
            return load_reference(scene, mode="require")
        except (ReferenceMissing, ReferenceDamaged):
            return None

    run = scoring.Run(scene, build_system(scene), hist, impacts, scoring.declared(scene.model))
    truth = scoring.truth(run, cached) if len(hist) else None
    if truth is None:
        from daebench.harness.references.reference import why_no_reference

        return {"against": None, "why": why_no_reference(scene) if len(hist) else "the run wrote no output time"}
    scores = scoring.score(run, truth, (scoring.accuracy,))
    return {"against": truth.description, **{k: v for k, v in scores.items() if k.startswith("err_")}}


def run(scene: SceneLike, integrator: str = "ida", *, overrides: Iterable[str] | dict[str, Any] | None = None,
        settings: dict[str, Any] | None = None, write: bool = False, out_dir: str | Path | None = None,
        run_cap: float | None = None, force: bool = False, progress: bool | Any = False,
        **setting_kw: Any) -> RunOutput:
    """Run one scene with one integrator.

    Parameters
    ----------
    scene : case name, path to a TOML file, or a Scene
    integrator : registered name, case-insensitive (default ``"ida"``)
    overrides : scene keys, ``{"t_end": 0.5}`` or ``["t_end=0.5"]``
    settings, **setting_kw : integrator settings, e.g. ``h=1e-3, alpha=-0.1``
    write, out_dir : also write the history file (default folder results/runs)
    run_cap : wall-time cap [s]; :class:`daebench.harness.running.deadline.RunTimeout` beyond it
    force : run even beyond the step-count and history-size limits
    progress : True for a progress bar on stderr, or a callable ``progress(t)``

    Returns
    -------
    RunOutput
    """
    from daebench.harness.running.progress import RunProgress
    from daebench.harness.running.runner import make_integrator, run_scene

    sc = load_scene(scene, overrides)
    from daebench.harness.running.inputs import mapping

    integ = make_integrator(integrator, {**mapping(settings, "settings", '{"h": 1e-3}'), **setting_kw})
    bar = RunProgress(f"{sc.name} with {integ.name}", sc.t_end) if progress is True else None
    cb = bar if bar is not None else (progress if callable(progress) else None)
    if bar is not None:
        bar.start()
    try:
        rec, res = run_scene(sc, integ, out_dir=out_dir, write=write, force=force, run_cap=run_cap,
                             progress=cb, record_states=True)
    finally:
        if bar is not None:
            bar.stop()
    hist = res.history
    st = res.states
    return RunOutput(sc, rec.integrator, rec.settings, rec.status, rec.message, rec.wall_s, st["t"], st["q"],
                     st["v"], st["a"], st["lam"], hist, rec.impacts, rec.counters, rec.energy_residual,
                     rec.constraint_max, rec.history, _error(sc, hist, res.impacts), rec)


# ---- references and sweeps ----------------------------------------------------------------------
def reference(scene: SceneLike, *, overrides: Iterable[str] | dict[str, Any] | None = None,
              rtol: float | None = None, atol: float | None = None, force: bool = False,
              progress: bool = False) -> Any:
    """The cached reference of a scene (history, impact times, sidecar), computed when
    missing, damaged or ``force`` (IDA at rtol 1e-11 by default, checked against a 10×
    looser run). Returns a :class:`daebench.harness.references.reference.Reference`."""
    from daebench.harness.references import reference as references
    from daebench.harness.running.progress import run_progress_factory

    sc = load_scene(scene, overrides)
    for name, x in (("rtol", rtol), ("atol", atol)):
        if x is not None:
            Param(name, float, 0.0, f"IDA {name} of the reference", low=1e-16, high=1e-2).validate(x, "reference")
    kw = dict(rtol=rtol, atol=atol, progress=run_progress_factory(progress))
    if force:
        return references.compute_reference(sc, **kw)
    return references.load_reference(sc, mode="compute", **kw)


def bench(scene: SceneLike, integrators: Sequence[str] | str | None = None, *,
          overrides: Iterable[str] | dict[str, Any] | None = None, plan: Any = None, timing: Any = None,
          storage: Any = None, execution: Any = None, **keywords: Any) -> pd.DataFrame:
    """Sweep integrators × grid × steps (or tolerances) on a scene; one scored row per run.

    The sweep's settings are four values (:mod:`daebench.harness.sweeps.options`): ``plan``
    (what to run), ``timing``, ``storage``, ``execution``; or, for convenience, these
    keyword arguments (mapped onto them by :func:`daebench.harness.sweeps.options.from_keywords`):

    Parameters
    ----------
    scene, overrides : as for :func:`run`
    integrators : names, or one comma-separated string (``"hht,newmark"``)
    steps, tols : fixed steps h [s], or tolerances (adaptive runs: rtol = tol, atol = tol/100)
    grid : {key: values}: an integrator setting or a scene key
    options : integrator settings fixed for every run that has them
    reference : 'auto' (score if a reference is cached), 'compute', 'require', 'none'; a
        model with an exact solution is scored against it
    force : allow runs beyond the step-count limit
    jobs : worker processes (a crashing run costs only its own row)
    scheduler : Dask scheduler address, 'local', or a Client
    executor : 'process' (default), 'inline' (this process, no isolation) or 'dask'
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
    from daebench.harness.sweeps import sweep as B
    from daebench.harness.sweeps import options

    sc = load_scene(scene, overrides)
    given = dict(plan=plan, timing=timing, storage=storage, execution=execution)
    return B.run_sweep(sc, *options.from_keywords(integrators, keywords, given))
