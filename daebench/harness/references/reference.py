"""Reference solutions: IDA far tighter than anything scored, checked against an
independent looser run, cached by scene hash — and never trusted blindly.

A reference is two files, ``results/references/<scene>-<hash>.parquet`` (the history)
and ``.json`` (the sidecar: settings, impact times, agreement with the check run,
provenance, and what makes the pair verifiable: the SHA-256 of the parquet file, its row
count, columns and time span). Both are written atomically (temporary file, then
``os.replace``), the parquet first, so a reader sees either the old pair, or a new
parquet whose checksum does not match the old sidecar — which :func:`load_reference`
reports as damaged. Every read (:func:`daebench.harness.references.stored.validate`)
checks the sidecar, the checksum, the columns, the time
span against the scene's ``t_end``, the scene hash and the kind of reference the scene
needs (IDA, or a fine event-capturing run for friction and complementarity contacts:
:mod:`daebench.harness.references.capturing`), and the model probe (the model's physics at a few
states, recorded in the sidecar: :mod:`daebench.harness.references.modelprobe`); a damaged reference is
recomputed (``compute`` and ``auto`` modes) or refused with the command that fixes it
(``require``). A scene without a cached reference gets the one the package ships, if any,
after the same checks (:mod:`daebench.harness.references.shipped`).
"""

from __future__ import annotations

import os
from contextlib import nullcontext
from pathlib import Path
from typing import Any, Callable

import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import Scene
from daebench.driver.contact_state import contact_law_revision
from daebench.driver.simulate import simulate
from daebench.harness.files import atomic_write, write_error
from daebench.harness.references import accuracy, capturing, modelprobe, packed, side_runs
from daebench.harness.references.stored import (Reference, ReferenceDamaged, ReferenceMissing, fix_command,
                                                 reference_command, reference_path, sha256, validate, write_sidecar)
from daebench.harness.running import provenance
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.integrators.registry import get_integrator
from daebench.harness.scoring import metrics
from daebench.harness.scoring.pipeline import declared
from daebench.integrators.odeint import IndexOneODE
from daebench.models import build_system

REF_RTOL = 1e-11        # default reference tolerances (IDA)
REF_ATOL = 1e-13
REF_MARGIN = 100.0      # the reference is at least this much tighter than any scored rtol
CHECK_FACTOR = 10.0     # the independent check runs this much looser
REF_INTEGRATOR = "ida"
#: a reference stores its history at the scene's output.dt / this: runs are scored at their
#: own output times against the reference interpolated there (metrics.dense), so its rows
#: must resolve what the runs' rows alias (beam-impact: an 11 131 rad/s tone, period
#: 0.56 ms, sampled every 1 ms by a run; at 50 µs the Hermite interpolation of θ with ω
#: errs by ≈ 3e-4 of the tone's amplitude)
REF_OVERSAMPLE = 20
MODES = ("auto", "require", "compute", "none")
#: references shipped inside the package (:mod:`daebench.harness.references.shipped`)
SHIPPED_DIR = Path(__file__).resolve().parents[2] / "data" / "references"


def shipped_path(scene: Scene) -> Path:
    """Where the package keeps a shipped reference of ``scene`` (it may not exist)."""
    return SHIPPED_DIR / reference_path(scene).name


def install_shipped(scene: Scene) -> Path | None:
    """Copy the reference the package ships for ``scene`` into the cache after every check
    of :func:`validate` (a model probe required); None when it ships none for this scene
    hash (:mod:`daebench.harness.references.shipped`).

    Raises
    ------
    ReferenceDamaged
        It fails a check (damaged; stale: another model).
    """
    src = shipped_path(scene)
    if not (src.is_file() and src.with_suffix(".json").is_file()):
        return None
    try:
        ref = validate(scene, src)
        if not isinstance(ref.meta.get("model_probe"), dict):
            raise ReferenceDamaged("it has no model probe")
    except ReferenceDamaged as exc:
        raise ReferenceDamaged(f"the reference shipped for '{scene.name}' is refused: {exc}") from None
    dest = reference_path(scene)
    kept = "nothing was cached; the shipped reference stays where it is"
    try:
        dest.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(exc, "the reference folder", dest.parent, kept) from None
    hist, meta = ref.history, {k: v for k, v in ref.meta.items() if k not in (packed.DERIVED_KEY, packed.ORDER_KEY)}
    if ref.meta.get(packed.DERIVED_KEY):   # shipped thin: the columns the states determine rebuilt and checked
        try:
            hist = packed.rebuild(build_system(scene), hist, ref.meta[packed.DERIVED_KEY], ref.meta[packed.ORDER_KEY])
        except (ValueError, KeyError, TypeError) as exc:
            raise ReferenceDamaged(f"the reference shipped for '{scene.name}' is refused: {exc}") from None
    atomic_write(dest, lambda p: write_history(p, hist), "the reference", kept)
    meta.update({"installed_from": f"shipped with daebench ({src.name})", "sha256": sha256(dest),
                 "columns": list(hist.columns)})
    atomic_write(dest.with_suffix(".json"), lambda p: write_sidecar(p, meta), "the reference's sidecar", kept)
    return dest


