"""Sweeps, references, executors: many runs → one tidy table.

* :func:`compute_reference` / :func:`load_reference` — IDA far tighter than anything
  scored, checked against an independent run, cached by scene hash.
* :func:`plan_sweep` — the Cartesian product of integrators × grid × steps/tols, with
  every grid key classified (integrator setting or scene key) before anything runs.
* :func:`run_sweep` — runs the plan on a local process pool or a Dask cluster and
  returns one row per run. A run never stops the sweep: an exception is a row with
  status ``failed`` and its reason; a diverged run is a row with NaN errors.
"""

from __future__ import annotations

import itertools
import json
import math
import signal
import threading
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np
import pandas as pd

from daebench import metrics, provenance
from daebench.integrators import base
from daebench.integrators.base import IntegratorError
from daebench.params import ParamError, did_you_mean
from daebench.runner import make_integrator, results_dir, run_scene
from daebench.scene import Scene

REF_RTOL = 1e-11        # default reference tolerances (IDA)
REF_ATOL = 1e-13
REF_MARGIN = 100.0      # the reference is at least this much tighter than any scored rtol
CHECK_FACTOR = 10.0     # the independent check runs this much looser
TOL_ATOL_RATIO = 1e-2   # --tols t sets rtol = t, atol = t · this
REF_INTEGRATOR = "ida"


class ReferenceMissing(FileNotFoundError):
    """No cached reference for a scene; the message says which command makes one."""


class RunTimeout(BaseException):
    """A run exceeded its wall-time cap (a BaseException so that a plugin's broad
    ``except Exception`` cannot swallow it)."""


@contextmanager
def deadline(seconds: float | None):
    """Raise :class:`RunTimeout` in this thread after ``seconds`` of wall time
    (SIGALRM; only in the main thread of a process — elsewhere no cap)."""
    if not seconds or threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise RunTimeout(f"run exceeded the wall-time cap of {seconds:g} s")

    old = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, float(seconds))
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)


class SweepError(ParamError):
    """A sweep that cannot be planned (unknown integrator or grid key …); raised before any run."""


# ==== references ======================================================================
@dataclass
class Reference:
    """A reference solution: its history, impact times and the JSON sidecar."""

    history: pd.DataFrame
    impacts: list[float]
    meta: dict[str, Any]
    path: Path

    @property
    def rtol(self) -> float:
        return float(self.meta["settings"]["rtol"])


def reference_path(scene: Scene) -> Path:
    """results/references/<scene-name>-<scene.hash>.parquet"""
    return results_dir() / "references" / f"{scene.name}-{scene.hash}.parquet"


def _set_arg(scene: Scene) -> str:
    return scene.name


def load_reference(scene: Scene, compute: bool = False, **kwargs: Any) -> Reference:
    """The cached reference of ``scene``; computed when ``compute`` (else an error
    that says how to make it). ``kwargs`` go to :func:`compute_reference`."""
    path = reference_path(scene)
    side = path.with_suffix(".json")
    if not (path.exists() and side.exists()):
        if compute:
            return compute_reference(scene, **kwargs)
        raise ReferenceMissing(
            f"no reference for scene '{scene.name}' (hash {scene.hash}) at {path}. "
            f"Make it with `daebench reference {_set_arg(scene)}` plus the same --set overrides "
            f"(or pass --reference compute / --reference none to `daebench bench`).")
    meta = json.loads(side.read_text())
    return Reference(pd.read_parquet(path), list(meta.get("impacts", [])), meta, path)


def _ida_run(scene: Scene, rtol: float, atol: float) -> Any:
    integ = make_integrator(REF_INTEGRATOR, {"rtol": rtol, "atol": atol})
    _, res = run_scene(scene, integ, write=False)
    return integ, res


