"""Stability map: the largest stable fixed step of each integrator, measured and predicted.

Measured
--------
For one integrator setting and one scene, the largest step h for which a whole trial run
*completes* — reaches its end with its energy balance within the driver's divergence
threshold (:data:`daebench.driver.history.DIVERGENCE_ENERGY` × the energy scale; the run's
status) — found by bisection in log h between ``h_min`` and ``h_max`` until the bracket
[h_stable, h_unstable] is narrower than a factor 1 + ``tol``. Bisection assumes one
boundary (stable below, unstable above); the trial length (:func:`trial_length`, 80
periods of the fastest mode by default) is chosen so that linear theory predicts one.

Predicted (linear theory, computed)
-----------------------------------
The system's frequencies at the start from its assembled mass and tangent stiffness, each
method's amplification on the undamped oscillator, and the largest step for which no mode
reaches the driver's divergence threshold (:data:`daebench.driver.history.DIVERGENCE_ENERGY`
× the energy scale) over the trial: :mod:`daebench.stepping.stability`, the same rule the
harness checks an explicit method's step with before its first step. The strict interval
{ρ ≤ 1} is reported too: ∞ for the unconditionally stable Newmark members; empty for
ABM4-PECE, whose interval for a run (Ω*) sits near 0.93 on short runs and drops towards 0.5
on long ones.

Trials run beyond the explicit methods' limits on purpose: the harness's check of the step
is off for them (``run_scene(..., step_check=False)``).
"""

from __future__ import annotations

import math
import multiprocessing as mp
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import Scene, check_name
from daebench.driver.history import DIVERGENCE_ENERGY
from daebench.core.interrupt import RunTimeout
from daebench.harness.files import ensure_writable_dir, results_dir
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.models import build_system
from daebench.stepping.stability import (OMEGA_GRID, STRICT_SLACK, AbmPece, Linearization,  # noqa: F401 (re-exported)
                                         NewmarkMember, divergence_time as _divergence_time, linearize_system,
                                         log_growth, predict as _predict, run_interval, strict_interval)
from daebench.workflows import stability_report

# the beam-impact paper's settings (docs/sources.md §G.3), plus generalized-α and two Newmark members:
# the trapezoidal rule (unconditionally stable) and Fox–Goodwin β = 1/12 (stable for hω ≤ √6)
DEFAULT_METHODS = ("baumgarte:delta=0,epsilon=0", "baumgarte:delta=10,epsilon=50",
                   "baumgarte:delta=1000,epsilon=5000", "hht:alpha=0", "hht:alpha=-0.15", "hht:alpha=-0.3333",
                   "genalpha:rho_inf=0.74", "newmark:beta=0.25", "newmark:beta=0.0833333333")
DEFAULT_N = (3, 5, 7, 9)
# trials of 80 periods of the fastest mode (≈ 530 steps near ABM4-PECE's boundary: an instability
# beyond it shows as e^18, the weak growth below it stays under e^3.4; see trial_length).
# On beam-impact that is 0.01-0.12 s (J_h = 0) and 0.03-0.32 s (with a hub): before the first
# impact (0.37 s), in the free flight that the linearization at the start describes.
DEFAULT_PERIODS = 80.0
MIN_STEPS = 100         # the largest step tried gives a trial this many steps (hω_max ≤ 5 at 80 periods)


# -- the methods and the system: daebench.stepping.stability, the one rule ------------------------
def method_of(integrator: Any) -> AbmPece | NewmarkMember | None:
    """The stability model of a fixed-step integrator instance (its ``stability_model()``;
    None: not covered)."""
    return integrator.stability_model()


def linearize(scene: Scene) -> Linearization:
    """Frequencies, seed energies and energy scale of the scene at its start
    (:func:`daebench.stepping.stability.linearize_system`)."""
    return linearize_system(build_system(scene))


def predict(method: AbmPece | NewmarkMember, lin: Linearization, t_trial: float) -> dict[str, float]:
    """Predicted h_max for a run of ``t_trial`` under the driver's divergence rule
    (:func:`daebench.stepping.stability.predict`)."""
    return _predict(method, lin, t_trial, DIVERGENCE_ENERGY)


