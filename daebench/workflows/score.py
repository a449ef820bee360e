"""`daebench score CASE FILE`: a trajectory from another code scored as a daebench run is —
by the one scoring pipeline (:func:`daebench.harness.scoring.pipeline.score`), against the
case's exact solution where it has one, else its cached (or computed) reference, over the
reference's trusted span — into one row with the columns of a sweep row
(:func:`daebench.harness.sweeps.row.execute`), marked as external (``integrator`` =
:data:`EXTERNAL`).

The file is read and checked by :mod:`daebench.harness.scoring.external` (what it may hold,
its metadata, its event sequence, every refusal). What a daebench run has and a file does
not is NaN in the row: the integrator's counters (but ``steps`` when the metadata give it),
the CPU time, ``h``; ``wall_s`` is the metadata's ``cost_s`` (NaN without one: the row is then
not placed on a work–precision figure); the energy balance needs the file's energy terms.
The exact impact oracle and the energy per impact need an impact's state, which a file does
not carry: they count its impacts as skipped.

**Cost and step.** The metadata's ``cost_s`` is the row's ``cpu_s`` (the abscissa of the
work–precision figure, :data:`daebench.harness.analysis.evidence.COST`) and its ``wall_s``:
what the other code measured, not timed here. With ``steps``, ``h`` = t_end / steps, so that a
code's files at several steps form one series with an observed order.

**Verdict.** The file is held to the rules of a run (:mod:`daebench.harness.scoring.external.judge`):
a file that went through the floor, made energy or left the case's values is ``diverged`` or
``failed``, with NaN errors, as a run that did not complete. Its start values must be the
case's (refused otherwise, unless ``allow_start_mismatch``: then a note).

The row is written to results/score/<case>-<hash8>/<label>-<key8>.json (atomically, after
every check passed: refused data writes nothing), the key a digest of everything scored —
the data, the impacts, the metadata, the options (:meth:`ExternalData.key`): the same data
scored with another impacts file or cost is another file, never the earlier one replaced. A
label names a line of a work–precision figure, as an integrator's name does: one code's files
at several step sizes share it.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import Scene
from daebench.harness.files import atomic_write, check_name_fits, ensure_writable_dir, jsonable, results_dir
from daebench.harness.references.reference import load_reference
from daebench.harness.scoring import external, metrics, pipeline
from daebench.harness.scoring.eventseq import default_windows
from daebench.harness.scoring.external import grid, judge
from daebench.harness.sweeps.row import nan_errors
from daebench.integrators.base import Counters
from daebench.integrators.declarations import EXTERNAL   # the ``integrator`` of a row scored from another code's file
from daebench.models import build_system

#: the columns an external row has beyond a sweep row's: the file's largest output spacing [s],
#: its rows, whether it was scored on the case's output times (:mod:`daebench.harness.scoring.external.grid`)
FILE_COLUMNS = ("file_dt_max", "file_rows", "file_resampled")
REFERENCE_MODES = ("compute", "require", "auto")


def is_external(table: pd.DataFrame) -> pd.Series:
    """Which rows of a table were scored from another code's file."""
    if "integrator" not in table.columns:
        return pd.Series(False, index=table.index)
    return table["integrator"].astype(str) == EXTERNAL


@dataclass(frozen=True)
class Source:
    """One external trajectory to score: the data (a path or a DataFrame), its impacts (a
    path, a DataFrame, a list of times or (t, contact) pairs; None: from the data) and
    metadata given beside the file (``label``, ``cost_s``, ``steps``; None: the file's);
    ``allow_start_mismatch``: score a file whose start differs from the case's (a note)."""

    data: Any
    impacts: Any = None
    label: str | None = None
    cost_s: float | None = None
    steps: int | None = None
    allow_start_mismatch: bool = False

    def overrides(self) -> dict[str, Any]:
        return {"label": self.label, "cost_s": self.cost_s, "steps": self.steps}


def prepare(scene: Scene, source: Source, what: str = "the data file") -> external.ExternalData:
    """The source read and checked against ``scene`` (nothing computed, nothing written).

    Raises
    ------
    daebench.harness.scoring.external.ExternalDataError
    """
    system = build_system(scene)
    return external.load(source.data, scene.t_end, system, pipeline.declared(scene.model),
                         list(scene.get("output.observables") or []), source.impacts, source.overrides(), what,
                         float(scene["output.dt"]), source.allow_start_mismatch)


def as_run(scene: Scene, ext: external.ExternalData, system: Any = None) -> pipeline.Run:
    """The external trajectory as the pipeline's :class:`~daebench.harness.scoring.pipeline.Run`."""
    return pipeline.Run(scene, system if system is not None else build_system(scene), ext.history, ext.impacts,
                        pipeline.declared(scene.model))


