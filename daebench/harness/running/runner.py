"""One run from a scene: build the system and the integrator, check the run before its
first step (:mod:`.checks`), simulate under its wall-time cap (:mod:`.deadline`), write
the history (:mod:`.history_io`), and return the run's record (:class:`RunRecord`, the one
result of a run: the API's run object is a view of it). Used by the Python API,
`daebench run` and sweeps."""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

from daebench.core import interrupt
from daebench.core.params import ParamError, parse_pairs
from daebench.core.scene import Scene
from daebench.driver.simulate import RunResult, simulate
from daebench.driver.step_policy import StepPolicy
from daebench.harness.files import OutputWriteError, ensure_writable_dir, jsonable
from daebench.harness.running import checks, isolated
from daebench.harness.running.deadline import deadline
from daebench.harness.running.history_io import history_dir, history_name, write_history
from daebench.integrators.base import Integrator, IntegratorError
from daebench.integrators.registry import get_integrator
from daebench.models import build_system

DEFAULT_INTEGRATOR = "ida"


def make_integrator(name: str, options: Iterable[str] | dict[str, Any] = ()) -> Integrator:
    """An integrator from its registered name (case-insensitive) and ``name=value``
    options (validated).

    Raises
    ------
    IntegratorError
        For an unknown name or setting, a bad value, or a plugin whose constructor raises.
    """
    cls = get_integrator(name)
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
    except (Exception, SystemExit) as exc:  # a plugin's own bug: still a clean refusal before any step
        raise IntegratorError(f"integrator '{cls.name}' raised while being configured: "
                              f"{interrupt.describe_raised(exc)}") from None


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
    impact_law: str = ""   # the driver's impact law (daebench.driver.transitions.impact_law_name; "": none applied)
    warnings: list[str] = field(default_factory=list)   # e.g. a step beyond the method's stability limit

    def as_dict(self) -> dict[str, Any]:
        return {k: jsonable(v) for k, v in self.__dict__.items()}

    def to_json(self) -> str:
        return json.dumps(self.as_dict(), indent=2)


def run_scene(scene: Scene, integrator: Integrator | str = DEFAULT_INTEGRATOR,
              options: Iterable[str] | dict[str, Any] = (), out_dir: str | Path | None = None,
              write: bool = True, *, force: bool = False, run_cap: float | None = None,
              progress: Callable[[float], None] | None = None,
              record_states: bool = False, step_check: bool = True) -> tuple[RunRecord, RunResult]:
    """Run ``scene`` with ``integrator`` (an instance, or a name plus ``options``).

    Parameters
    ----------
    scene, integrator, options : what to run
    out_dir, write : where the history goes (default results/runs), and whether it is written
    force : run even when the step count or history size is beyond :mod:`.checks`' limits
    run_cap : wall-time cap in seconds (:class:`daebench.core.interrupt.RunTimeout` beyond it);
        a plugin's run under a cap runs in a forked child process, killed when it does not
        stop by itself (:mod:`.isolated`: code blocked in a system call or its own compiled loop)
    progress : called with the simulated time, at most every 0.25 s of wall time
    record_states : keep the integrator's (t, q, v, a, λ) at the output times (``RunResult.states``)
    step_check : check a conditionally stable method's step against the scene before the first
        step (:func:`.checks.check_step`: refused beyond a strict limit, a warning in the
        record for Baumgarte's ABM4, h = auto resolved)

    Raises
    ------
    ParamError
        (GuardError, IntegratorError) before the first step: bad settings, an output
        folder that cannot be written, an unknown observable, a run beyond the limits.
    """
    scene.revalidated()  # values changed in place after loading are refused like overrides
    integ = integrator if isinstance(integrator, Integrator) else make_integrator(integrator, options)
    checks.check_contacts_fit(scene, type(integ))
    system = build_system(scene)
    checks.check_fits_system(scene, type(integ), system)
    # an explicit method's step against the scene's ω_max (h = auto resolved here); the stability
    # map's trials run beyond it on purpose (step_check=False)
    warnings, chosen = checks.check_step(scene, system, integ) if step_check else ([], None)
    if chosen is not None:    # h = auto (or a default beyond the limit) resolved: a new integrator takes it
        integ = integ.with_step(chosen)
    if not force:
        checks.check_size(scene, integ)
    if write:  # the folder and the longest name written there are checked before any step
        ensure_writable_dir(history_dir(out_dir), "history folder",
                                   longest_name=f".{history_name(scene, integ)}.json.{os.getpid()}.tmp")
    checks.check_memory(scene, system)
    checks.check_observables(scene, system)
    policy = StepPolicy.of(integ)   # the run's step rules, resolved once: the driver reads them, not the integrator
    # the history keeps every observable (modal participations included); the scene's
    # output.observables are the ones scored (see bench)

    def simulated(report: Callable[[float], None] | None) -> RunResult:
        with deadline(run_cap):
            return simulate(system, integ, scene.t_end, scene["output.dt"], progress=report,
                            record_states=record_states, policy=policy)

    if run_cap and isolated.available() and isolated.is_plugin(integ):
        # a plugin's code may block where no cap reaches it (time.sleep, its own compiled loop):
        # it runs in a child process, killed beyond the cap (harness.running.isolated)
        result, _ = isolated.call(simulated, run_cap, progress, "run")
    else:
        result = simulated(progress)
    path = None
    if write:
        try:
            path = write_history(result, scene, integ, out_dir)
        except OutputWriteError as exc:
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
        t_final=result.t_final, impact_law=result.impact_law, warnings=warnings,
    )
    return rec, result
