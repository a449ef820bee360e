"""An exact impact oracle per impact: the scene's Newton impact law applied to the run's own
pre-impact state, against what the run did there.

A trajectory error after an impact mixes two things: how far the run had drifted before
it (its pre-impact state is not the reference's) and how well it treats the impact itself.
The oracle removes the first: at the run's own configuration q and pre-impact velocity v⁻
(the impact record's, :class:`daebench.core.contact.Impact`), Newton's law with the
scene's restitution e through the system's mass matrix M(q), gap Jacobian g_q(q) and
bilateral constraint Jacobian C_q gives the exact post-impact velocity v⁺ and impulse Λ,
computed by the one impact map of the package, :func:`daebench.core.contact.impact_map`
(the driver applies the same function). Against it:

* the velocity jump, relative, in the kinetic-energy norm ‖x‖_M = √(xᵀ M x) (one norm for
  coordinates of mixed units): ``err_impact_dv`` = ‖Δv_run − Δv_exact‖_M / ‖Δv_exact‖_M with
  Δv = v⁺ − v⁻;
* the impulse [N s]: ``err_impulse`` = |Λ_run − Λ| and relative ``err_impulse_rel`` = that / Λ.

What the run's values are, per family:

* event-driven runs (the driver's impact map): v⁻, v⁺ and Λ of the map at the located
  impact; the oracle reproduces them to round-off unless the driver closed the contact
  plastically (a rebound slower than its threshold, a Zeno re-impact) — the impact
  treatment of these runs is exact, their post-impact error is the trajectory's;
* event-capturing runs (contact episodes, :mod:`daebench.stepping.episodes`): the state at
  the start of the episode's first step (v⁻), after that step (v⁺) and that step's impulse
  (``impact_impulse``). The step also carries the smooth forces over h (a Moreau step's
  impulse holds the weight m g h of the step as well as the impact's (1 + e) m |ġ⁻|), so
  these errors are O(h): the cost of resolving the impact inside a step.

Checked are the records with a state (q, v⁻, v⁺) whose contact approaches at v⁻
(g_q v⁻ < 0: Newton's law gives a jump); others (a grazing or separating start of an
episode, a continuous-law episode, a record without state) are counted as skipped.
Other contacts closed at the impact are not included (the record does not say which were
closed; every shipped impact scene has one contact point).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np

from daebench.core.contact import ImpactResult, impact_map
from daebench.core.params import ParamError


@dataclass(frozen=True)
class ImpactCheck:
    """One impact record against the oracle."""

    t: float
    contact: int
    dv_rel: float             # ‖Δv_run − Δv_exact‖_M / ‖Δv_exact‖_M
    impulse_run: float        # Λ of the run [N s]
    impulse_exact: float      # Λ of the exact law at the run's pre-impact state [N s]

    @property
    def impulse_err(self) -> float:
        return abs(self.impulse_run - self.impulse_exact)


def exact_impact(system: Any, q: np.ndarray, v_minus: np.ndarray, contact: int, restitution: float,
                 t: float = 0.0) -> ImpactResult:
    """The Newton impact of ``contact`` at (q, v⁻) with restitution e, respecting the
    system's bilateral constraints C_q v = 0: :func:`daebench.core.contact.impact_map` on
    M(q), the contact's row of g_q(q) and C_q(t, q)."""
    e = float(restitution)
    if not (math.isfinite(e) and 0.0 <= e <= 1.0):
        raise ParamError(f"the restitution of the impact oracle must lie in [0, 1], got {restitution!r}")
    q = np.asarray(q, float)
    v = np.asarray(v_minus, float)
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise ParamError("the impact oracle needs a finite pre-impact state (q, v⁻)")
    M = np.atleast_2d(system.mass(q))
    G = np.atleast_2d(system.gap_jacobian(q))
    if not 0 <= int(contact) < G.shape[0]:
        raise ParamError(f"contact {contact} does not exist: the system has {G.shape[0]} contact point(s)")
    Cb = np.atleast_2d(system.constraint_jacobian(t, q)).reshape(-1, M.shape[0])
    return impact_map(M, G[[int(contact)]], v, e, Cb if Cb.shape[0] else None)


