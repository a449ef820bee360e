"""A sweep's settings as values, built once (by the command line, or from the API's
keywords) and passed unchanged through the API (:mod:`daebench.api`) and the workflows
(:mod:`daebench.workflows`) to the sweep (:func:`daebench.harness.sweeps.sweep.run_sweep`):

* :class:`Plan` — what to run (integrators × grid × steps or tolerances, fixed settings);
* :class:`SweepOptions` — how its runs are made: what a run is scored against where the
  model has no exact solution (``reference``), and three values of their own:
  :class:`Timing` (warm-up, repeats, caps), :class:`Execution` (worker processes,
  in-process, Dask; progress bars) and :class:`Storage` (table name, folder, resume,
  overwrite, kept histories).

:func:`from_keywords` maps the API's keyword arguments (``steps=…, jobs=…``) onto
them: the one place where the user-facing names meet these values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from daebench.core.params import Param, ParamError, did_you_mean
from daebench.harness.running import inputs, timing
from daebench.harness.sweeps.dask_cluster import NO_WORKERS_TIMEOUT
from daebench.integrators.base import DEFAULT_STEP

STEP_PARAM = Param("h", float, DEFAULT_STEP, "a fixed step size [s] in --steps", low=1e-12, high=1.0)
TOL_PARAM = Param("tol", float, 1e-6, "a tolerance in --tols", low=1e-14, high=1.0)
REFERENCE_MODES = ("auto", "require", "compute", "none")


class SweepError(ParamError):
    """A sweep that cannot be planned (unknown integrator or grid key …); raised before any run."""


def _numbers(values: Sequence[Any] | None, what: str) -> tuple[float, ...] | None:
    """--steps/--tols values, each checked by the one parameter rule (finite, in range)."""
    if values is None:
        return None
    if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
        raise SweepError(f"{what} must be a list of numbers, e.g. [1e-3, 5e-4]; got {values!r}")
    p = STEP_PARAM if what == "steps" else TOL_PARAM
    out = tuple(p.validate(x, what) for x in values)
    if not out:
        raise SweepError(f"{what} is empty; give at least one value")
    return out


@dataclass(frozen=True)
class Plan:
    """What to run: ``integrators`` (names, or one comma-separated string) × ``grid``
    ({key: values}: integrator settings or scene keys) × ``steps`` (fixed h [s]) or
    ``tols`` (adaptive: rtol = tol, atol = tol/100), with ``options`` fixed for every run
    that has them; ``reference``: what a run is scored against where the model has no
    exact solution ('auto': a cached reference if any, 'compute', 'require', 'none');
    ``force``: allow runs beyond the step-count limit. Steps and tolerances are checked
    and converted here."""

    integrators: tuple[str, ...]
    steps: tuple[float, ...] | None = None
    tols: tuple[float, ...] | None = None
    grid: Mapping[str, Sequence[Any]] = field(default_factory=dict)
    options: Mapping[str, Any] = field(default_factory=dict)
    force: bool = False

    def __post_init__(self) -> None:
        # the shapes of Python arguments: a ParamError, never a TypeError
        object.__setattr__(self, "integrators", tuple(inputs.names(self.integrators)))
        object.__setattr__(self, "steps", _numbers(self.steps, "steps"))
        object.__setattr__(self, "tols", _numbers(self.tols, "tols"))
        object.__setattr__(self, "grid", inputs.grid(self.grid))
        object.__setattr__(self, "options", inputs.mapping(self.options, "options", '{"alpha": -0.1}'))
        inputs.check_grid_against_modes(self.grid, self.steps, self.tols)


@dataclass(frozen=True)
class Timing:
    """How to time a run (:func:`daebench.harness.running.timing.time_call`): a warm-up run
    (stopped after WARMUP_CAP_S), then up to ``repeats`` timed runs while a run takes
    under SHORT_RUN_S, no more after ``time_cap`` s; ``run_cap``: wall-time cap of one
    run [s] (a run over it is a 'timeout' row; None: no cap)."""

    repeats: int = timing.REPEATS
    warmup: bool = True
    time_cap: float = timing.TIME_CAP_S
    run_cap: float | None = None

    @classmethod
    def for_repeats(cls, repeats: int = timing.REPEATS, run_cap: float | None = None) -> "Timing":
        """The command line's rule: a warm-up unless ``repeats`` is 1 (one cold run)."""
        return cls(repeats=repeats, warmup=not (isinstance(repeats, int) and repeats == 1), run_cap=run_cap)


@dataclass(frozen=True)
class Storage:
    """Where the table goes: results/bench/<name>.parquet (or ``folder``), rows stored as
    they finish (``write``; False: memory only); ``resume`` completes the interrupted
    sweep ``name``, ``overwrite`` replaces it; ``history_dir`` keeps each run's history."""

    write: bool = True
    name: str | None = None
    folder: str | Path | None = None
    resume: bool = False
    overwrite: bool = False
    history_dir: str | Path | None = None