def truth_for(scene: Scene, ext: external.ExternalData, reference: Callable[[], Any]) -> pipeline.Truth:
    """What ``ext`` is scored against (:func:`daebench.harness.scoring.pipeline.truth`: the exact
    solution at its times, else ``reference()``), after the unit check
    (:func:`daebench.harness.scoring.external.check_units`) and the start check
    (:func:`start_notes`).

    Raises
    ------
    ParamError
        No truth (no exact solution and no reference), a likely unit error, a start that
        differs from the case's (unless the source allows it).
    """
    run = as_run(scene, ext)
    tr = pipeline.truth(run, reference)
    if tr is None:
        raise ParamError(f"case '{scene.name}' has no exact solution and no reference to score against; "
                         f"compute one (`daebench reference {scene.name}`) or let score compute it")
    external.check_units(ext.history, tr.history, [c for c in ext.history.columns if c != "t"],
                         run.declared, what=ext.source)
    start_notes(scene, ext, tr, run.system)
    return tr


def start_notes(scene: Scene, ext: external.ExternalData, tr: pipeline.Truth, system: Any) -> list[str]:
    """The columns whose first value differs from the case's start
    (:func:`daebench.harness.scoring.external.start_mismatches`), as a note when the source
    allows it.

    Raises
    ------
    ExternalDataError
        A mismatch the source does not allow: the column and both values named.
    """
    q0, v0 = system.initial_state()
    start = system.observables(0.0, np.asarray(q0, float), np.asarray(v0, float))
    found = external.start_mismatches(ext.history, start, tr.history, pipeline.declared(scene.model))
    if found and not ext.allow_start_mismatch:
        raise external.ExternalDataError(
            f"{ext.source}: the start is not the case's — {'; '.join(found)}. Set the other code up from "
            f"`daebench export {scene.name}` (the values at t = 0 it lists), or score it anyway with "
            f"--allow-start-mismatch")
    return [f"the start differs from the case's (allowed): {', '.join(found)}"] if found else []


def aligned(scene: Scene, ext: external.ExternalData, tr: pipeline.Truth, system: Any
            ) -> tuple[pipeline.Run, pipeline.Truth, list[str]]:
    """The run and truth as scored: the file's rows at an impact matched one-sidedly to the
    truth's (:func:`daebench.harness.scoring.external.grid.one_sided`, within the event
    tolerance), the exact solution taken again at the moved times; and the note saying so."""
    tol, _ = default_windows(float(scene.t_end))
    hist, moved, shift = grid.one_sided(ext.history, tr.impacts, tol)
    run = pipeline.Run(scene, system, hist, ext.impacts, pipeline.declared(scene.model))
    if not moved:
        return run, tr, []
    exact = pipeline.exact_truth(run) if tr.against == "exact solution" else None
    tr = exact if exact is not None else replace(tr, history=grid.split_truth_pairs(tr.history, tr.impacts))
    return run, tr, [f"{moved} impact(s) written as two rows matched one-sidedly to the truth's (each side "
                     f"to its own branch, the largest time shift {shift:.3g} s, within the event tolerance "
                     f"{tol:.3g} s)"]


def external_row(scene: Scene, ext: external.ExternalData, tr: pipeline.Truth, index: int = 0) -> dict[str, Any]:
    """The sweep row of an external trajectory (module docstring): the columns of
    :func:`daebench.harness.sweeps.row.execute`, the scores from the one pipeline, the
    verdict by the rules of a run, and the file's spacing (``file_dt_max`` [s],
    ``file_rows``, ``file_resampled``)."""
    system = build_system(scene)
    notes = list(ext.notes) + start_notes(scene, ext, tr, system)
    run, tr, moved = aligned(scene, ext, tr, system)
    notes += moved
    hist = ext.history
    t_final = float(hist["t"].iloc[-1])
    cols = run.scored_columns()
    status, why = judge.verdict(hist, tr.history, system, cols, {c: run.declared.get(c).unit for c in cols})
    h = float(scene.t_end) / ext.steps if math.isfinite(ext.steps) else math.nan
    row: dict[str, Any] = {
        "run": int(index), "case": scene.name, "integrator": EXTERNAL, "label": ext.label, "h": h,
        "settings": json.dumps(jsonable(ext.provenance()), sort_keys=True, default=str), "overrides": "{}",
        "scene_set": json.dumps(scene.changes(), sort_keys=True, default=str), "scene_hash": scene.hash,
        "status": status, "message": "; ".join([why] * bool(why) + notes), "wall_s": ext.cost_s,
        "cpu_s": ext.cost_s, "cpu_spread": math.nan, "repeats": 0, "t_final": t_final,
        "refused": False}   # a file is never an integrator's refusal
    row.update(dict.fromkeys(Counters().as_dict(), math.nan))
    row["steps"] = ext.steps
    row.update(metrics.stability_verdict(status, why, t_final, scene.t_end))
    row["digest"] = ext.digest
    row["impact_times"] = json.dumps([float(i.t) for i in ext.impacts])
    row.update(energy_row(hist, system))
    row.update({f"{k}_max": float(np.max(np.abs(hist[k].to_numpy(float)))) if k in hist.columns else math.nan
                for k in external.RESIDUAL_COLUMNS})
    row.update(pipeline.score(run, tr))
    row.update(zip(FILE_COLUMNS, (ext.spacing, ext.rows, ext.resampled)))
    if status != "completed":
        nan_errors(row)
    return row


