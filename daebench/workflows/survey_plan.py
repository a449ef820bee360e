"""What a survey was planned as, so that a resumed survey is that survey: the cases,
integrators, protocol size (``quick``), budget, targets and reference mode are recorded in
``<survey>/plan.json`` before the first run, and ``--resume`` with any of them different
is refused naming each difference (a resume that ran other cases would rewrite the
survey's tables with those cases only). And the targets a survey can judge: a target of a
measure no case is scored on is refused, with the measures there are.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping, Sequence

from daebench.core.params import ParamError, did_you_mean
from daebench.core.scene import Scene
from daebench.harness.files import DamagedFile, atomic_write, read_json
from daebench.harness.scoring import pipeline
from daebench.harness.sweeps.store import StoreError

PLAN_FILE = "plan.json"
#: the plan's entries, as a person reads them in a refusal
WHAT = {"cases": "cases (--cases)", "integrators": "integrators (-i)", "quick": "--quick",
        "budget_s": "budget per case (--budget, s)", "targets": "targets (--target)",
        "reference": "reference mode (--reference)"}


def plan_of(opts: Any, cases: Sequence[str]) -> dict[str, Any]:
    """The survey's plan: what its tables depend on (not how it executes: jobs, scheduler)."""
    targets = opts.targets or {}
    return {"cases": list(cases), "integrators": sorted(opts.integrators), "quick": bool(opts.quick),
            "budget_s": float(opts.budget), "reference": opts.reference,
            "targets": {m: sorted(float(v) for v in vs) for m, vs in sorted(targets.items())}}


def _shown(key: str, value: Any) -> str:
    if key == "integrators" and not value:
        return "every registered one"
    if key == "targets" and not value:
        return "the default decades"
    if isinstance(value, list):
        return ", ".join(map(str, value))
    if isinstance(value, dict):
        return "; ".join(f"{m}={','.join(f'{v:g}' for v in vs)}" for m, vs in value.items())
    return f"{value:g}" if isinstance(value, float) else str(value)


def check_resume(folder: Path, name: str, plan: Mapping[str, Any]) -> None:
    """Refuse to resume survey ``name`` in ``folder`` with another plan than its recorded one.

    Raises
    ------
    StoreError
        Naming each difference (planned, then given) and what to do.
    """
    path = folder / PLAN_FILE
    if not path.exists():
        return   # nothing ran under this name yet: the resume starts it
    try:
        old = read_json(path, "the survey's plan")
    except DamagedFile as exc:
        raise StoreError(f"cannot resume survey '{name}': {exc}; start it again with --overwrite") from None
    diffs = [f"{WHAT.get(k, k)}: planned {_shown(k, old.get(k))}, now {_shown(k, plan[k])}"
             for k in plan if old.get(k) != plan[k]]
    if diffs:
        raise StoreError(f"cannot resume survey '{name}': it was planned otherwise ({'; '.join(diffs)}); repeat "
                         f"the original command with --resume, or give another --name (or --overwrite) for a "
                         f"new survey")


def record(folder: Path, plan: Mapping[str, Any]) -> None:
    """Write the plan before the first run (atomically)."""
    folder.mkdir(parents=True, exist_ok=True)
    atomic_write(folder / PLAN_FILE, lambda p: p.write_text(json.dumps(plan, indent=1)), "the survey's plan")


def target_measures(scenes: Sequence[Scene], measures_of: Any) -> list[str]:
    """The measures a target can be given for: each case's protocol measures and the
    whole-run maxima ``err_<observable>_max`` a case falls back on (``measures_of(scene)``:
    the protocol's)."""
    out: list[str] = []
    for sc in scenes:
        d = pipeline.declared(sc.model)
        out += list(measures_of(sc))
        out += [f"err_{d.get(c).score_name}_max" for c in sc.get("output.observables") or []]
    return list(dict.fromkeys(out))


def check_targets(targets: Mapping[str, Any] | None, valid: Sequence[str]) -> None:
    """Refuse a target of a measure no case of the survey is scored on.

    Raises
    ------
    ParamError
        Naming the unknown measure (with the closest valid one) and listing the valid ones.
    """
    for m in targets or {}:
        if m not in valid:
            raise ParamError(f"--target {m}: no case of this survey is scored on '{m}'{did_you_mean(m, list(valid))} "
                             f"(the measures: {', '.join(valid)})")