@dataclass(frozen=True)
class Execution:
    """How to execute: ``executor`` 'process' (``jobs`` worker processes; a crash costs
    one row), 'inline' (this process) or 'dask' (a ``scheduler`` address, 'local' or a
    Client selects Dask too); ``progress``: bars on stderr; ``no_workers_timeout``: seconds
    a Dask cluster may have no worker while runs wait before the sweep stops
    (:mod:`daebench.harness.sweeps.dask_cluster`)."""

    jobs: int = 1
    executor: str = "process"
    scheduler: Any = None
    progress: bool = True
    no_workers_timeout: float = NO_WORKERS_TIMEOUT

    def __post_init__(self) -> None:
        t = self.no_workers_timeout
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not (math.isfinite(t) and t > 0):
            raise SweepError(f"--no-workers-timeout must be a positive number of seconds, got {t!r}")


@dataclass(frozen=True)
class SweepOptions:
    """How a sweep's runs are made: ``reference`` — what a run is scored against where the
    model has no exact solution ('auto': a cached reference if any, 'compute', 'require',
    'none') —, its :class:`Timing`, :class:`Execution` and :class:`Storage`."""

    reference: str = "auto"
    timing: Timing = Timing()
    execution: Execution = Execution()
    storage: Storage = Storage()

    def __post_init__(self) -> None:
        if self.reference not in REFERENCE_MODES:
            raise SweepError(f"unknown reference mode '{self.reference}' ({', '.join(REFERENCE_MODES)})")

    def scored_against(self, reference: str) -> "SweepOptions":
        """These options with another reference mode (a workflow that prepared the reference)."""
        return replace(self, reference=reference)


_GROUPS = ("plan", "timing", "storage", "execution")
#: the API's keyword → (concern, field); `repeats` also decides the warm-up (Timing.for_repeats)
KEYWORDS: dict[str, tuple[str, str]] = {
    **{f.name: ("plan", f.name) for f in fields(Plan) if f.name != "integrators"},
    "reference": ("options", "reference"),
    "repeats": ("timing", "repeats"), "run_cap": ("timing", "run_cap"),
    "name": ("storage", "name"), "folder": ("storage", "folder"), "write": ("storage", "write"),
    "resume": ("storage", "resume"),
    "overwrite": ("storage", "overwrite"),
    "jobs": ("execution", "jobs"), "executor": ("execution", "executor"), "scheduler": ("execution", "scheduler"),
    "progress": ("execution", "progress"), "no_workers_timeout": ("execution", "no_workers_timeout"),
}


def from_keywords(integrators: Sequence[str] | str | None, keywords: Mapping[str, Any],
                  given: Mapping[str, Any] | None = None) -> tuple[Plan, SweepOptions]:
    """The plan and the options of :func:`daebench.api.bench`'s keyword arguments.

    ``given`` holds values passed as such (``plan=``, ``options=``, or one of the options'
    parts ``timing=``, ``storage=``, ``execution=``); a keyword may not set a field of one
    of them. The API's defaults differ from the sweep's in one place: no progress bars
    unless asked.

    Raises
    ------
    SweepError
        For an unknown keyword (with the closest valid one), a keyword beside the value
        it belongs to, no integrators, or a value an option refuses.
    """
    given = {k: v for k, v in (given or {}).items() if v is not None}
    if "options" in given and given.keys() & {"timing", "storage", "execution"}:
        raise SweepError("give timing=, storage= and execution= inside options=, not beside it")
    per: dict[str, dict[str, Any]] = {g: {} for g in (*_GROUPS, "options")}
    for k, v in keywords.items():
        if k not in KEYWORDS:
            raise SweepError(f"unknown keyword argument '{k}'{did_you_mean(k, list(KEYWORDS))} "
                             f"(keywords: {', '.join(KEYWORDS)})")
        group, name = KEYWORDS[k]
        if group in given or (group != "plan" and "options" in given):
            raise SweepError(f"'{k}' is set by the {group if group in given else 'options'}= option; give it "
                             f"there, not as a keyword")
        per[group][name] = v
    if "plan" in given:
        if integrators is not None:
            raise SweepError("give the integrators in plan= or as the second argument, not both")
        plan = given["plan"]
    else:
        if integrators is None:
            raise SweepError("no integrators given (e.g. integrators=['hht', 'newmark'])")
        plan = Plan(integrators, **per["plan"])
    if "options" in given:
        return plan, given["options"]
    tm = given.get("timing") or Timing.for_repeats(**per["timing"])
    storage = given.get("storage") or Storage(**per["storage"])
    execution = given.get("execution") or Execution(**{"progress": False, **per["execution"]})
    return plan, SweepOptions(timing=tm, execution=execution, storage=storage, **per["options"])
