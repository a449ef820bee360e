"""What an integrator class declares, checked before it is registered: its name, its
capabilities and its settings (:func:`daebench.integrators.base.declaration_problems`
reads these rules for entry points and :func:`daebench.integrators.registry.register`).

* **name** — lower-case letters, digits, '-', '_', '.', at most :data:`MAX_NAME` characters
  (it is a column value, a file-name part and a table cell), and none of
  :data:`RESERVED_NAMES` (words the tables give their own meaning);
* **capabilities** — ``order`` a whole number in [1, :data:`MAX_ORDER`], the flags
  booleans, at least one of ``fixed_step``/``adaptive``, ``index`` one of 1, 2, 3 for a
  method that takes constraints and None for an ODE-only one;
* **settings** — each a :class:`daebench.core.params.Param` with a Python-identifier name
  declared once, a supported type, a finite range with low ≤ high, and a default its own
  range and choices accept.

Each function returns the broken rules as short sentences ([] when none).
"""

from __future__ import annotations

import math
import re
from typing import Any, Sequence

from daebench.core.params import Param, ParamError

NAME_RULE = re.compile(r"^[a-z0-9][a-z0-9_.-]*$")
MAX_NAME = 40
#: names a table reads as something else: 'external' marks the rows of trajectories from
#: other codes (`daebench score`, compare --include), dropped from the recommendation
EXTERNAL = "external"
RESERVED_NAMES = frozenset({EXTERNAL})
MAX_ORDER = 12
INDICES = (1, 2, 3)
SETTING_TYPES = (bool, int, float, str, list)
FLAGS = ("fixed_step", "adaptive", "constraints", "dense_output", "contacts", "friction")


def name_problems(name: Any) -> list[str]:
    """The rules the integrator name ``name`` breaks."""
    if not isinstance(name, str) or not NAME_RULE.match(name):
        shown = repr(name) if not isinstance(name, str) or len(name) <= 60 else repr(name[:60]) + "…"
        return [f"class attribute name = {shown}: a lower-case name is needed (letters, digits, '-', '_', '.')"]
    if len(name) > MAX_NAME:
        return [f"class attribute name is {len(name)} characters long: at most {MAX_NAME} are allowed"]
    if name in RESERVED_NAMES:
        return [f"class attribute name = '{name}' is reserved (the tables' rows of trajectories from other codes); "
                f"choose another name"]
    return []


def capability_problems(cap: Any) -> list[str]:
    """The rules the capabilities ``cap`` (a Capabilities value) break."""
    out = []
    order = cap.order
    if isinstance(order, bool) or not isinstance(order, int) or not 1 <= order <= MAX_ORDER:
        out.append(f"capabilities.order = {order!r}: a whole number in [1, {MAX_ORDER}] is needed")
    bad = [f for f in FLAGS if not isinstance(getattr(cap, f), bool)]
    if bad:
        out.append(f"capabilities.{bad[0]} = {getattr(cap, bad[0])!r}: true or false is needed")
    if not bad and not (cap.fixed_step or cap.adaptive):
        out.append("capabilities: fixed_step or adaptive must be true (a method takes some step)")
    whole = isinstance(cap.index, int) and not isinstance(cap.index, bool)   # 2.0 == 2 but is no index
    if cap.constraints is True and not (whole and cap.index in INDICES):
        out.append(f"capabilities.index = {cap.index!r}: a method with constraints declares the index it accepts, "
                   f"one of {', '.join(map(str, INDICES))}")
    elif cap.constraints is False and cap.index is not None:
        out.append(f"capabilities.index = {cap.index!r} with constraints = false: an ODE-only method declares "
                   f"index None")
    return out


def _setting_problems(s: Param) -> list[str]:
    where = f"setting '{s.name}'"
    if s.type not in SETTING_TYPES:
        return [f"{where}: type {getattr(s.type, '__name__', s.type)!r} is not one of "
                f"{', '.join(t.__name__ for t in SETTING_TYPES)}"]
    out = []
    for end in ("low", "high"):
        x = getattr(s, end)
        if x is not None and (isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x)):
            out.append(f"{where}: {end} = {x!r} is not a finite number")
    if not out and s.low is not None and s.high is not None and s.low > s.high:
        out.append(f"{where}: low = {s.low:g} > high = {s.high:g}")
    if not out and s.default is not None:
        try:
            s.validate(s.default, "default of setting")
        except ParamError as exc:
            out.append(f"{where}: its default is refused by its own declaration ({exc})")
    return out


def settings_problems(spec: Sequence[Param]) -> list[str]:
    """The rules the settings ``spec`` (a sequence of Param) break."""
    out, seen = [], set()
    for s in spec:
        if not isinstance(s.name, str) or not s.name.isidentifier() or len(s.name) > MAX_NAME:
            out.append(f"setting name {str(s.name)[:60]!r}: a Python identifier of at most {MAX_NAME} characters "
                       f"is needed")
            continue
        if s.name in seen:
            out.append(f"setting '{s.name}' is declared twice")
            continue
        seen.add(s.name)
        out += _setting_problems(s)
    return out
