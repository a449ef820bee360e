"""Shipped fingerprints of the default scenes' references: a few numbers that any
correctly computed reference reproduces, so that a cached reference (computed on this
machine, never committed: it is megabytes) is checked against what the project measured.

A fingerprint (``cases/reference-fingerprints.json``, keyed by scene hash) holds the
impact times and, at ten times, every observable the model declares with a
``fingerprint_tol`` (:mod:`daebench.core.observables`). :func:`check` compares a
reference with it to :data:`IMPACT_TOL` — 10× the agreement between the reference (IDA
rtol 1e-11) and its 10× looser check run on beam-impact (8.3e-10 s) — and to each
observable's declared tolerance, and refuses a reference that disagrees, with the
command that recomputes it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from daebench.harness.scoring import pipeline
from daebench.harness.references.reference import Reference, ReferenceDamaged
from daebench.core.scene import Scene, cases_dir

IMPACT_TOL = 1e-8     # s
SAMPLES = 10          # each fingerprinted observable at t_end·k/SAMPLES, k = 1 … SAMPLES


def path() -> Path:
    """cases/reference-fingerprints.json (beside the scene files)."""
    return cases_dir() / "reference-fingerprints.json"


def _load() -> dict[str, Any]:
    p = path()
    return json.loads(p.read_text()) if p.exists() else {}


def _sample(ref: Reference, column: str, t_end: float) -> list[float]:
    h = ref.history
    if column not in h.columns:
        return []
    ts = [t_end * k / SAMPLES for k in range(1, SAMPLES + 1)]
    t = h["t"].to_numpy(float)
    return [float(h[column].to_numpy(float)[int(np.argmin(np.abs(t - x)))]) for x in ts]


def make(scene: Scene, ref: Reference) -> dict[str, Any]:
    """The fingerprint of ``ref``: impact times and the model's fingerprinted observables
    at the sample times (the output rows nearest to them)."""
    made = {"rtol": ref.rtol} if ref.kind == "ida" else {"kind": ref.kind, "h": float(ref.meta["settings"]["h"])}
    return {"scene": scene.name, **made, "impacts": list(ref.impacts),
            **{o.name: _sample(ref, o.name, scene.t_end) for o in pipeline.declared(scene.model).fingerprinted()}}


def record(scene: Scene, ref: Reference) -> Path:
    """Add or replace the fingerprint of ``scene`` (maintainers: after a physics change)."""
    data = _load()
    data[scene.hash] = make(scene, ref)
    path().write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    return path()


def differences(scene: Scene, ref: Reference) -> list[str]:
    """What disagrees between ``ref`` and the shipped fingerprint of ``scene`` (empty when
    all agree or there is no fingerprint)."""
    fp = _load().get(scene.hash)
    if fp is None:
        return []
    got = make(scene, ref)
    out = []
    if len(got["impacts"]) != len(fp["impacts"]):
        out.append(f"{len(got['impacts'])} impacts, the fingerprint has {len(fp['impacts'])}")
    else:
        d = max((abs(a - b) for a, b in zip(got["impacts"], fp["impacts"])), default=0.0)
        if not d <= IMPACT_TOL:
            out.append(f"impact times differ by up to {d:.2e} s (tolerance {IMPACT_TOL:g} s)")
    for o in pipeline.declared(scene.model).fingerprinted():
        a, b, tol, unit = got[o.name], fp.get(o.name, []), o.fingerprint_tol, f" {o.unit}" if o.unit else ""
        if a and b and len(a) == len(b):
            d = max(abs(x - y) for x, y in zip(a, b))
            if not (math.isfinite(d) and d <= tol):
                out.append(f"{o.name} differs by up to {d:.2e}{unit} (tolerance {tol:g}{unit})")
    return out


def check(scene: Scene, ref: Reference) -> None:
    """Refuse a reference that disagrees with the shipped fingerprint.

    Raises
    ------
    ReferenceDamaged
    """
    diff = differences(scene, ref)
    if diff:
        raise ReferenceDamaged(
            f"the cached reference {ref.path} disagrees with the fingerprint shipped for scene '{scene.name}' "
            f"({'; '.join(diff)}); recompute it with `daebench reference {scene.name} --force`")