def _m_norm(M: np.ndarray, x: np.ndarray) -> float:
    return math.sqrt(max(float(x @ M @ x), 0.0))


def run_impulse(record: Any) -> float:
    """The impulse of the impact itself in a record: ``impact_impulse`` when given (an
    event-capturing episode's first step), else ``impulse`` (the driver's map)."""
    ii = float(getattr(record, "impact_impulse", math.nan))
    return ii if math.isfinite(ii) else float(getattr(record, "impulse", math.nan))


def check_impact(system: Any, record: Any, restitution: float) -> ImpactCheck | None:
    """The oracle at one record's own pre-impact state; None when the record cannot be
    checked (no state, or its contact does not approach at v⁻)."""
    q, vm, vp = (getattr(record, k, None) for k in ("q", "v_minus", "v_plus"))
    if q is None or vm is None or vp is None:
        return None
    q, vm, vp = (np.asarray(x, float) for x in (q, vm, vp))
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(vm)) and np.all(np.isfinite(vp))):
        return None
    res = exact_impact(system, q, vm, int(record.contact), restitution, float(record.t))
    if not res.vn_minus[0] < 0.0:
        return None
    M = np.atleast_2d(system.mass(q))
    dv_exact = res.v_plus - vm
    scale = _m_norm(M, dv_exact)
    if not scale > 0.0:
        return None
    return ImpactCheck(float(record.t), int(record.contact), _m_norm(M, (vp - vm) - dv_exact) / scale,
                       run_impulse(record), float(res.impulse[0]))


def oracle_scores(system: Any, impacts: Iterable[Any], restitution: float) -> dict[str, Any]:
    """The row's oracle columns over a run's impact records: ``err_impact_dv_max``
    (relative, M-norm), ``err_impulse_max`` [N s], ``err_impulse_rel_max``, the first
    record's ``err_impact1_dv`` (NaN when it cannot be checked), and ``oracle_impacts`` / ``oracle_skipped`` (records
    checked / not checkable). NaN errors when no record could be checked; all skipped
    for a continuous contact law (Newton's law is not the scene's) or a NaN restitution."""
    recs = list(impacts)
    law = getattr(system, "contact_law", None)
    nan = {"err_impact_dv_max": math.nan, "err_impulse_max": math.nan, "err_impulse_rel_max": math.nan,
           "err_impact1_dv": math.nan, "oracle_impacts": 0, "oracle_skipped": len(recs)}
    if (law is not None and getattr(law, "continuous", False)) or not math.isfinite(float(restitution)):
        return nan
    every = [check_impact(system, r, restitution) for r in recs]
    checks = [c for c in every if c is not None]
    if not checks:
        return nan
    dv = np.array([c.dv_rel for c in checks])
    di = np.array([c.impulse_err for c in checks])
    rel = di / np.array([c.impulse_exact for c in checks])
    return {"err_impact_dv_max": float(np.max(dv)),
            "err_impulse_max": float(np.nanmax(di)) if np.isfinite(di).any() else math.nan,
            "err_impulse_rel_max": float(np.nanmax(rel)) if np.isfinite(rel).any() else math.nan,
            "err_impact1_dv": every[0].dv_rel if every[0] is not None else math.nan,
            "oracle_impacts": len(checks), "oracle_skipped": len(recs) - len(checks)}


def measure(run: Any, truth: Any) -> dict[str, Any]:
    """The scoring pipeline's measure (:data:`daebench.harness.scoring.pipeline.MEASURES`): the run's
    impact records against the exact law with the system's restitution
    (``contact_restitution``: the scene's, whatever the law); needs no truth."""
    return oracle_scores(run.system, run.impacts, float(getattr(run.system, "contact_restitution", math.nan)))
