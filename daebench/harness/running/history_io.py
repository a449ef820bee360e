"""A run's history on disk: where it goes, its name, writing it with its JSON sidecar,
and reading it back — the one place history files are written and read.

``daebench run`` writes ``<folder>/<scene>-<integrator>-<run id>.<csv|parquet>`` and a
``.json`` sidecar (scene, integrator, settings, status) that figures use for legends
(:func:`history_label`); a sweep keeps a row's history as ``<folder>/<run>-<integrator>.parquet``
(:func:`keep_history`).
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import Scene, check_name
from daebench.driver.simulate import RunResult
from daebench.harness.files import DamagedFile, OutputError, atomic_write, read_json, jsonable, results_dir, under_root, write_error
from daebench.integrators.base import Integrator
from daebench.integrators.registry import get_integrator


def run_id(scene: Scene, integ: Integrator) -> str:
    """Ten hex digits of the scene hash and the integrator's configuration."""
    body = json.dumps({"scene": scene.hash, "cfg": integ.to_config()}, sort_keys=True, default=str)
    return hashlib.sha256(body.encode()).hexdigest()[:10]


def history_dir(out_dir: str | Path | None) -> Path:
    """The folder histories go to: ``out_dir`` or results/runs."""
    if out_dir is not None and not isinstance(out_dir, (str, os.PathLike)):
        raise OutputError(f"out_dir must be a folder path (a string), e.g. \"results/runs\"; got {out_dir!r}")
    return Path(out_dir) if out_dir is not None else results_dir() / "runs"


def write_history(result: RunResult, scene: Scene, integ: Integrator, out_dir: str | Path | None) -> Path:
    """<folder>/<scene>-<integrator>-<run id>.<csv|parquet>, written atomically, plus a
    .json sidecar (scene, integrator, settings, status) that figures use for legends."""
    out = history_dir(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(exc, "the history folder", out, "the run finished; its history was not kept") from None
    path = under_root(out, history_name(scene, integ), what="the history")  # the names checked again here
    kept = f"the run itself finished ({result.status}); only its history file is missing"
    if path.suffix == ".parquet":
        atomic_write(path, lambda p: result.history.to_parquet(p, index=False), "the history", kept)
    else:
        atomic_write(path, lambda p: result.history.to_csv(p, index=False, float_format="%.17g"),
                     "the history", kept)
    side = {"scene": scene.name, "scene_hash": scene.hash, "integrator": integ.name,
            "settings": jsonable(dict(integ.settings)), "status": result.status, "message": result.message,
            "impact_law": result.impact_law}
    atomic_write(path.with_suffix(".json"), lambda p: p.write_text(json.dumps(side, indent=2)),
                 "the history's sidecar", f"the history is in {path}")
    return path


def history_name(scene: Scene, integ: Integrator) -> str:
    """<scene>-<integrator>-<run id>.<csv|parquet>; the scene's name is checked as a plain file-name
    stem here, when the name is used (a ``Scene`` whose ``name`` was changed after loading included).

    Raises
    ------
    SceneError
    """
    check_name(scene.name)
    return f"{scene.name}-{integ.name}-{run_id(scene, integ)}.{scene.get('output.format', 'csv')}"


def keep_history(hist: pd.DataFrame, folder: str | Path, stem: str) -> Path:
    """A sweep row's history as ``<folder>/<stem>.parquet`` (the row's ``history`` column)."""
    path = under_root(folder, f"{stem}.parquet", what="the history")
    path.parent.mkdir(parents=True, exist_ok=True)
    hist.to_parquet(path, index=False)
    return path


class HistoryError(ParamError):
    """A file that is not a readable run history; the message says what it is instead."""


def read_history(path: str | Path) -> pd.DataFrame:
    """A history file (.csv or .parquet) as written by `daebench run`.

    Raises
    ------
    HistoryError
        Missing, a folder, unreadable, or not a history (e.g. a sweep table).
    """
    p = Path(path)
    if not p.exists():
        raise HistoryError(f"history file '{p}' does not exist (`daebench run` writes results/runs/…)")
    if p.is_dir():
        raise HistoryError(f"'{p}' is a folder; give history files, e.g. {p}/*.csv")
    try:
        h = pd.read_parquet(p) if p.suffix == ".parquet" else pd.read_csv(p)
    except Exception as exc:  # pyarrow / the csv parser raise many types for a damaged file
        raise HistoryError(f"cannot read '{p}': {type(exc).__name__} (truncated, or not a history file?)") from None
    if "t" not in h.columns:
        hint = " — it is a sweep table: plot it with `daebench plot wp`" if "label" in h.columns else ""
        raise HistoryError(f"'{p}' is not a run history (no column 't'){hint}")
    return h


def history_label(path: str | Path, taken: set[str] = frozenset()) -> str:
    """Legend label of a history file: integrator and the settings that differ from its
    defaults, from the sidecar `daebench run` writes (else the file name)."""
    p = Path(path)
    try:
        meta = read_json(p.with_suffix(".json"), "the history's sidecar")
        name, settings = str(meta["integrator"]), dict(meta["settings"])
    except (DamagedFile, KeyError, TypeError, ValueError, AttributeError):  # a damaged sidecar: the file name
        return p.stem
    try:
        defaults = {s.name: s.default for s in get_integrator(name).settings_spec}
    except Exception:  # an integrator no longer installed: show every setting
        defaults = {}
    diff = {k: v for k, v in settings.items() if defaults.get(k, object()) != v}
    label = name + (" (" + ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                     for k, v in diff.items()) + ")" if diff else " (default settings)")
    if label in taken:
        label += f" — {meta.get('scene', p.stem)}"
    return label if label not in taken else f"{label} [{p.stem}]"