def load_reference(scene: Scene, compute: bool = False, mode: str | None = None, **kwargs: Any) -> Reference:
    """The cached reference of ``scene``, checked.

    Parameters
    ----------
    scene : the scene (its hash names the file)
    compute : compute it when missing or damaged (same as ``mode='compute'``)
    mode : 'require' (missing or damaged: an error with the fix), 'compute' or 'auto'
        (missing: :class:`ReferenceMissing`; damaged: recomputed). Default: 'compute'
        if ``compute`` else 'require'.
    kwargs : go to :func:`compute_reference`

    Raises
    ------
    ReferenceMissing, ReferenceDamaged
    """
    mode = mode or ("compute" if compute else "require")
    path = reference_path(scene)
    if not (path.exists() and path.with_suffix(".json").exists()):
        try:
            if install_shipped(scene) is not None:
                return _meets(scene, validate(scene, path), mode, kwargs)
        except ReferenceDamaged:
            if mode not in ("compute", "auto"):
                raise
            return compute_reference(scene, **kwargs)
        if mode == "compute":
            return compute_reference(scene, **kwargs)
        raise ReferenceMissing(
            f"no reference for scene '{scene.name}' (hash {scene.hash}) at {path}. "
            f"Make it with `{reference_command(scene)}` "
            f"(or pass --reference compute / --reference none to `daebench bench`).")
    try:
        ref = validate(scene, path)
    except ReferenceDamaged:
        if mode in ("compute", "auto"):
            return compute_reference(scene, **kwargs)
        raise
    return _meets(scene, ref, mode, kwargs)


def _meets(scene: Scene, ref: Reference, mode: str, kwargs: dict[str, Any]) -> Reference:
    """``ref`` when it is at least as tight as an explicitly requested ``rtol``; otherwise
    recomputed at that rtol (modes 'compute', 'auto') or refused with the reason."""
    assessed = list((ref.meta.get("scene_values") or {}).get("output.observables") or [])
    scored = list(scene["output.observables"])
    if assessed and not (scored and set(scored) <= set(assessed)):
        # its accuracy record (trust_t) covers only the observables its scene named
        if mode in ("compute", "auto"):
            return compute_reference(scene, **kwargs)
        raise ReferenceDamaged(f"the cached reference {ref.path} assessed its accuracy on {', '.join(assessed)} only, "
                               f"this scene scores {', '.join(scored) or 'every observable'}; recompute it with "
                               f"{fix_command(scene)}")
    want = kwargs.get("rtol")
    if want is None or ref.kind != "ida" or not ref.rtol > float(want) * (1 + 1e-9):
        return ref
    if mode in ("compute", "auto"):
        return compute_reference(scene, **kwargs)
    raise ReferenceDamaged(f"the cached reference {ref.path} was computed at rtol {ref.rtol:g}, looser than the "
                           f"requested {float(want):g}; recompute it with {fix_command(scene)} --rtol {float(want):g}")


def _ida_setting(name: str) -> Any:
    """The reference solver's declared setting ``name``: its range is the one bound of a
    reference's tolerance (a value outside it is refused, never raised silently)."""
    return next(s for s in get_integrator(REF_INTEGRATOR).settings_spec if s.name == name)


def reference_tolerances(tightest_rtol: float | None = None, rtol: float | None = None,
                         atol: float | None = None) -> tuple[float, float]:
    """rtol/atol of a reference: the given ones, checked against the reference solver's
    declared ranges (:class:`ParamError` outside them); else the defaults, tightened to
    REF_MARGIN below the tightest scored rtol but not below the solver's lowest rtol."""
    if rtol is not None:
        r = float(_ida_setting("rtol").validate(rtol, "reference"))
    else:
        r = REF_RTOL if tightest_rtol is None else min(REF_RTOL, float(tightest_rtol) / REF_MARGIN)
        r = max(r, float(_ida_setting("rtol").low))
    a = (REF_ATOL * r / REF_RTOL) if atol is None else float(_ida_setting("atol").validate(atol, "reference"))
    return r, max(a, float(_ida_setting("atol").low))