def divergence_time(method: AbmPece | NewmarkMember, lin: Linearization, h: float) -> float:
    """Predicted time [s] at which a run at fixed step h crosses the divergence threshold in
    free flight (:func:`daebench.stepping.stability.divergence_time`)."""
    return _divergence_time(method, lin, h, DIVERGENCE_ENERGY)


# -- measured: bisection on whole runs --------------------------------------------------------------
@dataclass(frozen=True)
class Task:
    """One (integrator setting, scene) bisection."""

    scene: Scene
    integrator: str
    settings: tuple[tuple[str, Any], ...]
    label: str
    n: int | None
    h_min: float
    h_max: float
    tol: float
    t_trial: float
    run_cap: float | None = None


def run_is_stable(scene: Scene, integrator: str, settings: dict[str, Any], h: float, t_trial: float | None = None,
                  run_cap: float | None = None) -> tuple[bool, str, str]:
    """(completed?, status, message) of one fixed-step run at h (h_contact = h) to
    ``t_trial`` (the scene's t_end when None)."""
    integ = make_integrator(integrator, {**settings, "h": h, "h_contact": h})
    if t_trial is not None:
        scene = scene.with_overrides({"t_end": t_trial})
    try:
        _, res = run_scene(scene, integ, write=False, force=True, run_cap=run_cap, step_check=False)
    except RunTimeout:
        return False, "timeout", f"over the run cap of {run_cap:g} s"
    return res.status == "completed", res.status, res.message