def reference_tolerances(tightest_rtol: float | None = None, rtol: float | None = None,
                         atol: float | None = None) -> tuple[float, float]:
    """rtol/atol of a reference: the defaults, tightened to REF_MARGIN below the
    tightest scored rtol, never below IDA's floor of 1e-14."""
    r = REF_RTOL if rtol is None else float(rtol)
    if tightest_rtol is not None:
        r = min(r, float(tightest_rtol) / REF_MARGIN)
    r = max(r, 1e-14)
    a = (REF_ATOL * r / REF_RTOL) if atol is None else float(atol)
    return r, max(a, 1e-16)


def compute_reference(scene: Scene, tightest_rtol: float | None = None, rtol: float | None = None,
                      atol: float | None = None, check: bool = True) -> Reference:
    """Compute, check and cache the reference of ``scene``.

    IDA runs at (rtol, atol) (defaults 1e-11 / 1e-13, or REF_MARGIN tighter than
    ``tightest_rtol``), then again CHECK_FACTOR looser as an independent check. The
    measured agreement (max error of the check run per observable, impact times) is
    stored in the JSON sidecar with the settings and provenance.

    Raises
    ------
    RuntimeError
        If the reference run does not complete.
    """
    r, a = reference_tolerances(tightest_rtol, rtol, atol)
    integ, res = _ida_run(scene, r, a)
    if res.status != "completed":
        raise RuntimeError(f"reference run of '{scene.name}' {res.status}: {res.message}")
    impacts = [float(i.t) for i in res.impacts]
    agreement: dict[str, Any] = {}
    if check:
        _, chk = _ida_run(scene, r * CHECK_FACTOR, a * CHECK_FACTOR)
        agreement = {"check": f"{REF_INTEGRATOR} rtol={r * CHECK_FACTOR:g} atol={a * CHECK_FACTOR:g}",
                     "status": chk.status}
        if chk.status == "completed":
            acc = metrics.accuracy(chk.history, res.history)
            agreement.update({k: v for k, v in acc.items() if k.endswith("_max")})
            agreement.update(metrics.impact_time_errors([i.t for i in chk.impacts], impacts))
    path = reference_path(scene)
    path.parent.mkdir(parents=True, exist_ok=True)
    res.history.to_parquet(path, index=False)
    meta = {"scene": scene.name, "scene_hash": scene.hash, "scene_values": scene.values,
            "integrator": REF_INTEGRATOR, "settings": integ.to_config(), "wall_s": res.wall_s,
            "counters": res.counters, "impacts": impacts, "agreement": agreement,
            "energy_residual_max": res.energy_residual}
    provenance.write_sidecar(path.with_suffix(".json"), provenance.collect([scene]), **meta)
    return Reference(res.history, impacts, meta, path)


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
    reg = base.registry()
    out = {}
    for n in names:
        if n not in reg:
            raise SweepError(f"unknown integrator '{n}' in --integrators{did_you_mean(n, reg)} "
                             f"Available: {', '.join(reg)} (see `daebench list`).")
        out[n] = reg[n].cls
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
               options: dict[str, Any] | None = None) -> list[RunSpec]:
    """Every run of the sweep, validated before anything runs.

    Integrator settings in ``grid`` vary only for integrators that have them; scene
    keys vary for all. ``steps`` sets ``h``; ``tols`` sets rtol = tol, atol =
    TOL_ATOL_RATIO·tol and adaptive = true (a non-adaptive integrator gets a row that
    says it was skipped). ``options`` are fixed settings for every integrator that
    has them.
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
    for sc in scene_combos:
        scene.with_overrides(sc)
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
        for sc in scene_combos:
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
                            cls(**opts)  # validate settings now
                        except IntegratorError as exc:
                            raise SweepError(str(exc)) from None
                    specs.append(RunSpec(len(specs), name, opts, dict(sc), varied, skip))
    return specs


# ==== one run ============================================================================
def _nan_errors(row: dict[str, Any]) -> None:
    for k in list(row):
        if k.startswith("err_"):
            row[k] = math.nan


def execute(spec: RunSpec, scene: Scene, reference_mode: str = "auto", repeats: int = 1,
            warmup: bool = False, time_cap: float = 600.0, history_dir: str | Path | None = None,
            run_cap: float | None = None) -> dict[str, Any]:
    """Run one spec and score it; never raises — an exception becomes a 'failed' row.

    ``reference_mode``: 'auto' (score if a cached reference exists), 'require',
    'compute' or 'none'. With ``history_dir`` the history is kept as
    ``<history_dir>/<run>-<integrator>.parquet`` and its path is the row's ``history``.
    ``run_cap`` (seconds) bounds each run's wall time: a run that hangs becomes a
    'failed' row saying so.
    """
    row: dict[str, Any] = {"run": spec.index, "case": scene.name, "integrator": spec.integrator,
                           "label": spec.label, **spec.varied,
                           "settings": json.dumps(spec.options, sort_keys=True, default=str),
                           "overrides": json.dumps(spec.scene_overrides, sort_keys=True, default=str)}
    try:
        sc = scene.with_overrides(spec.scene_overrides) if spec.scene_overrides else scene
        row["scene_hash"] = sc.hash
        if spec.skip:
            row.update(status="skipped", message=spec.skip, verdict="skipped", verdict_reason=spec.skip)
            return row
        cls = base.get_integrator(spec.integrator)  # entry-point loading stays out of the timing
        def one_run():
            with deadline(run_cap):
                return run_scene(sc, cls(**spec.options), write=False)

        timing = metrics.time_call(one_run, repeats=repeats, warmup=warmup, time_cap=time_cap)
        rec, res = timing.result
        row.update(status=res.status, message=res.message, wall_s=timing.wall_s, cpu_s=timing.cpu_s,
                   repeats=timing.repeats, t_final=res.t_final, settings=json.dumps(rec.settings, default=str))
        row.update(res.counters)
        row.update(metrics.stability_verdict(res.status, res.message, res.t_final, sc.t_end))
        hist = res.history
        impacts = [float(i.t) for i in res.impacts]
        row["impact_times"] = json.dumps(impacts)
        if history_dir is not None and len(hist):
            hp = Path(history_dir) / f"{spec.index:04d}-{spec.integrator}.parquet"
            hp.parent.mkdir(parents=True, exist_ok=True)
            hist.to_parquet(hp, index=False)
            row["history"] = str(hp)
        if len(hist):
            row.update(metrics.energy_balance(hist))
        row.update({f"{k}_max": float(v) for k, v in res.constraint_max.items()})
        ref = None
        if reference_mode != "none":
            try:
                ref = load_reference(sc, compute=reference_mode == "compute")
            except ReferenceMissing:
                if reference_mode == "require":
                    raise
        if ref is not None and len(hist):
            row["ref_rtol"] = ref.rtol
            row.update(metrics.accuracy(hist, ref.history, sc.get("output.observables") or None))
            row.update(metrics.event_errors(hist, impacts, ref.history, ref.impacts))
        else:
            row.update(metrics.impact_time_errors(impacts, []))
        if res.status != "completed":
            _nan_errors(row)
    except (Exception, RunTimeout) as exc:  # never lose a row
        row.update(status="failed", message=f"{type(exc).__name__}: {exc}", verdict="failed",
                   verdict_reason=f"{type(exc).__name__}: {exc}",
                   traceback=traceback.format_exc(limit=4))
        _nan_errors(row)
    return row


# ==== executors ===========================================================================
def _progress():
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeElapsedColumn(), TextColumn("{task.fields[last]}"), transient=False)


def _failed_row(spec: RunSpec, scene: Scene, exc: BaseException) -> dict[str, Any]:
    msg = f"{type(exc).__name__}: {exc}"
    return {"run": spec.index, "case": scene.name, "integrator": spec.integrator, "label": spec.label,
            **spec.varied, "settings": json.dumps(spec.options, default=str), "status": "failed",
            "message": msg, "verdict": "failed", "verdict_reason": msg}


def _run_local(specs, scene, jobs, kw, tick) -> list[dict[str, Any]]:
    rows = []
    if jobs <= 1:
        for s in specs:
            rows.append(execute(s, scene, **kw))
            tick(rows[-1])
        return rows
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futs = {pool.submit(execute, s, scene, **kw): s for s in specs}
        for f in as_completed(futs):
            try:
                rows.append(f.result())
            except BaseException as exc:  # a worker died (BrokenProcessPool …): still a row
                rows.append(_failed_row(futs[f], scene, exc))
            tick(rows[-1])
    return rows


def _run_dask(specs, scene, scheduler, jobs, kw, tick) -> list[dict[str, Any]]:
    """Runs as Dask futures. ``scheduler``: a ``Client``, an address (tcp://host:8786), or
    None / "local" for a local cluster of ``jobs`` single-threaded worker processes (a
    run's wall-time cap needs the main thread of its process, which Dask workers are not:
    under Dask a hanging run is bounded by the worker, not by ``run_cap``)."""
    try:
        from dask.distributed import Client, LocalCluster, as_completed as dask_completed
    except ImportError:
        raise SweepError("the Dask executor needs dask.distributed: pip install 'daebench[dask]' "
                         "(or pip install \"dask[distributed]\")") from None
    rows = []
    owned = scheduler is None or isinstance(scheduler, str)
    if scheduler is None or scheduler == "local":
        client = Client(LocalCluster(n_workers=max(1, int(jobs)), threads_per_worker=1, processes=True,
                                     dashboard_address=None))
    elif isinstance(scheduler, str):
        client = Client(scheduler)
    else:
        client = scheduler
    try:
        futs = [client.submit(execute, s, scene, pure=False, **kw) for s in specs]
        by_key = {f.key: s for f, s in zip(futs, specs)}
        for f in dask_completed(futs):
            try:
                rows.append(f.result())
            except BaseException as exc:
                rows.append(_failed_row(by_key[f.key], scene, exc))
            tick(rows[-1])
    finally:
        if owned:
            cluster = client.cluster
            client.close()
            if cluster is not None and (scheduler is None or scheduler == "local"):
                cluster.close()
    return rows


def run_specs(specs: Sequence[RunSpec], scene: Scene, jobs: int = 1, executor: str = "process",
              scheduler: Any = None, reference_mode: str = "auto", repeats: int = 1, warmup: bool = False,
              time_cap: float = 600.0, progress: bool = True, description: str = "runs",
              history_dir: str | Path | None = None, run_cap: float | None = None) -> pd.DataFrame:
    """Execute planned runs; one row each, in plan order."""
    kw = dict(reference_mode=reference_mode, repeats=repeats, warmup=warmup, time_cap=time_cap,
              history_dir=history_dir, run_cap=run_cap)
    bar = _progress() if progress else None
    task = bar.add_task(description, total=len(specs), last="") if bar else None

    def tick(row: dict[str, Any]) -> None:
        if bar is not None:
            bar.update(task, advance=1, last=f"{row.get('label', '')}: {row.get('status')}")

    if bar is not None:
        bar.start()
    try:
        if executor == "dask" or scheduler is not None:
            rows = _run_dask(specs, scene, scheduler, jobs, kw, tick)
        elif executor == "process":
            rows = _run_local(specs, scene, int(jobs), kw, tick)
        else:
            raise SweepError(f"unknown executor '{executor}' (process or dask)")
    finally:
        if bar is not None:
            bar.stop()
    df = pd.DataFrame(rows).sort_values("run").reset_index(drop=True)
    return df


def check_reference_tolerance(specs: Sequence[RunSpec], scene: Scene, reference_mode: str) -> None:
    """Refuse cached references that are not REF_MARGIN tighter than the tightest
    scored rtol, and (mode 'require') missing ones — before running anything."""
    if reference_mode not in ("auto", "require", "compute", "none"):
        raise SweepError(f"unknown reference mode '{reference_mode}' (auto, require, compute, none)")
    if reference_mode == "none":
        return
    tight = min((s.options["rtol"] for s in specs if "rtol" in s.options and not s.skip), default=None)
    for over in {json.dumps(s.scene_overrides, sort_keys=True) for s in specs}:
        sc = scene.with_overrides(json.loads(over)) if over != "{}" else scene
        try:
            ref = load_reference(sc)
        except ReferenceMissing:
            if reference_mode == "require":
                raise
            continue
        if tight is not None and ref.rtol > tight / REF_MARGIN:
            raise SweepError(
                f"the cached reference of '{sc.name}' (rtol {ref.rtol:g}) is not {REF_MARGIN:g}× tighter than "
                f"the tightest scored rtol {tight:g}; run `daebench reference {sc.name} --force "
                f"--rtol {tight / REF_MARGIN:g}`")


def run_sweep(scene: Scene, integrators: Sequence[str], grid: dict[str, Sequence[Any]] | None = None,
              steps: Sequence[float] | None = None, tols: Sequence[float] | None = None,
              jobs: int = 1, executor: str = "process", scheduler: Any = None,
              options: dict[str, Any] | None = None, name: str | None = None,
              reference_mode: str = "auto", repeats: int = 1, warmup: bool = False,
              time_cap: float = 600.0, write: bool = True, progress: bool = True,
              run_cap: float | None = None) -> pd.DataFrame:
    """Plan, run and score a sweep; one tidy row per run.

    Parameters
    ----------
    scene : Scene
    integrators : names from the registry
    grid : {key: values}; integrator settings (checked first) or scene keys
    steps, tols : fixed steps ``h`` or tolerances (adaptive runs); at most one
    jobs : local worker processes (1: in this process)
    executor, scheduler : 'process' (default) or 'dask'; a scheduler address, "local"
        (a local Dask cluster of ``jobs`` workers) or a ``dask.distributed.Client``
        selects Dask
    options : fixed integrator settings for every run that has them
    name : table name under results/bench/ (default ``<scene>-<hash8>``)
    reference_mode : 'auto' | 'require' | 'compute' | 'none'
    repeats, warmup, time_cap : timing (see :func:`daebench.metrics.time_call`)
    run_cap : wall-time cap of one run in seconds (None: no cap)

    Returns
    -------
    pandas.DataFrame
        Also written to results/bench/<name>.parquet and .csv with a JSON sidecar
        holding the provenance, when ``write``.
    """
    specs = plan_sweep(scene, integrators, grid, steps, tols, options)
    check_reference_tolerance(specs, scene, reference_mode)
    df = run_specs(specs, scene, jobs, executor, scheduler, reference_mode, repeats, warmup, time_cap,
                   progress, description=f"{scene.name}", run_cap=run_cap)
    if write:
        write_table(df, name or f"{scene.name}-{scene.hash[:8]}", [scene])
    return df


def write_table(df: pd.DataFrame, name: str, scenes: Iterable[Scene] = (), folder: Path | None = None
                ) -> Path:
    """results/bench/<name>.parquet + .csv + .json (provenance); returns the parquet path."""
    out = Path(folder) if folder is not None else results_dir() / "bench"
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{name}.parquet"
    df.to_parquet(path, index=False)
    df.to_csv(path.with_suffix(".csv"), index=False)
    hashes = sorted(set(df["scene_hash"].dropna())) if "scene_hash" in df else []
    pairs = [(s.name, s.hash) for s in scenes] + [(str(df["case"].iloc[0]), h) for h in hashes if len(df)]
    prov = provenance.collect(list(dict.fromkeys(pairs)))
    provenance.write_sidecar(path.with_suffix(".json"), prov, rows=len(df))
    return path


def read_table(path: str | Path) -> pd.DataFrame:
    """A sweep table from .parquet or .csv."""
    p = Path(path)
    return pd.read_parquet(p) if p.suffix == ".parquet" else pd.read_csv(p)
