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

from daebench.harness import metrics
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
    from daebench.harness import guards

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
    error : the error against the case's exact solution or its cached reference, when one
        exists ({'against': ..., 'err_<observable>_max': ...}), else {}
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


def exact_or_reference_error(scene: Scene, system: Any, hist: pd.DataFrame) -> dict[str, Any]:
    """Errors of a history against the case's exact solution (a model with
    ``exact_theta``/``exact_position``), else against a valid cached reference, else {}."""
    if not len(hist):
        return {}
    t = hist["t"].to_numpy(float)
    out: dict[str, Any] = {}
    if hasattr(system, "exact_theta") and "theta_deg" in hist:
        try:
            e = hist["theta_deg"].to_numpy(float) - np.rad2deg(system.exact_theta(t))
            out.update(metrics.error_norms(e, "err_theta"))
            if hasattr(system, "exact_position") and {"x", "y"} <= set(hist.columns):
                xy = system.exact_position(t)
                out.update(metrics.error_norms(np.hypot(hist["x"] - xy[0], hist["y"] - xy[1]), "err_pos"))
            return {"against": "exact solution", **out}
        except ValueError:  # outside the exact solution's range (e.g. a revolving pendulum)
            out = {}
    from daebench.harness.references import ReferenceDamaged, ReferenceMissing, load_reference

    try:
        ref = load_reference(scene, mode="require")
    except (ReferenceMissing, ReferenceDamaged):
        return {}
    scored = [o for o in scene.get("output.observables") or [] if o in hist.columns]
    acc = metrics.accuracy(hist, ref.history, scored or None, ref_impacts=ref.impacts)
    return {"against": f"cached reference (IDA rtol {ref.rtol:g})",
            **{k: v for k, v in acc.items() if k.endswith("_max")}}


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
    run_cap : wall-time cap [s]; :class:`daebench.harness.guards.RunTimeout` beyond it
    force : run even beyond the step-count and history-size limits
    progress : True for a progress bar on stderr, or a callable ``progress(t)``

    Returns
    -------
    RunOutput
    """
    from daebench.harness.progress import RunProgress
    from daebench.harness.runner import make_integrator, run_scene

    sc = load_scene(scene, overrides)
    integ = make_integrator(integrator, {**(settings or {}), **setting_kw})
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
                     rec.constraint_max, rec.history, exact_or_reference_error(sc, build_system(sc), hist), rec)


# ---- references and sweeps ----------------------------------------------------------------------
def reference(scene: SceneLike, *, overrides: Iterable[str] | dict[str, Any] | None = None,
              rtol: float | None = None, atol: float | None = None, force: bool = False,
              progress: bool = False) -> Any:
    """The cached reference of a scene (history, impact times, sidecar), computed when
    missing, damaged or ``force`` (IDA at rtol 1e-11 by default, checked against a 10×
    looser run). Returns a :class:`daebench.harness.references.Reference`."""
    from daebench.harness import references
    from daebench.harness.progress import run_progress_factory

    sc = load_scene(scene, overrides)
    for name, x in (("rtol", rtol), ("atol", atol)):
        if x is not None:
            Param(name, float, 0.0, f"IDA {name} of the reference", low=1e-16, high=1e-2).validate(x, "reference")
    kw = dict(rtol=rtol, atol=atol, progress=run_progress_factory(progress))
    if force:
        return references.compute_reference(sc, **kw)
    return references.load_reference(sc, mode="compute", **kw)


def bench(scene: SceneLike, integrators: Sequence[str] | str, *, steps: Sequence[float] | None = None,
          tols: Sequence[float] | None = None, grid: dict[str, Sequence[Any]] | None = None,
          options: dict[str, Any] | None = None, overrides: Iterable[str] | dict[str, Any] | None = None,
          reference: str = "auto", jobs: int = 1, name: str | None = None, write: bool = True,
          resume: bool = False, overwrite: bool = False, run_cap: float | None = None, repeats: int = 3,
          scheduler: Any = None, executor: str = "process", progress: bool = False,
          force: bool = False) -> pd.DataFrame:
    """Sweep integrators × grid × steps (or tolerances) on a scene; one scored row per run.

    Parameters
    ----------
    scene, overrides : as for :func:`run`
    integrators : names, or one comma-separated string (``"hht,newmark"``)
    steps, tols : fixed steps h [s], or tolerances (adaptive runs: rtol = tol, atol = tol/100)
    grid : {key: values}: an integrator setting or a scene key
    options : integrator settings fixed for every run that has them
    reference : 'auto' (score if a reference is cached), 'compute', 'require', 'none'
    jobs : worker processes (a crashing run costs only its own row)
    name, write, resume, overwrite : the table results/bench/<name>.parquet (unique name
        by default; rows stored as they finish; ``resume`` completes an interrupted sweep)
    run_cap : wall-time cap of one run [s]; a run over it is a 'timeout' row
    repeats : timed runs (minimum taken) after a warm-up run, made while a run takes
        under a second (:data:`daebench.harness.timing.REPEATS`); 1: one cold run, no warm-up
    scheduler : Dask scheduler address, 'local', or a Client
    executor : 'process' (default), 'inline' (this process, no isolation) or 'dask'

    Returns
    -------
    pandas.DataFrame
        One row per run: label, settings, status, verdict, wall_s, counters, errors
        (``err_<observable>_{final,max,l2}``), energy and constraint residuals.
    """
    from daebench.harness import bench as B

    sc = load_scene(scene, overrides)
    names = [x.strip() for x in integrators.split(",")] if isinstance(integrators, str) else list(integrators)
    return B.run_sweep(sc, names, grid, _numbers(steps, "steps"), _numbers(tols, "tols"), jobs=jobs,
                       executor=executor, scheduler=scheduler, options=options, name=name,
                       reference_mode=reference, repeats=repeats, warmup=repeats > 1, write=write,
                       progress=progress, run_cap=run_cap, resume=resume, overwrite=overwrite, force=force)


STEP_PARAM = Param("h", float, 1e-4, "a fixed step size [s] in --steps", low=1e-12, high=1.0)
TOL_PARAM = Param("tol", float, 1e-6, "a tolerance in --tols", low=1e-14, high=1.0)


def _numbers(values: Sequence[Any] | None, what: str) -> list[float] | None:
    """--steps/--tols values, each checked by the one parameter rule (finite, in range)."""
    if values is None:
        return None
    if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
        raise _sweep_error(f"{what} must be a list of numbers, e.g. [1e-3, 5e-4]; got {values!r}")
    p = STEP_PARAM if what == "steps" else TOL_PARAM
    out = [p.validate(x, what) for x in values]
    if not out:
        raise _sweep_error(f"{what} is empty; give at least one value")
    return out


def _sweep_error(msg: str) -> Exception:
    from daebench.harness.bench import SweepError

    return SweepError(msg)