def bisect(task: Task, report: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Largest stable h of one task: the bracket [h_stable, h_unstable] (NaN where the
    bounds were not crossed) and the status of the run at h_unstable."""
    s = dict(task.settings)
    lo, hi, bad, why, runs = math.nan, math.nan, "", "", 0

    def probe(h: float) -> bool:
        nonlocal lo, hi, bad, why, runs
        runs += 1
        ok, status, message = run_is_stable(task.scene, task.integrator, s, h, task.t_trial, task.run_cap)
        if ok:
            lo = h
        else:
            hi, bad, why = h, status, message
        return ok

    if not probe(task.h_max):
        probe(task.h_min)
    while math.isfinite(lo) and math.isfinite(hi) and hi / lo > 1.0 + task.tol:
        probe(math.sqrt(lo * hi))
    if report is not None:
        report(f"{task.label:<34s} N = {task.n!s:>4}: h_max in [{lo:.4g}, {hi:.4g}] s ({runs} runs)")
    return {"h_stable": lo, "h_unstable": hi, "unstable_status": bad, "unstable_message": why, "runs": runs}


def _solve(task: Task) -> dict[str, Any]:
    return bisect(task, lambda line: print(line, file=sys.stderr, flush=True))


def trial_length(scene: Scene, lin: Linearization, periods: float) -> float:
    """The run length of one trial: ``periods`` periods of the fastest mode at the start,
    capped at the scene's t_end. With 80 periods (≈ 500 rad) a run near ABM4-PECE's boundary
    takes ≈ 530 steps: beyond it the parasitic root grows ≥ 3.6 % a step (e^18 over the run),
    below it the principal root's weak growth (≤ 0.7 % a step, e^3.4) cannot reach the
    threshold — so the stable steps form one interval and the boundary is the method's.
    Longer runs add a band of weak instability below that boundary (:func:`divergence_time`
    predicts when it ends a whole run)."""
    w = float(lin.omega.max(initial=0.0))
    return scene.t_end if w <= 0.0 else min(scene.t_end, periods * 2.0 * math.pi / w)


@dataclass(frozen=True)
class Bisection:
    """How the largest stable step is searched: the key N stands for (``n_key``), the trial
    length (``t_end`` [s], or None: ``periods`` periods of the fastest mode,
    :func:`trial_length`), the bisection bounds ``h_min``, ``h_max`` [s] and relative
    bracket width ``tol`` (the upper bound is lowered to t_trial/:data:`MIN_STEPS`: a trial
    of fewer steps shows no instability), worker processes (``jobs``: one bisection per
    task, the tasks in parallel), the wall-time cap of one run (``run_cap`` [s]), and a step
    drawn as a line on the figure (``mark_h`` [s]); ``whole_run``: bisect a second time on
    runs over the scene's whole horizon (impacts included), the run a user makes."""

    n_key: str = "discretization.n"
    t_end: float | None = None
    periods: float = DEFAULT_PERIODS
    h_min: float = 1e-6
    h_max: float = 1e-2
    tol: float = 0.02
    jobs: int = 1
    run_cap: float | None = None
    mark_h: float | None = None
    whole_run: bool = True


def stability_map(scene: Scene, methods: Sequence[tuple[str, dict[str, Any]]], n_values: Iterable[int] | None,
                  search: Bisection = Bisection(), progress: Callable[[str], None] | None = None) -> pd.DataFrame:
    """The stability table: one row per (integrator setting, N).

    Parameters
    ----------
    scene : the case
    methods : (integrator name, settings) pairs, e.g. ``("baumgarte", {"delta": 10, "epsilon": 50})``
    n_values : values of ``search.n_key`` to sweep (None: the scene's own)
    search : trial length, bisection bounds and width, workers, run cap (:class:`Bisection`)

    Returns
    -------
    DataFrame with columns integrator, settings, label, N, omega_max [rad/s], method,
    interval_strict, interval [hω], h_pred, h_stable, h_unstable [s], unstable_status,
    runs, t_trial [s], agrees (h_pred within one bisection step of the measured bracket),
    and t_run, h_pred_run [s]: the scene's whole horizon and linear theory's largest stable
    step for a run that long — on beam-impact-hub at N = 9, Baumgarte's 5.3e-5 s for an
    80-period trial becomes 2.0e-5 s for the 1 s run (its run at 2.5e-5 s is predicted to
    diverge at 0.366 s; it does at 0.367 s). The trial measures the method's boundary; the
    run's prediction is what a user's step must stay below. With ``search.whole_run`` the
    same bisection on runs over the whole horizon (h_contact = h, impacts included):
    h_stable_run, h_unstable_run, unstable_status_run, unstable_message_run, runs_run,
    agrees_run (h_pred_run within one bisection step of that bracket; None where the run
    above it failed rather than diverged: no test of a stability prediction).
    """
    n_key, t_end, periods, h_min, h_max, tol, jobs, run_cap = (
        search.n_key, search.t_end, search.periods, search.h_min, search.h_max, search.tol, search.jobs, search.run_cap)
    scenes = []
    for n in (list(n_values) if n_values else [None]):
        sc = scene.with_overrides({n_key: n}) if n is not None else scene
        lin = linearize(sc)
        te = min(t_end, sc.t_end) if t_end is not None else trial_length(sc, lin, periods)
        scenes.append((n, sc, lin, te))
    tasks, run_tasks, meta = [], [], []
    for name, settings in methods:
        integ = make_integrator(name, settings)
        if not integ.capabilities.fixed_step or integ.adaptive:
            raise ValueError(f"integrator '{integ.name}' does not take fixed steps; the stability map bisects h")
        label = name + ("" if not settings else " " + ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                                               for k, v in settings.items()))
        meth = method_of(integ)
        strict = strict_interval(meth) if meth is not None else math.nan
        for n, sc, lin, te in scenes:
            pred = predict(meth, lin, te) if meth is not None else {"h_pred": math.nan, "interval": math.nan}
            # the run a user makes is the scene's whole horizon, not the trial: its own prediction
            run = predict(meth, lin, sc.t_end)["h_pred"] if meth is not None else math.nan
            top = min(h_max, te / MIN_STEPS)       # never fewer than MIN_STEPS steps in a trial
            tasks.append(Task(sc, name, tuple(settings.items()), label, n, min(h_min, 0.5 * top), top, tol, te,
                              run_cap))
            if search.whole_run:
                top_run = min(h_max, sc.t_end / MIN_STEPS)
                run_tasks.append(Task(sc, name, tuple(settings.items()), label + " (whole run)", n,
                                      min(h_min, 0.5 * top_run), top_run, tol, sc.t_end, run_cap))
            meta.append({"integrator": name, "settings": dict(settings), "label": label, "N": n,
                         "omega_max": float(lin.omega.max(initial=0.0)), "method": getattr(meth, "name", "n/a"),
                         "interval_strict": strict, "interval": pred["interval"], "h_pred": pred["h_pred"],
                         "t_run": sc.t_end, "h_pred_run": run})
    every = tasks + run_tasks
    if jobs > 1 and len(every) > 1:
        ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
        with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
            found = list(pool.map(_solve, every))
    else:
        found = [bisect(t, progress) for t in every]
    found_run = found[len(tasks):]
    rows = []
    for i, (m, f, t) in enumerate(zip(meta, found, tasks)):
        row = {**m, **f, "t_trial": t.t_trial, "h_top": t.h_max, "tol": tol,
               "agrees": agrees(m["h_pred"], f, tol, t.h_max)}
        if run_tasks:
            fr, tr = found_run[i], run_tasks[i]
            row.update({f"{k}_run": v for k, v in fr.items()})
            # linear theory predicts divergence; a run that failed otherwise (Newton at an impact
            # with h_contact = h, a weak instability of the constraints) is no test of it
            diverged = fr["unstable_status"] in ("", "diverged")
            row["agrees_run"] = agrees(m["h_pred_run"], fr, tol, tr.h_max) if diverged else None
        rows.append(row)
    return pd.DataFrame(rows)


