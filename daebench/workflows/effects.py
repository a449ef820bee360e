"""`daebench effects CASE`: what each switchable effect costs and changes.

The case runs once with its effects as the scene file has them (the *all-on* run) and
once more for each effect that is on (``effects.<name> = true``), with that one effect
turned off. Per effect: the run's verdict, its cost (wall time by the sweep's timing
rule, steps) and their change against the all-on run, and for every observable of the
scene the largest absolute difference from the all-on run over the run (the off run
interpolated linearly onto the all-on run's output times; an observable the off run does
not have is reported as missing). Effects the scene cannot turn off (its own cross-key
check refuses, e.g. a contact law without contact) are rows with their reason.

The runs are ordinary sweep runs (:func:`daebench.harness.sweeps.plan.plan_sweep` with one
scene key, :func:`daebench.harness.sweeps.sweep.run_specs`), unscored: the question is what the
effect does to this integrator's answer, not how far the answer is from a reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import Scene
from daebench.harness.files import atomic_write, ensure_writable_dir, results_dir, under_root, write_error
from daebench.harness.running import provenance
from daebench.harness.running.history_io import read_history
from daebench.harness.scoring import metrics
from daebench.harness.sweeps import sweep
from daebench.harness.sweeps.options import Execution, Storage, SweepOptions
from daebench.harness.sweeps.plan import plan_sweep

ALL_ON = "(all on)"


@dataclass
class EffectsResult:
    """The table (one row per effect turned off, and the all-on run) and its files."""

    table: pd.DataFrame
    files: list[Path] = field(default_factory=list)

    def table_rows(self) -> tuple[list[str], list[list[Any]]]:
        """The printed table (:func:`table_rows`)."""
        return table_rows(self.table)


def switchable(scene: Scene) -> list[str]:
    """The scene keys ``effects.<name>`` that are booleans and on."""
    return [k for k, v in scene.values.items() if k.startswith("effects.") and isinstance(v, bool) and v]


def max_differences(on: pd.DataFrame, off: pd.DataFrame, observables: list[str]) -> dict[str, float]:
    """max |off − on| per observable over the all-on run's output times (NaN where the off
    run lacks the observable or where the two do not overlap)."""
    out = {}
    t = on["t"].to_numpy(float)
    for c in observables:
        if c not in on.columns or c not in off.columns or not len(off):
            out[c] = math.nan
            continue
        d = np.abs(metrics.interpolate(off, c, t) - on[c].to_numpy(float))
        out[c] = float(np.nanmax(d)) if np.isfinite(d).any() else math.nan
    return out


def run_effects(scene: Scene, integrator: str = "hht", settings: Mapping[str, Any] | None = None,
                folder: Path | None = None, options: SweepOptions = SweepOptions(execution=Execution(progress=False))
                ) -> EffectsResult:
    """Run ``scene`` all on and with each switchable effect off (``integrator`` with
    ``settings``; the runs unscored, executed and timed by ``options``); the table and its
    files (effects.csv, effects.json with provenance) in ``folder`` (default
    results/effects/<scene>-<hash>).

    Raises
    ------
    ParamError
        For an unknown integrator or setting, a scene without a switchable effect, or an
        all-on run the plan refuses.
    """
    keys = switchable(scene)
    if not keys:
        raise ParamError(f"scene '{scene.name}' has no effect switched on (effects.* keys); nothing to turn off")
    folder = (Path(folder) if folder is not None
              else under_root(results_dir() / "effects", f"{scene.name}-{scene.hash[:8]}", what="the scene"))
    ensure_writable_dir(folder, "output folder (--out)")  # before the runs, not after them
    specs, refused = plan_sweep(scene, [integrator], options=dict(settings or {})), {}
    for k in keys:
        try:
            specs += plan_sweep(scene, [integrator], grid={k: [False]}, options=dict(settings or {}))
        except ParamError as exc:
            refused[k] = str(exc)
    for i, s in enumerate(specs):
        s.index = i
    unscored = replace(options, reference="none", storage=Storage(write=False, history_dir=folder / "histories"))
    df = sweep.run_specs(specs, scene, unscored, description=f"effects {scene.name}")
    obs = [str(o) for o in (scene.get("output.observables") or [])]
    hist = {int(r["run"]): read_history(r["history"]) if isinstance(r.get("history"), str) else pd.DataFrame()
            for _, r in df.iterrows()}
    base = df.iloc[0]
    rows = []
    for _, r in df.iterrows():
        eff = next(iter(json_keys(r, keys)), ALL_ON)
        row = {"effect": eff, "status": r["status"], "wall_s": float(r.get("wall_s", math.nan)),
               "steps": float(r.get("steps", math.nan)), "message": str(r.get("message", "") or "")}
        row["wall_ratio"] = row["wall_s"] / float(base.get("wall_s", math.nan))
        row["steps_ratio"] = row["steps"] / float(base.get("steps", math.nan))
        diffs = max_differences(hist[int(base["run"])], hist[int(r["run"])], obs) if r["status"] == "completed" \
            else {o: math.nan for o in obs}
        row.update({f"max_abs_d_{o}": v for o, v in diffs.items()})
        rows.append(row)
    for k, why in refused.items():
        rows.append({"effect": k.split(".", 1)[1], "status": "refused", "message": why})
    table = pd.DataFrame(rows)
    kept = "the table is printed below"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(exc, "the effects folder", folder, kept) from None
    files = [folder / "effects.csv", folder / "effects.json"]
    atomic_write(files[0], lambda p: table.to_csv(p, index=False), "the effects table", kept)
    atomic_write(files[1], lambda p: provenance.write_sidecar(p, provenance.collect([scene]), scene=scene.name,
                                                              integrator=integrator, options=dict(settings or {}),
                                                              effects=keys), "the effects sidecar", kept)
    return EffectsResult(table, files)


def json_keys(row: Mapping[str, Any], keys: list[str]) -> list[str]:
    """The effect a row turned off (its varied ``effects.*`` column), short name."""
    return [k.split(".", 1)[1] for k in keys if isinstance(row.get(k), (bool, np.bool_)) and not row.get(k)]


def table_rows(table: pd.DataFrame) -> tuple[list[str], list[list[Any]]]:
    """The printed table: effect off, verdict, wall time and steps (and × the all-on run),
    max |Δ| per observable."""
    dcols = [c for c in table.columns if c.startswith("max_abs_d_")]
    cols = ["effect off", "status", "wall[s]", "×wall", "steps", "×steps"] + ["max|Δ " + c[10:] + "|" for c in dcols]
    rows = []
    for _, r in table.iterrows():
        steps = r.get("steps")
        rows.append([r["effect"], r["status"], r.get("wall_s"), r.get("wall_ratio"),
                     int(steps) if isinstance(steps, float) and math.isfinite(steps) else steps,
                     r.get("steps_ratio")] + [r.get(c) for c in dcols])
    return cols, rows