def energy_row(hist: pd.DataFrame, system: Any) -> dict[str, Any]:
    """The energy-balance columns of :func:`daebench.harness.scoring.metrics.energy_balance`,
    relative to the case's energy scale (:func:`daebench.harness.scoring.external.judge.case_energy_scale`),
    not the file's values; NaN without energy terms."""
    if "E" not in hist.columns:
        return dict.fromkeys(metrics.energy_balance(pd.DataFrame({"E": [0.0, 0.0]})), math.nan)
    out = metrics.energy_balance(hist)
    scale = judge.case_energy_scale(system)
    out["energy_resid_rel"] = out["energy_resid_max"] / scale
    out["energy_ok"] = bool(out["energy_resid_max"] <= metrics.ENERGY_RTOL * scale)
    return out


@dataclass
class ScoreResult:
    """One external trajectory scored: its row (the keys of a sweep row), the checked data,
    what it was scored against, the scene and the file written (None: not written)."""

    row: dict[str, Any]
    data: external.ExternalData
    truth: pipeline.Truth
    scene: Scene
    path: Path | None = None
    notes: list[str] = field(default_factory=list)

    def as_json(self) -> str:
        """The row as one JSON record (NaN as null)."""
        return json.dumps(jsonable(self.row), default=str)

    def summary(self) -> list[tuple[str, str]]:
        """(label, text) lines of the summary :func:`summary` gives."""
        return summary(self)


def score_file(scene: Scene, source: Source, reference_mode: str = "compute",
               progress: Callable[[str, float], Any] | None = None, write: bool = True,
               out: str | Path | None = None) -> ScoreResult:
    """Read, check and score one external trajectory of ``scene``; write its row.

    Parameters
    ----------
    scene : the case (overrides applied)
    source : the data, impacts and metadata (:class:`Source`)
    reference_mode : without an exact solution: 'compute' the reference when missing (the
        default), 'require' a cached one, 'auto' (the same as 'require' here: a score needs one)
    progress : the reference computation's progress factory
    write : write the row (default results/score/<case>-<hash8>/<label>-<digest8>.json)
    out : the folder instead of the default

    Raises
    ------
    ParamError
        Refused data (:class:`daebench.harness.scoring.external.ExternalDataError`), no truth,
        a missing reference under 'require', an unusable output folder — before anything is
        written.
    """
    if reference_mode not in REFERENCE_MODES:
        raise ParamError(f"unknown reference mode '{reference_mode}': one of {', '.join(REFERENCE_MODES)}")
    ext = prepare(scene, source)
    folder = out if out is not None else default_folder(scene)   # "" stays "": refused, not the current folder
    name = f"{ext.label}-{ext.key()[:8]}.json"   # one label may name a code's runs at several steps
    mode = "compute" if reference_mode == "compute" else "require"
    tr = truth_for(scene, ext, lambda: load_reference(scene, mode=mode, progress=progress))
    if write:  # after every check of the data (a refusal leaves no folder), before the scoring
        folder = ensure_writable_dir(folder, "score folder (--out)")
        check_name_fits(folder, f".{name}.9999999.tmp", "score folder (--out)")
    res = ScoreResult(external_row(scene, ext, tr), ext, tr, scene)
    if write:
        path = folder / name
        text = res.as_json() + "\n"
        atomic_write(path, lambda p: Path(p).write_text(text, encoding="utf-8"), "the scored row")
        res.path = path
    return res


def default_folder(scene: Scene) -> Path:
    """results/score/<scene>-<first 8 digits of its hash>"""
    return results_dir() / "score" / f"{scene.name}-{scene.hash[:8]}"


def _g(x: Any, fmt: str = ".3e") -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    return format(v, fmt) if math.isfinite(v) else "-"