def agrees(h_pred: float, found: dict[str, Any], tol: float, h_max: float) -> bool:
    """Whether the prediction lies within one bisection step (a factor 1 + tol) of the
    measured bracket; an unbounded prediction agrees when no instability was found below h_max."""
    lo, hi = found["h_stable"], found["h_unstable"]
    if not math.isfinite(h_pred):
        return bool(math.isfinite(lo) and lo >= h_max)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return False
    return lo / (1.0 + tol) <= h_pred <= hi * (1.0 + tol)


def parse_method(text: str) -> tuple[str, dict[str, Any]]:
    """``"baumgarte:delta=10,epsilon=50"`` → ("baumgarte", {"delta": 10.0, "epsilon": 50.0}),
    validated and typed by the integrator's own settings."""
    name, _, rest = text.partition(":")
    pairs = [kv for kv in rest.split(",") if kv.strip()]
    if any("=" not in kv or not kv.split("=", 1)[0].strip() for kv in pairs):
        bad = next(kv for kv in pairs if "=" not in kv or not kv.split("=", 1)[0].strip())
        raise ParamError(f"--method '{text}': '{bad}' is not name=value; write integrator:name=value,name=value, "
                         f"e.g. hht:alpha=-0.1")
    raw = dict(kv.split("=", 1) for kv in pairs)
    integ = make_integrator(name.strip(), {k.strip(): v.strip() for k, v in raw.items()})
    return integ.name, {k.strip(): integ.settings[k.strip()] for k in raw}


@dataclass
class StabilityResult:
    """The table, the files written, and what a reader is told first (``heading``: what was
    measured) and last (``summary``: how many rows agree, the runs and their wall time)."""

    table: pd.DataFrame
    files: list[Path]
    markdown: str
    heading: str
    summary: str


def _whole_numbers(text: str, key: str) -> list[int]:
    """``"3,5,7"`` → [3, 5, 7]; a ValueError that says what --n takes."""
    out = []
    for x in (x.strip() for x in text.split(",") if x.strip()):
        if not x.isdigit() or len(x) > 6:
            raise ValueError(f"--n takes whole numbers for {key}, comma-separated, e.g. --n 3,5,7 ('' = the "
                             f"scene's own, auto = {','.join(map(str, DEFAULT_N))}); got {x[:20]!r}")
        out.append(int(x))
    return out


def _check_n_key(scene: Scene, key: str) -> None:
    """Refuse an N key the scene does not have, naming the whole-number keys it has (the
    default key is allowed to be absent: the scene's own N is then used)."""
    if key in scene.schema or key == Bisection.n_key:
        return
    ints = sorted(k for k, p in scene.schema.items() if p.type is int)
    have = ", ".join(ints) if ints else "none (give --n '' to run the scene's own)"
    raise ParamError(f"--n-key '{key}': scene '{scene.name}' has no such key; its whole-number keys: {have}")


