"""Typed, range-checked parameters: one mechanism for scene keys and integrator settings.

Errors say what is wrong and how to fix it: the key, the allowed type or range, and
for unknown keys the closest valid one.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np


class ParamError(ValueError):
    """A bad value or an unknown key; the message names both and the fix."""


def did_you_mean(key: str, valid: Iterable[str]) -> str:
    close = difflib.get_close_matches(str(key), [str(v) for v in valid], n=1, cutoff=0.5)
    return f"; did you mean '{close[0]}'?" if close else ""


def coerce(value: Any, typ: type, what: str, strict: bool = False, finite: bool = True) -> Any:
    """Convert ``value`` to the declared type or refuse it with a message naming ``what``.

    ``typ`` is one of bool, int, float, str, list (of str). A string is parsed as
    command-line text (``"1e-3"``, ``"true"``, ``"a,b"``) unless ``strict`` (values from a
    typed source such as a TOML file, where ``"1e-3"`` in quotes is a mistake). Numbers must
    be finite unless ``finite`` is False: this is the one non-finite check of the package
    (NaN passes every ``<``/``>`` range test, so it must be refused before them).
    """
    text = isinstance(value, str) and not strict
    if typ is bool:
        if isinstance(value, (bool, np.bool_)):  # numpy's booleans too (a mask's element, np.False_)
            return bool(value)
        if text and value.lower() in ("true", "false", "1", "0", "yes", "no", "on", "off"):
            return value.lower() in ("true", "1", "yes", "on")
        raise ParamError(f"{what} must be true or false, got {value!r}")
    if typ in (float, int):
        if isinstance(value, (bool, np.bool_)) or (isinstance(value, str) and not text):
            raise ParamError(f"{what} must be a number, got {value!r}"
                             + (" (a quoted string: write the number without quotes)" if isinstance(value, str) else ""))
        if text and "_" in value:  # Python's float() reads "1_0e-3" as 0.01: a typo, not a number
            raise ParamError(f"{what} must be a number, got {value!r} (no '_' in numbers: write e.g. 1e-3)")
        digits = str(value).strip().lstrip("+-") if isinstance(value, (int, str)) else ""
        huge = digits.isdigit() and len(digits) > 30
        shown = f"a {len(digits)}-digit number" if huge else repr(value)
        try:
            f = float(value)
        except (TypeError, ValueError, OverflowError):
            if huge:
                raise ParamError(f"{what} must be a finite number of ordinary size, got {shown} (beyond any "
                                 f"range; write e.g. 1e6)") from None
            raise ParamError(f"{what} must be a number, got {value!r}") from None
        if finite and not math.isfinite(f):
            raise ParamError(f"{what} must be a finite number, got {shown}"
                             + (" (beyond any range; write e.g. 1e6)" if huge else ""))
        if typ is int:
            if not math.isfinite(f) or f != int(f):
                raise ParamError(f"{what} must be an integer, got {value!r}")
            return int(f)
        return f
    if typ is str:
        if not isinstance(value, str):
            raise ParamError(f"{what} must be a string, got {value!r}")
        return value
    if typ is list:
        if text:
            value = [v.strip() for v in value.split(",") if v.strip()]
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) and v for v in value):
            raise ParamError(f"{what} must be a list of names, e.g. [\"theta_deg\", \"tip_y\"]; got {value!r}")
        return list(value)
    raise TypeError(f"unsupported parameter type {typ}")


@dataclass(frozen=True)
class Param:
    """One declared parameter: name, type, default, allowed range or choices, meaning."""

    name: str
    type: type
    default: Any
    doc: str
    low: float | None = None
    high: float | None = None
    choices: tuple | None = None
    unit: str = ""
    allow_nonfinite: bool = False  # True: NaN/±inf are meaningful values of this key

    def validate(self, value: Any, where: str, strict: bool = False) -> Any:
        """The value converted to this parameter's type and checked against its range or
        choices (see :func:`coerce` for ``strict``); raises :class:`ParamError`."""
        what = f"{where} '{self.name}'"
        value = coerce(value, self.type, what, strict=strict, finite=not self.allow_nonfinite)
        if self.choices is not None:
            items = value if isinstance(value, list) else [value]
            for v in items:
                if v not in self.choices:
                    raise ParamError(
                        f"{what} must be one of {', '.join(map(str, self.choices))}; got {v!r}"
                        f"{did_you_mean(str(v), map(str, self.choices))}"
                    )
        if self.type in (int, float):
            if (self.low is not None and value < self.low) or (self.high is not None and value > self.high):
                lo = "-inf" if self.low is None else f"{self.low:g}"
                hi = "inf" if self.high is None else f"{self.high:g}"
                raise ParamError(f"{what} = {value!r} is out of range [{lo}, {hi}] ({self.doc})")
        return value

    def describe(self) -> str:
        rng = ""
        if self.choices is not None:
            rng = " | ".join(map(str, self.choices))
        elif self.low is not None or self.high is not None:
            lo = "-inf" if self.low is None else f"{self.low:g}"
            hi = "inf" if self.high is None else f"{self.high:g}"
            rng = f"[{lo}, {hi}]"
        return f"{self.type.__name__} {rng}".strip()


def parse_pairs(items: Iterable[str], flag: str, example: str) -> dict[str, str]:
    """``["k=v", ...]`` → ``{k: v}``; a malformed item names the flag and an example."""
    out: dict[str, str] = {}
    if isinstance(items, (str, bytes)) or not isinstance(items, Iterable):
        raise ParamError(f"{flag} values must be a list of \"key=value\" strings, e.g. [\"{example}\"]; got {items!r}")
    for item in items:
        if not isinstance(item, str):
            raise ParamError(f"{flag} '{item!r}' must be a \"key=value\" string, e.g. {flag} {example}")
        if "=" not in item:
            raise ParamError(f"{flag} '{item}' must look like key=value, e.g. {flag} {example}")
        k, v = item.split("=", 1)
        out[k.strip()] = v.strip()
    return out
