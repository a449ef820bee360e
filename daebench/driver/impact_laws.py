"""The driver's impact laws (scene key ``contact.impact_law``) as objects with one interface,
as Siconos' one-step nonsmooth problems are: what an impact of contact i involves and how
its impulses are found.

Each law answers four questions for :func:`daebench.driver.transitions._impact`:

* :meth:`ImpactLaw.participants` — which contacts take part (and which rows are held
  bilateral while it acts);
* :meth:`ImpactLaw.solve` — the impulse map on them (post-impact velocity, impulses,
  energy loss), whose failure ends the run, named;
* :attr:`ImpactLaw.zeno_rules` — whether the driver's Zeno rules apply to the result (a
  rebound too slow for any step is plastic; a contact the impact lifts only briefly rests);
* :meth:`ImpactLaw.name` — the law as the run record names it.

The laws: ``simultaneous`` (Newton's law on every contact of the event at once, one LCP —
with planar Coulomb friction in the manner of Pfeiffer & Glocker where μ > 0,
:func:`daebench.core.frictional_impact.frictional_impact`); ``sequential`` (the impacting
contact alone, the closed contacts held); ``lzb`` (the simultaneous law's contacts through
the Liu–Zhao–Brogliato impact process, :mod:`daebench.core.lzb`, where each contact's e
shapes the whole wave: the Zeno rules do not apply). The choice of names is the scene's
(:data:`daebench.core.contact.IMPACT_LAWS`).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from daebench.core.frictional_impact import failure_message, frictional_impact, law_name
from daebench.core.lzb import NAME as LZB_NAME, failure_message as lzb_failure, lzb_law
from daebench.integrators.base import StepFailure
from daebench.stepping.watch import GAP_BAND


class ImpactLaw:
    """Newton's law applied to every contact of the event at once (``simultaneous``)."""

    key: ClassVar[str] = "simultaneous"
    #: the law an :class:`daebench.core.contact.Impact` records
    record: ClassVar[str] = "newton"
    #: whether slow rebounds are made plastic and briefly lifted contacts rest
    zeno_rules: ClassVar[bool] = True

    def participants(self, i: int, g: np.ndarray, Gq: np.ndarray, v: np.ndarray, active: list[int],
                     penetrating: set[int], continuous: bool, B: np.ndarray) -> tuple[list[int], np.ndarray]:
        """The contacts of the impact of contact ``i`` — it, the closed ones and the open ones
        on their surface that do not separate — and the rows held while it acts (the
        bilateral constraints ``B``)."""
        part = sorted({i, *active} | {c for c in range(len(g)) if g[c] <= GAP_BAND and Gq[c] @ v <= 0.0
                                      and not (continuous and c in penetrating)})
        return part, B

    def solve(self, system: Any, part: list[int], M: np.ndarray, GN: np.ndarray, GT: np.ndarray,
              mu: np.ndarray, v: np.ndarray, e: np.ndarray, held: np.ndarray, t: float, i: int) -> Any:
        """The impulse map of contacts ``part`` (rows GN, GT) at velocity ``v``; a failure is a
        :class:`StepFailure` naming the impact of contact ``i`` at ``t``."""
        res = frictional_impact(M, GN, GT, mu, v, e, held)
        if not res.ok:
            raise StepFailure(f"{failure_message(res.status)} (impact of contact {i})", t)
        return res

    def restitution(self, e: float) -> float:
        """The restitution an impact record carries."""
        return e

    def name(self, mu: np.ndarray) -> str:
        """The run record's name of the law, e.g. ``newton-coulomb (Pfeiffer–Glocker LCP), simultaneous``."""
        return f"{law_name(mu)}, {self.key}"


class SequentialImpact(ImpactLaw):
    """Newton's law on the impacting contact alone, the closed contacts held: the next
    contact's impact follows as its own event (a three-ball cradle leaves at (0, 0, 1) v)."""

    key: ClassVar[str] = "sequential"

    def participants(self, i, g, Gq, v, active, penetrating, continuous, B):
        return [i], np.vstack([B] + [Gq[[c]] for c in active])


class LzbImpact(ImpactLaw):
    """The Liu–Zhao–Brogliato multiple-impact process on the simultaneous law's contacts
    (:func:`daebench.core.lzb.lzb_law`, the model's contact stiffness)."""

    key: ClassVar[str] = "lzb"
    record: ClassVar[str] = "lzb"
    zeno_rules: ClassVar[bool] = False

    def solve(self, system, part, M, GN, GT, mu, v, e, held, t, i):
        res = lzb_law(system, part)(M, GN, v, e=e, B=held)
        if not res.ok:
            raise StepFailure(f"{lzb_failure(res.status, res.step_count, float(np.min(e)))} (impact of contact {i})", t)
        return res

    def restitution(self, e: float) -> float:
        return float("nan")     # LZB's e acts through the wave, not as one contact's ratio

    def name(self, mu):
        return LZB_NAME


#: the driver's impact law of each ``contact.impact_law``
LAWS: dict[str, ImpactLaw] = {law.key: law for law in (ImpactLaw(), SequentialImpact(), LzbImpact())}