def impacts_text(r: Mapping[str, Any], events_from: str) -> str:
    """The summary's line on the event sequence: the counts, and where the file's came from."""
    if events_from == "none" and not int(r.get("impacts_ref", 0)):
        return "none in the data, none in the truth"
    if events_from == "none":
        return (f"none in the data (no impacts file, gap column or repeated time), {r.get('impacts_ref')} in the "
                f"truth" + (f": {r.get('impacts_missed')} missed" if int(r.get("impacts_ref", 0)) else ""))
    return (f"{r.get('impacts')} in the data (from the {events_from}), {r.get('impacts_ref')} in the truth: "
            f"{r.get('impacts_matched')} matched, {r.get('impacts_missed')} missed, {r.get('impacts_spurious')} "
            f"spurious, {r.get('impacts_merged')} merged (within {_g(r.get('impact_tol'), '.3g')} s)")


def summary(res: ScoreResult) -> list[tuple[str, str]]:
    """What `daebench score` prints: what was scored against what, the errors of each scored
    observable (whole run, trusted span, before the first impact), the event sequence, the
    graph distance, the energy balance, the cost, the notes and the file written."""
    r, ext, sc = res.row, res.data, res.scene
    declared = pipeline.declared(sc.model)
    tr = res.truth
    lines = [("scored", f"{ext.source} as '{ext.label}' on {sc.name} (scene hash {sc.hash})"),
             ("status", r["status"] + (f": {r['verdict_reason']}" if r["status"] != "completed" else "")),
             ("against", f"{tr.description}; trusted span [0, {_g(r.get('trust_t'), '.6g')}] s"
                         + (f", {r.get('trust_impacts')} impacts" if int(r.get("trust_impacts", -1)) >= 0 else ""))]
    given = set(ext.history.columns)
    names = [(d.score_name, d.text) for d in (*declared.declared, *declared.positions)
             if f"err_{d.score_name}_max" in r and ({getattr(d, "x", ""), getattr(d, "y", "")} <= given
                                                     if hasattr(d, "x") else d.name in given)]
    names += [(k[4:-4], k[4:-4]) for k in r if k.startswith("err_") and k.endswith("_max") and
              declared.by_score_name(k[4:-4]) is None and k[4:-4] in ext.history.columns]
    for n, text in names:
        lines.append((f"error {text}", f"max {_g(r.get(f'err_{n}_max'))}, final {_g(r.get(f'err_{n}_final'))}, "
                                       f"L2 {_g(r.get(f'err_{n}_l2'))}; over the trusted span max "
                                       f"{_g(r.get(f'err_{n}_max_trusted'))}"
                                       + (f"; before the first impact max {_g(r.get(f'err_pre_{n}_max'))}"
                                          if f"err_pre_{n}_max" in r and int(r.get("impacts_ref", 0)) else "")))
    lines.append(("impacts", impacts_text(r, ext.events_from)))
    if math.isfinite(float(r.get("err_impact_t_matched_max", math.nan))):
        in_order = not (int(r.get("impacts_missed", 0)) or int(r.get("impacts_spurious", 0)))
        lines.append(("impact times", (f"first {_g(r.get('err_impact1_t'))} s, " if in_order else "")
                      + f"max over the matched {_g(r.get('err_impact_t_matched_max'))} s"
                      + ("" if in_order else " (a missed or spurious impact: the k-th is not the truth's k-th)")))
    lines.append(("graph distance", f"position level {_g(r.get('err_graph_q'))} ({r.get('graph_q_worst') or '-'}), "
                                    f"velocity level {_g(r.get('err_graph_v'))} ({r.get('graph_v_worst') or '-'}); "
                                    f"scaled by the truth's span and range"))
    if "E" in ext.history.columns:
        lines.append(("energy balance", f"max |E − E0 − W + D_impacts| = {_g(r.get('energy_resid_max'))} J "
                                        f"({_g(r.get('energy_resid_rel'), '.2e')} of the case's energy scale)"))
    else:
        lines.append(("energy balance", "not scored: the data hold no energy terms (E or E_<term>)"))
    if math.isfinite(ext.cost_s) or math.isfinite(ext.steps):
        lines.append(("cost", f"{_g(ext.cost_s, '.4g')} s, {_g(ext.steps, '.0f')} steps (as the data say)"))
    lines.append(("file", f"{ext.rows} rows, largest output spacing {_g(ext.spacing, '.4g')} s (the case's "
                          f"output.dt {_g(sc['output.dt'], '.4g')} s)" + (", resampled" if ext.resampled else "")))
    notes = str(r.get("message") or "").split("; ")   # the reason (a file that did not complete), then the notes
    for note in notes[r["status"] != "completed":]:
        if note:
            lines.append(("note", note))
    if res.path is not None:
        lines.append(("written", str(res.path)))
    return lines
