"""Other codes' results: score a trajectory from another solver against a case's truth
(`daebench score`), and export a case so that another code can set it up (`daebench
export`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable

from daebench.api.catalogue import SceneLike, load_scene
from daebench.harness.running.progress import run_progress_factory
from daebench.workflows import export as _export
from daebench.workflows import score as _score
from daebench.workflows.export import ExportResult
from daebench.workflows.score import ScoreResult, Source


def score(scene: SceneLike, data: Any, *, impacts: Any = None, overrides: Iterable[str] | dict[str, Any] | None = None,
          label: str | None = None, cost_s: float | None = None, steps: int | None = None,
          reference: str = "compute", progress: bool = False, write: bool = True,
          out: str | Path | None = None, allow_start_mismatch: bool = False) -> ScoreResult:
    """Score another code's trajectory of a case as a daebench run is scored.

    Parameters
    ----------
    scene, overrides : the case, as for :func:`daebench.run`
    data : a path to a CSV or Parquet file, or a DataFrame: a column ``t`` [s] and any of
        the case's observables in its units (`daebench show CASE`), optionally energy terms
        (:mod:`daebench.harness.scoring.external`)
    impacts : the event sequence: a file or DataFrame with columns ``t`` and ``contact``,
        or a list of times; default: the file ``<stem>-impacts.csv`` beside ``data``, else
        from the ``gap`` column, else repeated times
    label, cost_s, steps : the row's name, the external run's cost [s] and step count
        (default: the file's metadata)
    reference : 'compute' (the reference is computed when missing), 'require'
    progress : a progress bar on stderr while a reference is computed
    write, out : write the row (default results/score/<case>-<hash8>/<label>-<key8>.json, the key
        a digest of everything scored)
    allow_start_mismatch : score a file whose values at t = 0 differ from the case's start
        (else refused, the column and both values named)

    Returns
    -------
    ScoreResult
        ``.row``: one record with the keys of a sweep row (``integrator`` = 'external').

    Raises
    ------
    ParamError
        Refused data (what is wrong and the fix), before anything is written.
    """
    sc = load_scene(scene, overrides)
    return _score.score_file(sc, Source(data, impacts, label, cost_s, steps, allow_start_mismatch), reference,
                             run_progress_factory(progress), write, out)


def export_case(scene: SceneLike, *, overrides: Iterable[str] | dict[str, Any] | None = None,
                out: str | Path | None = None, write: bool = True) -> ExportResult:
    """What another code needs to set ``scene`` up (parameters with units, initial state,
    contact, observables, times; :mod:`daebench.workflows.export`), written as JSON and a
    Markdown sheet to ``out`` (default results/export/<case>-<hash8>)."""
    sc = load_scene(scene, overrides)
    return _export.export_case(sc, out, write)