def run_stability(scene: Scene, methods: Sequence[str] = DEFAULT_METHODS, n: str = "auto",
                  search: Bisection = Bisection(), out: Path | None = None,
                  name: str | None = None, progress: Callable[[str], None] | None = None,
                  overwrite: bool = False) -> StabilityResult:
    """The stability map of ``scene`` (:func:`stability_map`) with its files under ``out``
    (default results/stability; ``<name or scene-stability>``.parquet, .csv, .md, .png:
    :mod:`.stability_report`), the folder proved writable and the name a plain file-name
    stem before any run.

    ``methods`` are ``integrator:setting=value,...`` texts (:func:`parse_method`); ``n``
    the values of ``search.n_key``, comma-separated ('': the scene's own; 'auto':
    :data:`DEFAULT_N` when the scene has that key). Files of an earlier map of the same
    name are replaced only with ``overwrite``.

    Raises
    ------
    ParamError
        For a bad method, N, N key or bound, or files that exist without ``overwrite``,
        before anything runs.
    """
    _check_n_key(scene, search.n_key)
    try:
        parsed = [parse_method(m) for m in methods]
        if n.strip() == "auto":
            n = ",".join(map(str, DEFAULT_N)) if search.n_key in scene.schema else ""
        ns = _whole_numbers(n, search.n_key) if n.strip() else None
    except ValueError as exc:
        raise ParamError(str(exc)) from None
    if ns is not None and search.n_key not in scene.schema:
        raise ParamError(f"scene '{scene.name}' has no key '{search.n_key}' to vary; give --n '' or --n-key")
    if not (0.0 < search.h_min < search.h_max) or not (0.0 < search.tol < 1.0) or search.jobs < 1 \
            or (search.t_end is not None and search.t_end <= 0.0) or search.periods <= 0.0:
        raise ParamError("need 0 < --h-min < --h-max, 0 < --tol < 1, --jobs ≥ 1, --t-end ≥ 0 and --periods > 0")
    stem = check_name(name if name is not None else f"{scene.name}-stability", "--name")
    out = ensure_writable_dir(Path(out) if out is not None else results_dir() / "stability", "output folder (--out)",
                              stem + ".parquet")
    earlier = [p.name for p in stability_report.paths(out, stem) if p.exists()]
    if earlier and not overwrite:
        raise ParamError(f"a stability map '{stem}' exists in {out} ({', '.join(earlier)}); pass --overwrite to "
                         f"replace it, or choose another --name")
    te = min(search.t_end, scene.t_end) if search.t_end is not None else None
    search = replace(search, t_end=te)
    length = f"{te:g} s" if te is not None else f"{search.periods:g} periods of the fastest mode"
    heading = (f"stability map of {scene.name}: {len(parsed)} settings × {len(ns or [None])} N, trials of {length}, "
               f"h in [{search.h_min:g}, {search.h_max:g}] s to {search.tol:.0%}, {search.jobs} job(s)")
    if progress is not None:
        progress(heading)
    wall0 = time.perf_counter()
    try:
        df = stability_map(scene, parsed, ns, search, progress)
    except ValueError as exc:
        raise ParamError(str(exc)) from None
    extra = ", ".join(f"{k}={v}" for k, v in scene.changes().items())
    title = (f"{scene.name}{' (' + extra + ')' if extra else ''}: largest stable step, trials of {length}, "
             f"bisection to {search.tol:.0%}")
    files = stability_report.write(df, out, stem, title, search.h_max, search.mark_h,
                                   scenes=((scene.name, scene.hash),))
    whole = ""
    if "agrees_run" in df:
        tested = df["agrees_run"].dropna()
        whole = (f"; over the whole run {int(tested.astype(bool).sum())}/{len(tested)} where the run diverged "
                 f"({len(df) - len(tested)} failed otherwise: no test of the prediction)")
    runs = int(df["runs"].sum() + (df["runs_run"].sum() if "runs_run" in df else 0))
    summary = (f"{int(df['agrees'].sum())}/{len(df)} rows agree with the prediction within one bisection step"
               f"{whole}; {runs} runs in {time.perf_counter() - wall0:.1f} s")
    return StabilityResult(df, files, stability_report.markdown(df, search.h_max), heading, summary)
