"""One run from a scene: build the system and the integrator, simulate, write the
history, and return a JSON-ready record. Used by `daebench run` and by sweeps."""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from daebench.integrators.base import Integrator, IntegratorError, get_integrator
from daebench.models import build_system
from daebench.params import ParamError, parse_pairs
from daebench.scene import Scene
from daebench.simulate import RunResult, simulate

DEFAULT_INTEGRATOR = "ida"


def results_dir() -> Path:
    """Where runs write: $DAEBENCH_RESULTS or ./results."""
    return Path(os.environ.get("DAEBENCH_RESULTS", "results"))


def make_integrator(name: str, options: Iterable[str] | dict[str, Any] = ()) -> Integrator:
    """An integrator from its registered name and ``name=value`` options (validated)."""
    cls = get_integrator(name)
    if isinstance(options, dict):
        opts = dict(options)
    else:
        try:
            opts = parse_pairs(options, "--opt", "h=1e-4")
        except ParamError as exc:
            raise IntegratorError(str(exc)) from None
    return cls(**opts)


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
              write: bool = True) -> tuple[RunRecord, RunResult]:
    """Run ``scene`` with ``integrator`` (an instance, or a name plus ``options``)."""
    integ = integrator if isinstance(integrator, Integrator) else make_integrator(integrator, options)
    system = build_system(scene)
    # the history keeps every observable (modal participations included); the scene's
    # output.observables are the ones scored (see bench)
    result = simulate(system, integ, scene.t_end, scene["output.dt"])
    path = None
    if write:
        path = write_history(result, scene, integ, out_dir)
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
        t_final=result.t_final,
    )
    return rec, result


def run_id(scene: Scene, integ: Integrator) -> str:
    body = json.dumps({"scene": scene.hash, "cfg": integ.to_config()}, sort_keys=True, default=str)
    return hashlib.sha256(body.encode()).hexdigest()[:10]


def write_history(result: RunResult, scene: Scene, integ: Integrator, out_dir: str | Path | None) -> Path:
    out = Path(out_dir) if out_dir is not None else results_dir() / "runs"
    out.mkdir(parents=True, exist_ok=True)
    fmt = scene.get("output.format", "csv")
    path = out / f"{scene.name}-{integ.name}-{run_id(scene, integ)}.{fmt}"
    if fmt == "parquet":
        result.history.to_parquet(path, index=False)
    else:
        result.history.to_csv(path, index=False, float_format="%.17g")
    return path
