"""What an external trajectory becomes once read: its impact records, the checked data, and
the one error every refusal raises."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import pandas as pd

from daebench.core.params import ParamError
from daebench.harness.scoring.eventseq import ANY

#: metadata keys read (every other key is provenance, kept as text)
META_KEYS = ("label", "cost_s", "steps")
#: the longest text of a file (a label, a cell, a column name) echoed in a message
ECHO_CHARS = 80


class ExternalDataError(ParamError):
    """External data that cannot be scored; the message names the problem and the fix."""


def clip(value: Any, n: int = ECHO_CHARS) -> str:
    """``repr(value)`` cut to ``n`` characters (with its length said): what a message may
    echo of a file's text, however long the text is."""
    text = value if isinstance(value, str) else repr(value)
    if len(text) <= n:
        return repr(text) if isinstance(value, str) else text
    return f"{text[:n]!r}… ({len(text)} characters)"


@dataclass(frozen=True)
class ExternalImpact:
    """One impact of an external trajectory, as the measures read an impact record
    (:class:`daebench.core.contact.Impact`): its time, contact (:data:`ANY` when unknown) and
    episode; it carries no state, so the exact impact oracle and the energy per impact skip it,
    and no impulse, so the impulse measure is NaN for it (unknown, not zero)."""

    t: float
    contact: int = ANY
    t_end: float = math.nan
    closed: bool = False
    min_gap: float = math.nan
    energy_loss: float = math.nan
    q: Any = None
    v_minus: Any = None
    v_plus: Any = None
    impulse: float = math.nan


@dataclass(frozen=True)
class ExternalData:
    """A checked external trajectory: its history (``t``, observables, energy terms; on the
    case's output grid when the file is coarser: ``spacing``), impact records, where the events
    came from, its metadata, what it is (``source``), the notes the row carries, the file's
    largest output spacing [s] and rows, and whether a start that differs from the case's is
    allowed."""

    history: pd.DataFrame
    impacts: tuple[ExternalImpact, ...]
    events_from: str
    meta: Mapping[str, Any] = field(default_factory=dict)
    source: str = "DataFrame"
    notes: tuple[str, ...] = ()
    spacing: float = math.nan
    rows: int = 0
    resampled: bool = False
    allow_start_mismatch: bool = False
    digest: str = ""

    @property
    def label(self) -> str:
        return str(self.meta.get("label") or "external")

    @property
    def cost_s(self) -> float:
        return float(self.meta.get("cost_s", math.nan))

    @property
    def steps(self) -> float:
        return float(self.meta.get("steps", math.nan))

    def provenance(self) -> dict[str, Any]:
        """What the row's ``settings`` say about it: the source, the event source and every
        metadata key that is not the label, cost or step count."""
        extra = {k: v for k, v in self.meta.items() if k not in META_KEYS}
        return {"source": self.source, "events": self.events_from, **extra}

    def key(self) -> str:
        """SHA-256 (hex) of everything scored: the data as read (:attr:`digest`), the impact
        records, the metadata (label, cost, steps, provenance) and the start option — what a
        result file is named by, so that the same data scored with another impacts file or
        cost is another file, never the same one replaced."""
        h = hashlib.sha256(self.digest.encode())
        h.update(json.dumps([[i.t, i.contact, i.t_end, i.closed] for i in self.impacts], default=str).encode())
        h.update(json.dumps({str(k): str(v) for k, v in self.meta.items()}, sort_keys=True).encode())
        h.update(f"{self.events_from}|{self.allow_start_mismatch}".encode())
        return h.hexdigest()

