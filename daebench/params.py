"""Typed, range-checked parameters: one mechanism for scene keys and integrator settings.

Errors say what is wrong and how to fix it: the key, the allowed type or range, and
for unknown keys the closest valid one.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from typing import Any, Iterable


class ParamError(ValueError):
    """A bad value or an unknown key; the message names both and the fix."""


def did_you_mean(key: str, valid: Iterable[str]) -> str:
    close = difflib.get_close_matches(key, list(valid), n=1, cutoff=0.5)
    return f"; did you mean '{close[0]}'?" if close else ""


def coerce(value: Any, typ: type, what: str) -> Any:
    """Convert to the declared type (command-line strings included); refuse anything else.
    ``typ`` is one of bool, int, float, str, list (of str)."""
    if typ is bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in ("true", "false", "1", "0", "yes", "no", "on", "off"):
            return value.lower() in ("true", "1", "yes", "on")
        raise ParamError(f"{what} must be true or false, got {value!r}")
    if typ in (float, int):
        if isinstance(value, bool):
            raise ParamError(f"{what} must be a number, got {value!r}")
        try:
            f = float(value)
        except (TypeError, ValueError):
            raise ParamError(f"{what} must be a number, got {value!r}") from None
        if typ is int:
            if f != int(f):
                raise ParamError(f"{what} must be an integer, got {value!r}")
            return int(f)
        return f
    if typ is str:
        if not isinstance(value, str):
            raise ParamError(f"{what} must be a string, got {value!r}")
        return value
    if typ is list:
        if isinstance(value, str):
            value = [v.strip() for v in value.split(",") if v.strip()]
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise ParamError(f"{what} must be a list of names, got {value!r}")
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

    def validate(self, value: Any, where: str) -> Any:
        what = f"{where} '{self.name}'"
        value = coerce(value, self.type, what)
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
    for item in items:
        if "=" not in item:
            raise ParamError(f"{flag} '{item}' must look like key=value, e.g. {flag} {example}")
        k, v = item.split("=", 1)
        out[k.strip()] = v.strip()
    return out