def compute_reference(scene: Scene, tightest_rtol: float | None = None, rtol: float | None = None,
                      atol: float | None = None, check: bool = True,
                      progress: Callable[[str, float], Any] | None = None,
                      tightest_h: float | None = None, parallel: bool = True) -> Reference:
    """Compute, check and cache the reference of ``scene``, with its accuracy record.

    A scene with friction, with contacts left to an integrator, or whose model asks for it
    gets a fine event-capturing reference instead of IDA's
    (:func:`daebench.harness.references.capturing.reference_kind`): Moreau–Jean at a fixed step
    (at most ``tightest_h`` / STEP_MARGIN), checked by a 2× coarser run and a perturbed
    start, its accuracy record built the same way; ``rtol``/``atol`` do not apply to it.
    Otherwise the reference solver is IDA, or — for a model that declares ``reference_solver``
    (the IVP test-set mechanisms) — that solver on the index-1 ODE with per-component
    absolute tolerances rtol × the model's ``state_scale()``
    (:mod:`daebench.integrators.odeint`). It runs at (rtol, atol) (defaults 1e-11 /
    1e-13, or REF_MARGIN tighter than ``tightest_rtol``); with ``check``, again
    CHECK_FACTOR looser and again at (rtol, atol) from a start perturbed at the round-off
    level of rtol (:mod:`daebench.harness.references.accuracy`): their spread gives the digits per
    observable over time, ``trust_t`` and ``trust_impacts`` (sidecar ``accuracy``). A
    reference by the ODE solver is also checked by IDA CHECK_FACTOR looser (another method
    family; sidecar ``agreement``). All runs write REF_OVERSAMPLE× denser output than the
    scene's. With ``parallel`` the check runs are shared between the caller and forked workers
    beside the reference run (:mod:`daebench.harness.references.side_runs`: same numbers). ``progress(label, t_end)`` is a context manager factory whose value
    receives the simulated time of the reference run
    (:class:`daebench.harness.running.progress.RunProgress`).

    Raises
    ------
    RuntimeError
        If the reference run does not complete.
    """
    dense_scene = scene.with_overrides({"output.dt": scene["output.dt"] / REF_OVERSAMPLE})
    system = build_system(scene)
    kind, why = capturing.reference_kind(scene, system)
    if kind == "capturing":
        if rtol is not None or atol is not None:
            raise ParamError(f"scene '{scene.name}' has an event-capturing reference ({why}); IDA's --rtol/--atol "
                             f"do not apply to it: leave them out")
        h = capturing.reference_step(scene, REF_OVERSAMPLE, tightest_h)
        integ, res, acc_meta = capturing.capture_runs(scene, dense_scene, h, check, progress)
        return _store(scene, dense_scene, integ, res, {}, acc_meta, {"kind": kind, "why": why})
    r, a = reference_tolerances(tightest_rtol, rtol, atol)
    solver = getattr(system, "reference_solver", REF_INTEGRATOR)

    caller = os.getpid()   # a check run shows its progress where the caller makes it, not in a worker

    def run(rt: float, at: float, label: str | None, method: str = solver, start: Any = None,
            tick: Callable[[float], Any] | None = None) -> tuple[Any, Any]:
        integ = (make_integrator(REF_INTEGRATOR, {"rtol": rt, "atol": at}) if method == REF_INTEGRATOR
                 else IndexOneODE(rtol=rt, atol=at, method=method))
        shown = progress is not None and label and os.getpid() == caller
        with progress(label, scene.t_end) if shown else nullcontext() as bar:
            cb = bar if tick is None else (lambda t: (tick(t), bar(t) if bar is not None else None))
            if start is None:
                return integ, run_scene(dense_scene, integ, write=False, force=True, progress=cb)[1]
            system = accuracy.with_start(build_system(dense_scene), *start)
            return integ, simulate(system, integ, scene.t_end, dense_scene["output.dt"], progress=cb)

    def side(what: str, rt: float, at: float, method: str = solver, start: Any = None
             ) -> Callable[[], side_runs.RunSummary]:
        label = f"{what} run of {scene.name}: {method} rtol {rt:g}"
        return lambda: side_runs.RunSummary.of(run(rt, at, label, method, start)[1])

    jobs: dict[str, Callable[[], side_runs.RunSummary]] = {}
    if check:
        # the independent check: IDA CHECK_FACTOR looser (for an ODE reference, also its loose run);
        # the perturbed start; beside the reference run once it has stepped (refside: forked processes)
        jobs["check"] = side("check", r * CHECK_FACTOR, a * CHECK_FACTOR, REF_INTEGRATOR)
        if solver != REF_INTEGRATOR:
            jobs["loose"] = side("loose", r * accuracy.LOOSE_FACTOR, a * accuracy.LOOSE_FACTOR)
        jobs["perturbed"] = side("perturbed-start", r, a, start=accuracy.perturbed_start(build_system(scene), r))
        for d in accuracy.CONDITIONING_PERTURBATIONS:  # the problem's own amplification of a start error
            tol = accuracy.conditioning_tolerance(d, r)
            name = f"conditioning {d:g}"
            jobs[name] = side(name, tol, a * tol / r, start=accuracy.perturbed_start(build_system(scene), d, 1.0))
    with side_runs.SideRuns(jobs, parallel=parallel) as runs:
        integ, res = run(r, a, f"reference of {scene.name}: {solver} rtol {r:g}", tick=runs.start)
        if res.status != "completed":
            raise RuntimeError(f"reference run of '{scene.name}' {res.status}: {res.message}")
        impacts = [float(i.t) for i in res.impacts]
        agreement: dict[str, Any] = {}
        acc_meta: dict[str, Any] = {}
        if check:
            got = runs.results()
            chk = got["check"]
            agreement = {"check": f"{REF_INTEGRATOR} rtol={r * CHECK_FACTOR:g} atol={a * CHECK_FACTOR:g}",
                         "status": chk.status}
            if chk.status == "completed":
                acc = metrics.accuracy(chk.history, res.history, ref_impacts=impacts, declared=declared(scene.model))
                agreement.update({k: v for k, v in acc.items() if k.endswith("_max")})
                agreement.update(metrics.impact_time_errors(chk.impacts, impacts))
            loose, f = (got["loose"], accuracy.LOOSE_FACTOR) if "loose" in got else (chk, CHECK_FACTOR)
            pert = got["perturbed"]
            cols = list(scene["output.observables"]) or metrics.observable_columns(res.history)
            acc_meta = accuracy.assess(res.history, impacts, loose.history, pert.history, cols, scene.t_end,
                                       loose_factor=f)
            acc_meta.update({"loose": loose.status, "perturbed": pert.status,
                             "perturbed_impacts": len(pert.impacts), "loose_impacts": len(loose.impacts)})
            cond = {d: got[f"conditioning {d:g}"] for d in accuracy.CONDITIONING_PERTURBATIONS}
            acc_meta["conditioning"] = accuracy.conditioning(
                res.history, {d: (c.history, len(c.impacts)) for d, c in cond.items() if c.status == "completed"},
                cols)
    return _store(scene, dense_scene, integ, res, agreement, acc_meta, {"kind": "ida"})


