"""One run from a scene: build the system and the integrator, check the run before its
first step (:mod:`daebench.harness.guards`), simulate, write the history (with a JSON sidecar
naming the scene, integrator and settings, for figure legends), and return a JSON-ready
record. Used by the Python API, `daebench run` and sweeps."""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from daebench.harness import guards
from daebench.integrators.base import Integrator, IntegratorError, get_integrator
from daebench.models import build_system
from daebench.core.params import ParamError, parse_pairs
from daebench.core.scene import Scene
from daebench.driver.simulate import RunResult, simulate

DEFAULT_INTEGRATOR = "ida"


def results_dir() -> Path:
    """Where runs write: $DAEBENCH_RESULTS or ./results."""
    return Path(os.environ.get("DAEBENCH_RESULTS", "results"))


def make_integrator(name: str, options: Iterable[str] | dict[str, Any] = ()) -> Integrator:
    """An integrator from its registered name (case-insensitive) and ``name=value``
    options (validated).

    Raises
    ------
    IntegratorError
        For an unknown name or setting, a bad value, or a plugin whose constructor raises.
    """
    cls = get_integrator(guards.resolve_integrator(name))
    if isinstance(options, dict):
        opts = dict(options)
    else:
        try:
            opts = parse_pairs(options, "--opt", "h=1e-4")
        except ParamError as exc:
            raise IntegratorError(str(exc)) from None
    try:
        return cls(**opts)
    except IntegratorError:
        raise
    except Exception as exc:  # a plugin's own bug: still a clean refusal before any step
        raise IntegratorError(f"integrator '{cls.name}' raised while being configured: "
                              f"{type(exc).__name__}: {exc}") from None


@dataclass
class RunRecord:
    scene: str
    scene_hash: str
    integrator: str
    settings: dict[str, Any]
    status: str
    message: str
    wall_s: float
    counters: dict[str, int]
    energy_residual: float
    observables: dict[str, float]
    history: str | None
    impacts: list[dict[str, Any]] = field(default_factory=list)
    constraint_max: dict[str, float] = field(default_factory=dict)
    t_final: float = math.nan
    impact_law: str = ""   # the driver's impact law (daebench.driver.events.impact_law_name; "": none applied)

    def as_dict(self) -> dict[str, Any]:
        return {k: _jsonable(v) for k, v in self.__dict__.items()}

    def to_json(self) -> str:
        return json.dumps(self.as_dict(), indent=2)


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return None if not math.isfinite(float(x)) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def run_scene(scene: Scene, integrator: Integrator | str = DEFAULT_INTEGRATOR,
              options: Iterable[str] | dict[str, Any] = (), out_dir: str | Path | None = None,
              write: bool = True, *, force: bool = False, run_cap: float | None = None,
              progress: Callable[[float], None] | None = None,
              record_states: bool = False) -> tuple[RunRecord, RunResult]:
    """Run ``scene`` with ``integrator`` (an instance, or a name plus ``options``).

    Parameters
    ----------
    scene, integrator, options : what to run
    out_dir, write : where the history goes (default results/runs), and whether it is written
    force : run even when the step count or history size is beyond :mod:`daebench.harness.guards`' limits
    run_cap : wall-time cap in seconds (:class:`daebench.harness.guards.RunTimeout` beyond it)
    progress : called with the simulated time, at most every 0.25 s of wall time
    record_states : keep the integrator's (t, q, v, a, λ) at the output times (``RunResult.states``)

    Raises
    ------
    ParamError
        (GuardError, IntegratorError) before the first step: bad settings, an output
        folder that cannot be written, an unknown observable, a run beyond the limits.
    """
    integ = integrator if isinstance(integrator, Integrator) else make_integrator(integrator, options)
    guards.check_contacts_fit(scene, type(integ))
    if not force:
        guards.check_size(scene, integ)
    if write:  # the folder and the longest name written there are checked before any step
        guards.ensure_writable_dir(history_dir(out_dir), "history folder",
                                   longest_name=f".{history_name(scene, integ)}.json.{os.getpid()}.tmp")
    system = build_system(scene)
    guards.check_observables(scene, system)
    # the history keeps every observable (modal participations included); the scene's
    # output.observables are the ones scored (see bench)
    with guards.deadline(run_cap):
        result = simulate(system, integ, scene.t_end, scene["output.dt"], progress=progress,
                          record_states=record_states)
    path = None
    if write:
        try:
            path = write_history(result, scene, integ, out_dir)
        except guards.OutputWriteError as exc:
            exc.result = result  # what was computed stays reachable (the API's callers)
            raise
    final = {}
    if len(result.history):
        last = result.history.iloc[-1]
        final = {k: float(last[k]) for k in result.history.columns
                 if k != "t" and not k.startswith(("E_", "W_")) and not isinstance(last[k], str)}
        final["t"] = float(last["t"])
    rec = RunRecord(
        scene=scene.name, scene_hash=scene.hash, integrator=integ.name, settings=dict(integ.settings),
        status=result.status, message=result.message, wall_s=result.wall_s, counters=result.counters,
        energy_residual=result.energy_residual, observables=final, history=str(path) if path else None,
        impacts=[i.as_dict() for i in result.impacts], constraint_max=result.constraint_max,
        t_final=result.t_final, impact_law=result.impact_law,
    )
    return rec, result


def run_id(scene: Scene, integ: Integrator) -> str:
    body = json.dumps({"scene": scene.hash, "cfg": integ.to_config()}, sort_keys=True, default=str)
    return hashlib.sha256(body.encode()).hexdigest()[:10]


def history_dir(out_dir: str | Path | None) -> Path:
    """The folder histories go to: ``out_dir`` or results/runs."""
    if out_dir is not None and not isinstance(out_dir, (str, os.PathLike)):
        raise guards.GuardError(f"out_dir must be a folder path (a string), e.g. \"results/runs\"; got {out_dir!r}")
    return Path(out_dir) if out_dir is not None else results_dir() / "runs"


def write_history(result: RunResult, scene: Scene, integ: Integrator, out_dir: str | Path | None) -> Path:
    """<folder>/<scene>-<integrator>-<run id>.<csv|parquet>, written atomically, plus a
    .json sidecar (scene, integrator, settings, status) that figures use for legends."""
    out = history_dir(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise guards.write_error(exc, "the history folder", out, "the run finished; its history was not kept") from None
    path = out / history_name(scene, integ)
    kept = f"the run itself finished ({result.status}); only its history file is missing"
    if path.suffix == ".parquet":
        guards.atomic_write(path, lambda p: result.history.to_parquet(p, index=False), "the history", kept)
    else:
        guards.atomic_write(path, lambda p: result.history.to_csv(p, index=False, float_format="%.17g"),
                            "the history", kept)
    side = {"scene": scene.name, "scene_hash": scene.hash, "integrator": integ.name,
            "settings": _jsonable(dict(integ.settings)), "status": result.status, "message": result.message,
            "impact_law": result.impact_law}
    guards.atomic_write(path.with_suffix(".json"), lambda p: p.write_text(json.dumps(side, indent=2)),
                        "the history's sidecar", f"the history is in {path}")
    return path


def history_name(scene: Scene, integ: Integrator) -> str:
    """<scene>-<integrator>-<run id>.<csv|parquet>"""
    return f"{scene.name}-{integ.name}-{run_id(scene, integ)}.{scene.get('output.format', 'csv')}"
