"""A case's comparison: the ``[compare]`` table of a scene file — how `daebench compare`
and the survey run and judge the case — read and validated here, the one owner.

It is not physics: it is kept out of the scene's values, so the scene hash that keys the
cached references does not see it (a changed step list re-keys no reference).

Keys (every one optional)::

    [compare]
    methods = ["hht", "ida"]     # integrators given the protocol (default: every one)
    steps = [1e-4, 5e-5]         # s: the fixed-step methods' series, coarse → fine
    contact_step = 1e-6          # s: h_contact of the event-driven methods (0: h)
    tolerances = [1e-4, 1e-5, 1e-6]   # the adaptive-only methods' series (rtol; atol = rtol/100)
    measures = ["err_theta_max_trusted"]   # headline error measures, plotted and judged
    tags = ["quick", "survey"]   # the survey's sets (default: ["survey"])
    modes_below = 5000.0         # rad/s: the resolved modal band (flexible models)
    why = "…"                    # one line: why these measures
    [compare.targets]
    err_theta_max_trusted = [1.0]   # target errors per measure (default: round decades)

A fixed-step method takes ``steps``, an adaptive-only one ``tolerances``; a method the
table does not name runs once at its defaults. An integrator's own declaration for the
case (:meth:`daebench.integrators.base.Integrator.protocol`) comes before the case's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from daebench.core.params import ParamError, did_you_mean

#: the sets a case can be tagged with: the survey's, and ``housner`` — the rocking block whose
#: first impacts follow Housner's closed form, on which `verify` checks a friction declaration
TAGS = ("quick", "survey", "housner")
#: the tags of a case whose file says none: it is surveyed, not in the quick set
DEFAULT_TAGS = ("survey",)
#: the keys of the table and what each holds (for messages)
KEYS = {"methods": "a list of integrator names", "steps": "a list of step sizes [s], coarse → fine",
        "contact_step": "a step size [s] (0: the same as h)", "tolerances": "a list of tolerances, loose → tight",
        "measures": "a list of score columns", "targets": "a table: measure = [target errors]",
        "tags": f"a list of tags from {', '.join(TAGS)}", "modes_below": "a frequency [rad/s]",
        "why": "one line of text"}


class ComparisonError(ParamError):
    """A ``[compare]`` table that cannot be used; the message names the key and the fix."""


@dataclass(frozen=True)
class Comparison:
    """A case's ``[compare]`` table, validated (module docstring); ``declared`` is False
    for a case whose file has none."""

    methods: tuple[str, ...] = ()
    steps: tuple[float, ...] = ()
    contact_step: float = 0.0
    tolerances: tuple[float, ...] = ()
    measures: tuple[str, ...] = ()
    targets: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    tags: tuple[str, ...] = DEFAULT_TAGS
    modes_below: float = math.nan
    why: str = ""
    declared: bool = False

    def names(self, method: str) -> bool:
        """Whether the protocol is given to ``method`` (every method when none is named)."""
        return bool(self.steps or self.tolerances) and (not self.methods or method in self.methods)


def _numbers(v: Any, key: str, where: str, ordered: str) -> tuple[float, ...]:
    if not isinstance(v, list) or not v or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                  for x in v):
        raise ComparisonError(f"{where}: [compare] {key} must be {KEYS[key]}, e.g. {key} = [1e-4, 5e-5]; "
                              f"got {v!r}")
    xs = tuple(float(x) for x in v)
    if not all(math.isfinite(x) and x > 0 for x in xs):
        raise ComparisonError(f"{where}: [compare] {key} must hold positive finite numbers; got {v!r}")
    if any(b >= a for a, b in zip(xs, xs[1:])):
        raise ComparisonError(f"{where}: [compare] {key} must be {ordered} (strictly decreasing); got {v!r}")
    return xs


def _names(v: Any, key: str, where: str) -> tuple[str, ...]:
    if not isinstance(v, list) or not all(isinstance(x, str) and x.strip() for x in v):
        raise ComparisonError(f"{where}: [compare] {key} must be {KEYS[key]}, e.g. {key} = [\"a\", \"b\"]; got {v!r}")
    if len(set(v)) != len(v):
        raise ComparisonError(f"{where}: [compare] {key} names an entry twice: {v!r}")
    return tuple(v)


def _number(v: Any, key: str, where: str, zero: bool) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)) \
            or float(v) < 0 or (float(v) == 0 and not zero):
        raise ComparisonError(f"{where}: [compare] {key} must be {KEYS[key]}, a finite number "
                              f"{'≥' if zero else '>'} 0; got {v!r}")
    return float(v)


def parse(raw: Any, where: str = "scene") -> Comparison:
    """The :class:`Comparison` of a scene file's ``[compare]`` table (None: the case has
    none).

    Raises
    ------
    ComparisonError
        An unknown key (with the closest one), a value of the wrong kind, a series that is
        not strictly refining, a tag not in :data:`TAGS`, a target for a measure the table
        does not list.
    """
    if raw is None:
        return Comparison()
    if not isinstance(raw, dict):
        raise ComparisonError(f"{where}: 'compare' must be a table ([compare] with keys {', '.join(KEYS)}); "
                              f"got {raw!r}")
    unknown = [k for k in raw if k not in KEYS]
    if unknown:
        raise ComparisonError(f"{where}: unknown key '{unknown[0]}' in [compare]{did_you_mean(unknown[0], KEYS)} "
                              f"(keys: {', '.join(KEYS)})")
    out: dict[str, Any] = {"declared": True}
    if "methods" in raw:
        out["methods"] = _names(raw["methods"], "methods", where)
    if "steps" in raw:
        out["steps"] = _numbers(raw["steps"], "steps", where, "coarse → fine")
    if "tolerances" in raw:
        out["tolerances"] = _numbers(raw["tolerances"], "tolerances", where, "loose → tight")
    if "contact_step" in raw:
        out["contact_step"] = _number(raw["contact_step"], "contact_step", where, zero=True)
    if "modes_below" in raw:
        out["modes_below"] = _number(raw["modes_below"], "modes_below", where, zero=False)
    if "measures" in raw:
        out["measures"] = _names(raw["measures"], "measures", where)
    if "tags" in raw:
        tags = _names(raw["tags"], "tags", where)
        bad = [t for t in tags if t not in TAGS]
        if bad:
            raise ComparisonError(f"{where}: [compare] tags: unknown tag '{bad[0]}'{did_you_mean(bad[0], TAGS)} "
                                  f"(tags: {', '.join(TAGS)})")
        out["tags"] = tags
    if "why" in raw:
        if not isinstance(raw["why"], str):
            raise ComparisonError(f"{where}: [compare] why must be {KEYS['why']}; got {raw['why']!r}")
        out["why"] = raw["why"]
    if "targets" in raw:
        tg = raw["targets"]
        if not isinstance(tg, dict):
            raise ComparisonError(f"{where}: [compare] targets must be {KEYS['targets']} ([compare.targets]); "
                                  f"got {tg!r}")
        listed = out.get("measures", ())
        targets = {}
        for m, ts in tg.items():
            if m not in listed:
                raise ComparisonError(f"{where}: [compare.targets] {m}: not one of the table's measures"
                                      f"{did_you_mean(m, listed)} (measures: {', '.join(listed) or 'none'}); "
                                      f"list it in [compare] measures")
            vals = ts if isinstance(ts, list) else [ts]
            targets[m] = tuple(sorted({_number(x, 'targets', where, zero=False) for x in vals}, reverse=True))
        out["targets"] = targets
    return Comparison(**out)