def write_history(path: Path, hist: pd.DataFrame) -> None:
    """Write a reference's history as the cache keeps it (zstd, byte-stream-split floats:
    the values bit for bit)."""
    floats = [c for c in hist.columns if hist[c].dtype.kind == "f"]
    hist.to_parquet(path, index=False, compression="zstd", compression_level=9, use_dictionary=False,
                    use_byte_stream_split=floats)


def _store(scene: Scene, dense_scene: Scene, integ: Any, res: Any, agreement: dict[str, Any],
           acc_meta: dict[str, Any], extra: dict[str, Any]) -> Reference:
    """Write the reference's history and sidecar atomically (module docstring), with the
    model probe (:mod:`daebench.harness.references.modelprobe`)."""
    impacts = [float(i.t) for i in res.impacts]
    path, system = reference_path(scene), build_system(scene)
    hist = res.history
    kept = (f"the reference was computed ({res.wall_s:.3g} s) but is not cached; the runs scored against it "
            f"need it cached")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(exc, "the reference folder", path.parent, kept) from None
    for f in (path, path.with_suffix(".json")):
        if f.is_dir():
            raise ReferenceDamaged(f"the cached reference {f} is a folder, not a file; remove it (`rm -r {f}`) "
                                   f"and run {fix_command(scene)}")
    atomic_write(path, lambda p: write_history(p, hist), "the reference", kept)
    meta = {"scene": scene.name, "scene_hash": scene.hash, "scene_values": scene.values,
            "integrator": integ.name, "settings": integ.to_config(), "wall_s": res.wall_s,
            "counters": res.counters, "impacts": impacts,
            "impulses": [float(i.impulse) for i in res.impacts],   # the impulse measure's truth
            "output_dt": dense_scene["output.dt"], "agreement": agreement,
            "accuracy": acc_meta, "contact_law_revision": contact_law_revision(system),
            "energy_residual_max": res.energy_residual, "model_probe": modelprobe.record(system),
            **extra, "sha256": sha256(path), "rows": len(hist),
            "columns": list(hist.columns), "t_span": [float(hist["t"].iloc[0]), float(hist["t"].iloc[-1])]}
    meta = {**meta, "provenance": provenance.collect([scene])}
    atomic_write(path.with_suffix(".json"), lambda p: write_sidecar(p, meta), "the reference's sidecar", kept)
    return Reference(hist, impacts, meta, path)


def trust_span(scene: Scene) -> tuple[float, int]:
    """(trust_t, trust_impacts) of the cached reference of ``scene`` (module docstring).

    Raises
    ------
    ReferenceMissing, ReferenceDamaged
        No cached reference, or one without an accuracy record (computed by an older
        daebench: recompute it with ``daebench reference NAME --force``).
    """
    return load_reference(scene, mode="require").trust_span
