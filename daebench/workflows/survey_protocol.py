"""The survey's protocol of a case (:mod:`daebench.workflows.survey`): the runs each
integrator declares for the case (as `daebench compare` has them), every other integrator
at its defaults and halvings (:func:`halvings`), grouped in rounds of refinement
(:func:`rounds`), and the measures a case is judged by (:func:`case_measures`)."""

from __future__ import annotations

import json
from typing import Sequence

import pandas as pd

from daebench.core.scene import Scene
from daebench.harness.scoring import pipeline
from daebench.harness.sweeps.plan import RunSpec
from daebench.integrators import registry as integrator_registry
from daebench.models.scenes import load_scene
from daebench.workflows import compare
from daebench.workflows.compare import Entry, Protocol

QUICK_T_END = 0.5          # s: the ball's first impact is at 0.45 s
QUICK_LEVELS = 2           # --quick: defaults and one halving
LEVELS = 3                 # defaults and two halvings
#: measures a case's protocol does not declare are taken from these, in order, when present
FALLBACK_SUFFIX = "_max"


def _default(cls: type, key: str) -> float | None:
    for s in cls.settings_spec:
        if s.name == key:
            return float(s.default)
    return None


def halvings(name: str, levels: int = LEVELS) -> Entry:
    """``name`` at its default step and ``levels - 1`` halvings (fixed-step), or at its
    default rtol and decades below it (adaptive only); one run at its defaults otherwise."""
    cls = integrator_registry.get_integrator(name)
    caps = cls.capabilities
    h0 = _default(cls, "h")
    if caps.fixed_step and h0 is not None:
        return Entry(name, steps=tuple(h0 / 2 ** k for k in range(levels)))
    r0 = _default(cls, "rtol")
    if caps.adaptive and r0 is not None:
        return Entry(name, tols=tuple(r0 / 10 ** k for k in range(levels)))
    return Entry(name)


def survey_protocol(scene: Scene, quick: bool = False) -> Protocol:
    """The runs each integrator declares for the case (as `compare` has them) and every
    other integrator at its defaults and halvings; under ``quick`` every integrator at its
    default and one halving."""
    levels = QUICK_LEVELS if quick else LEVELS
    declared = {} if quick else compare.declared_entries(scene)
    # a plugin that cannot be loaded gets one entry, which planning lists as not applicable with the reason
    entries = list(declared.values()) + [halvings(n, levels) if r.cls is not None else Entry(n)
                                         for n, r in sorted(integrator_registry.registry().items()) if n not in declared]
    measures = compare.protocol_for(scene).measures if declared else compare.default_protocol(scene).measures
    why = "each integrator's declared runs for this case, the others at their defaults and two halvings" \
        if declared else f"every integrator at its defaults and {levels - 1} halving(s)"
    return Protocol(tuple(entries), tuple(measures), why).resolved(pipeline.headline(scene).score_name)


def case_scene(name: str, quick: bool = False) -> Scene:
    """The scene of a case; under ``quick`` with t_end at most :data:`QUICK_T_END`."""
    sc = load_scene(name)
    return sc.with_overrides({"t_end": min(sc.t_end, QUICK_T_END)}) if quick else sc


def rounds(specs: Sequence[RunSpec]) -> list[list[RunSpec]]:
    """Specs grouped by refinement level: the k-th run of each setting in round k."""
    seen: dict[str, int] = {}
    out: list[list[RunSpec]] = []
    for s in specs:
        key = s.integrator + json.dumps({k: v for k, v in s.options.items()
                                         if k not in ("h", "rtol", "atol", "adaptive")}, sort_keys=True, default=str)
        k = seen.get(key, 0)
        seen[key] = k + 1
        while len(out) <= k:
            out.append([])
        out[k].append(s)
    return out


def case_measures(df: pd.DataFrame, proto: Protocol) -> list[str]:
    """The protocol's measures with a finite value, else the first two ``err_*_max``
    whole-run measures that have one."""
    ms = compare.measures_present(df, proto.measures)
    if ms:
        return ms
    cand = [c for c in df.columns if c.startswith("err_") and c.endswith(FALLBACK_SUFFIX)
            and c.count("_") == 2 and pd.to_numeric(df[c], errors="coerce").notna().any()]
    return cand[:2]
