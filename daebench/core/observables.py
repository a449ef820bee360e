"""Declared observables: what a model's history columns mean to the scorer.

A model declares its observables as it declares its settings: a module-level
``OBSERVABLES`` tuple of :class:`Observable` (one history column) and :class:`Position`
(a point given by two columns, scored as one Euclidean error). The scoring pipeline
(:mod:`daebench.harness.scoring`) reads nothing else about a column: its short name in
the error columns, its unit, the column holding its time derivative (for the cubic
Hermite interpolation of a reference), whether it is scored before the first impact and
per re-synchronised window, whether it measures a rebound height, whether its final
value is printed by ``daebench run``, and the tolerance of the reference fingerprint.

A column a model does not declare is still scored, under its own name, with linear
interpolation and no unit (:meth:`Observables.get`): declaring adds meaning, it never
decides whether a column is scored (that is the scene's ``output.observables``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

from daebench.core.params import ParamError


@dataclass(frozen=True)
class Observable:
    """One history column.

    Attributes
    ----------
    name : the history column (``theta_deg``)
    unit : its unit, as printed (``deg``)
    label : a symbol or words for figures and text (``θ``); default: ``name``
    short : its name in error columns (``err_<short>_max``); default: ``name``
    derivative : the column holding its time derivative, or None (the reference is then
        interpolated linearly instead of by cubic Hermite)
    derivative_factor : d(name)/dt = derivative_factor × that column (θ in degrees from
        ω in rad/s: 180/π)
    fingerprint_tol : tolerance of this column in the shipped reference fingerprints
        (:mod:`daebench.harness.fingerprints`); None: not fingerprinted
    impact_windows : also scored before the first impact and per re-synchronised window
        after each impact (:mod:`daebench.harness.impact_metrics`)
    height : a height above the contact surface; the first declared one present in a
        history locates the rebound apex
    summary : its final value is printed by ``daebench run``
    """

    name: str
    unit: str = ""
    label: str = ""
    short: str = ""
    derivative: str | None = None
    derivative_factor: float = 1.0
    fingerprint_tol: float | None = None
    impact_windows: bool = False
    height: bool = False
    summary: bool = False

    def __post_init__(self) -> None:
        _check_name(self.name, "Observable name")
        if not (isinstance(self.derivative_factor, (int, float)) and math.isfinite(self.derivative_factor)):
            raise ParamError(f"observable '{self.name}': derivative_factor must be a finite number, "
                             f"got {self.derivative_factor!r}")
        tol = self.fingerprint_tol
        if tol is not None and not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0):
            raise ParamError(f"observable '{self.name}': fingerprint_tol must be a positive number or None, got {tol!r}")

    @property
    def score_name(self) -> str:
        """The name in error columns: ``short``, else the column's name."""
        return self.short or self.name

    @property
    def text(self) -> str:
        """``label [unit]`` (the name when there is no label)."""
        what = self.label or self.name
        return f"{what} [{self.unit}]" if self.unit else what


@dataclass(frozen=True)
class Position:
    """A point from two columns (``tip_x``, ``tip_y``), scored as one Euclidean error
    ``err_<name>_{final,max,l2}``; with ``angle`` also its polar angle about the origin
    (a chord angle when the origin is a hinge: frame-invariant), scored as
    ``err_<angle>_{final,max,l2}`` [deg]."""

    name: str
    x: str
    y: str
    unit: str = "m"
    label: str = ""
    impact_windows: bool = False
    angle: str = ""
    angle_label: str = ""

    def __post_init__(self) -> None:
        for what, v in (("name", self.name), ("x column", self.x), ("y column", self.y)):
            _check_name(v, f"Position {what}")

    @property
    def score_name(self) -> str:
        return self.name

    @property
    def text(self) -> str:
        return f"{self.label or self.name} [{self.unit}]" if self.unit else (self.label or self.name)


def _check_name(value: object, what: str) -> None:
    if not isinstance(value, str) or not value.strip():
        raise ParamError(f"{what} must be a non-empty string, got {value!r}")


class Observables:
    """A model's declared observables, looked up by column (immutable)."""

    def __init__(self, declared: Iterable[Observable | Position] = ()) -> None:
        items = tuple(declared)
        bad = [d for d in items if not isinstance(d, (Observable, Position))]
        if bad:
            raise ParamError(f"OBSERVABLES holds {bad[0]!r}; declare Observable(...) or Position(...) values")
        self._columns = {d.name: d for d in items if isinstance(d, Observable)}
        self.positions: tuple[Position, ...] = tuple(d for d in items if isinstance(d, Position))
        names = [d.score_name for d in items]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ParamError(f"OBSERVABLES declares the score name '{twice[0]}' twice")

    @property
    def declared(self) -> tuple[Observable, ...]:
        """The declared single-column observables, in declaration order."""
        return tuple(self._columns.values())

    def get(self, column: str) -> Observable:
        """The declaration of ``column``, or a default one (its own name, no unit)."""
        return self._columns.get(column) or Observable(column)

    def derivative(self, column: str) -> tuple[str, float] | None:
        """(column of d(column)/dt, factor) when declared, else None."""
        o = self._columns.get(column)
        return (o.derivative, float(o.derivative_factor)) if o is not None and o.derivative else None

    def windowed(self, columns: Sequence[str]) -> tuple[list[Observable], list[Position]]:
        """The observables and positions scored around impacts that ``columns`` hold."""
        have = set(columns)
        obs = [o for o in self.declared if o.impact_windows and o.name in have]
        pos = [p for p in self.positions if p.impact_windows and p.x in have and p.y in have]
        return obs, pos

    def height_column(self, columns: Sequence[str]) -> str | None:
        """The first declared height that ``columns`` hold (None: no rebound to measure)."""
        have = set(columns)
        return next((o.name for o in self.declared if o.height and o.name in have), None)

    def fingerprinted(self) -> list[Observable]:
        """The observables sampled into reference fingerprints."""
        return [o for o in self.declared if o.fingerprint_tol is not None]

    def by_score_name(self, name: str) -> Observable | Position | None:
        """The declaration whose error columns are ``err_<name>_*`` (a position's polar
        angle as an observable in deg)."""
        for d in (*self.declared, *self.positions):
            if d.score_name == name:
                return d
        for p in self.positions:
            if p.angle and p.angle == name:
                return Observable(name, "deg", p.angle_label or f"angle of {p.label or p.name}")
        return None


NONE = Observables()

#: history columns that hold the generalized state (``q_<coordinate>``, ``v_<coordinate>``):
#: recorded for the modal measures, never scored as observables
STATE_PREFIXES = ("q_", "v_")
