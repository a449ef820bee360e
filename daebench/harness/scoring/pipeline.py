"""One scoring pipeline: a run's history → its scores, used by ``daebench run``, the
Python API (:func:`daebench.api.run`), sweeps (:func:`daebench.harness.sweeps.row.execute`)
and ``daebench compare`` alike.

**Against what.** The model's exact solution where it has one for this run — a system
method ``exact_observables(t) -> {column: values}`` that raises ``ValueError`` outside
its range (the pendulum's elliptic-function solution; a revolving pendulum has none), and
``exact_impacts(t_end) -> times`` where the motion has impacts (the ball's) —
else the scene's cached reference (:mod:`daebench.harness.references.reference`), else nothing.
:func:`truth` picks it; :func:`score` scores against it.

**What.** Every column the scene scores (``output.observables``, else every observable
the truth holds), named and interpolated as the model declares
(:mod:`daebench.core.observables`: ``OBSERVABLES`` in the model's module); nothing here
knows a column by name, so a new model's observables are scored as the built-ins' are.

**Adding a measure.** A new score of a run is one function ``(Run, Truth) -> dict`` added
to :data:`MEASURES` (every sweep row, the API's and ``daebench run``'s scores gain its
columns; a run that did not complete gets NaN for every ``err_*`` column it returns).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
import pandas as pd

from daebench.core.observables import Observable, Observables, Position
from daebench.harness.scoring import eventseq, graphdist, impact_metrics, metrics, modal, nonsmooth, oracle
from daebench.core.params import ParamError
from daebench.models import MODELS, get_model


def declared(model: str) -> Observables:
    """The observables model ``model`` declares (its module's ``OBSERVABLES``; none: {})."""
    return Observables(getattr(get_model(model), "OBSERVABLES", ()))


def every_declared() -> list[Observable | Position]:
    """The declarations of every registered model, in registry order (for figure labels,
    which know a column but not its model); a model that cannot be imported declares none
    here (its own runs report why)."""
    out: list[Observable | Position] = []
    for name in MODELS:
        try:
            d = declared(name)
        except (ImportError, ParamError):
            continue
        out += [*d.declared, *d.positions]
    return out


def headline(scene: Any) -> Observable | Position:
    """The observable a case is judged by first (``daebench compare``'s table and
    figure): the first observable, else position, the model declares to be scored around
    impacts that the scene scores; else the scene's first scored observable."""
    cols = list(scene.get("output.observables") or [])
    d = declared(scene.model)
    obs, pos = d.windowed(cols)
    if obs or pos:
        return (obs or pos)[0]
    return d.get(cols[0]) if cols else Observable("none")


def restitution(system: Any) -> float:
    """The coefficient of restitution of ``system``'s contact law (NaN without a law):
    the one place the scorer reads it."""
    law = getattr(system, "contact_law", None)
    e = getattr(law, "restitution", None) if law is not None else None
    return float(e) if isinstance(e, (int, float)) and not isinstance(e, bool) else math.nan


@dataclass(frozen=True)
class Truth:
    """What a run is scored against: a history with ``t`` and observable columns, its
    impact times, and what it is (``against``: 'exact solution' or 'reference')."""

    history: pd.DataFrame
    impacts: tuple[float, ...] = ()
    against: str = "reference"
    rtol: float = math.nan        # the reference's IDA rtol (NaN for an exact solution)
    #: the span [0, trust_t] on which the truth is trusted (daebench.harness.references.accuracy) and its
    #: impacts there; an exact solution: its whole span; a reference without an accuracy record: NaN, -1
    trust_t: float = math.nan
    trust_impacts: int = -1
    #: what computed the reference, in a few words ('ida rtol 1e-11', 'moreau h 5e-06 (event capturing)')
    made_by: str = ""
    #: the normal impulse of each impact [N s] (the impulse measure; empty: not recorded)
    impulses: tuple[float, ...] = ()

    @property
    def description(self) -> str:
        if self.against != "reference":
            return self.against
        return f"cached reference ({self.made_by or f'ida rtol {self.rtol:g}'})"


@dataclass(frozen=True)
class Run:
    """One run as the measures see it: the scene, its system, the history, the Impact
    records (:class:`daebench.core.contact.Impact`) and the model's declarations."""

    scene: Any
    system: Any
    history: pd.DataFrame
    impacts: Sequence[Any] = ()
    declared: Observables = field(default_factory=Observables)

    @property
    def impact_times(self) -> list[float]:
        return [float(i.t) for i in self.impacts]

    def scored_columns(self) -> list[str]:
        """The scene's ``output.observables`` the history holds (an effect switched off
        removes some: :func:`unscored`)."""
        return [o for o in self.scene.get("output.observables") or [] if o in self.history.columns]

    def unscored(self) -> list[str]:
        """The scene's ``output.observables`` that this run's history does not hold."""
        return [o for o in self.scene.get("output.observables") or [] if o not in self.history.columns]


def exact_truth(run: Run) -> Truth | None:
    """The model's exact solution at the run's output times, or None (no exact solution,
    none for this run — outside its range —, or one without every scored column)."""
    fn = getattr(run.system, "exact_observables", None)
    if fn is None or not len(run.history):
        return None
    t = run.history["t"].to_numpy(float)
    try:
        cols = fn(t)
    except ValueError:  # outside the exact solution's range (e.g. a revolving pendulum)
        return None
    if not set(run.scored_columns()) <= set(cols):
        return None
    exact_impacts = getattr(run.system, "exact_impacts", None)   # a model with impacts: their exact times
    impacts = tuple(float(x) for x in exact_impacts(float(t[-1]))) if exact_impacts is not None else ()
    return Truth(pd.DataFrame({"t": t, **{k: np.asarray(v, float) for k, v in cols.items()}}),
                 impacts, "exact solution", trust_t=float(t[-1]), trust_impacts=len(impacts))


def reference_truth(ref: Any) -> Truth:
    """A cached reference (:class:`daebench.harness.references.stored.Reference`) as a truth."""
    acc = ref.meta.get("accuracy") or {}
    imp = ref.meta.get("impulses") or ()
    return Truth(ref.history, tuple(float(x) for x in ref.impacts), "reference", float(ref.rtol),
                 float(acc.get("trust_t", math.nan)), int(acc.get("trust_impacts", -1)), ref.describe(),
                 tuple(float(x) for x in imp) if len(imp) == len(ref.impacts) else ())


def truth(run: Run, reference: Callable[[], Any] | None) -> Truth | None:
    """The exact solution when the model has one for ``run``, else the reference that
    ``reference()`` returns (None: none), else None."""
    ex = exact_truth(run)
    if ex is not None:
        return ex
    ref = reference() if reference is not None else None
    return reference_truth(ref) if ref is not None else None


# ---- the measures ------------------------------------------------------------------------------
def accuracy(run: Run, tr: Truth) -> dict[str, Any]:
    """Whole-run errors of every scored observable and declared position."""
    return metrics.accuracy(run.history, tr.history, run.scored_columns() or None, ref_impacts=tr.impacts,
                            declared=run.declared)


def events(run: Run, tr: Truth) -> dict[str, Any]:
    """Impact-time and rebound-apex errors."""
    return metrics.event_errors(run.history, run.impact_times, tr.history, tr.impacts, run.declared)


def impacts(run: Run, tr: Truth) -> dict[str, Any]:
    """Errors before the first impact, per re-synchronised window, energy per impact
    (the exact impact map with the contact law's restitution)."""
    return impact_metrics.impact_scores(run.history, run.impacts, tr.history, tr.impacts, run.system,
                                        restitution(run.system), run.declared)


def trusted(run: Run, tr: Truth) -> dict[str, Any]:
    """``trust_t``, ``trust_impacts`` of the truth and the errors of every scored observable
    on [0, trust_t] (:func:`daebench.harness.scoring.metrics.trusted_errors`), named
    ``err_<obs>_{final,max,l2}_trusted`` (none without a trusted span: a reference computed
    without its accuracy record)."""
    out: dict[str, Any] = {"trust_t": tr.trust_t, "trust_impacts": tr.trust_impacts}
    if math.isfinite(tr.trust_t):
        errs = metrics.trusted_errors(run.history, tr.history, tr.impacts, tr.trust_t,
                                          run.scored_columns() or None, declared=run.declared)
        out.update({f"{k}_trusted": v for k, v in errs.items()})
    return out


#: every measure of a run against its truth, in column order (see the module docstring)
#: (event sequence classified, the exact impact oracle, the graph distance, the modal band
#: errors of a flexible model, velocities in L¹ and the impulse measure of a run with contacts)
MEASURES: tuple[Callable[[Run, Truth], dict[str, Any]], ...] = (accuracy, trusted, events, impacts,
                                                                eventseq.measure, oracle.measure,
                                                                graphdist.measure, modal.measure,
                                                                nonsmooth.measure)


def score(run: Run, tr: Truth | None,
          measures: Sequence[Callable[[Run, Truth], dict[str, Any]]] = MEASURES) -> dict[str, Any]:
    """Every score of ``run`` against ``tr``: ``against`` (what it was scored against),
    ``ref_rtol`` (when scored against a reference), then the columns of each of
    ``measures`` (default: all); without a truth only the run's impact count
    (``impacts``; ``impacts_ref`` 0, impact-time errors NaN)."""
    if tr is None or not len(run.history):
        return metrics.impact_time_errors(run.impact_times, [])
    out: dict[str, Any] = {"against": tr.against}
    if tr.against == "reference":
        out["ref_rtol"] = tr.rtol
    if run.unscored():
        out["unscored_observables"] = ",".join(run.unscored())
    for m in measures:
        out.update(m(run, tr))
    return out
