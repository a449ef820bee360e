"""An exact impact oracle per impact: the scene's unilateral impact law applied to the run's
own pre-impact state, solved independently of the driver, against what the run did there.

A trajectory error after an impact mixes two things: how far the run had drifted before
it (its pre-impact state is not the reference's) and how well it treats the impact itself.
The oracle removes the first: at the run's own configuration q and pre-impact velocity v⁻
(the impact record's, :class:`daebench.core.contact.Impact`), Newton's law with the
restitution e — unilateral, for every contact that takes part —

    vn⁺ = vn⁻ + W Λ,   0 ≤ vn⁺ + e vn⁻ ⟂ Λ ≥ 0,   W = G M_B⁻¹ Gᵀ,

gives the exact post-impact velocity v⁺ and impulses Λ. The contacts that take part are
the record's and every other contact touching at q (|g| ≤ :data:`TOUCH`) that does not
separate (vn⁻ ≤ 0); under the scene's ``sequential`` impact law only the record's, the
other touching ones held as bilateral rows. The solution is computed here by a different
route than the driver's (:mod:`daebench.core.frictional_impact`: an augmented solve and
Murty's pivoting): M_B⁻¹ through an orthonormal null-space basis N of the bilateral
Jacobian, M_B⁻¹ = N (Nᵀ M N)⁻¹ Nᵀ, and the LCP (W symmetric positive definite) as its
equivalent convex quadratic program min ½ΛᵀWΛ + cᵀΛ, Λ ≥ 0 (c = (1 + e) vn⁻), written
‖LᵀΛ + L⁻¹c‖ → min with W = LLᵀ and solved by Lawson–Hanson non-negative least squares
(:func:`scipy.optimize.nnls`). So the oracle
can fail where the driver errs: an adhesive impulse, an impact applied to a separating
contact (the law gives Λ = 0 there), a wrong restitution.

Against it:

* the velocity jump in the kinetic-energy norm ‖x‖_M = √(xᵀ M x) (one norm for coordinates
  of mixed units): ``err_impact_dv`` = ‖Δv_run − Δv_exact‖_M / max(‖Δv_exact‖_M, ‖Δv_run‖_M)
  with Δv = v⁺ − v⁻ (1 where the law gives no jump and the run made one);
* the impulse [N s]: ``err_impulse`` = |Λ_run − Λ| and relative ``err_impulse_rel`` = that / Λ.

The restitution is the one the record says its law applied (the driver's records carry
it: the scene's, or 0 where it closed a rebound too slow or too short to resolve), else the
scene's. What the run's values are, per family:

* event-driven runs (the driver's impact law): v⁻, v⁺ and Λ at the located impact; the
  oracle reproduces them to round-off when the driver applied the law;
* event-capturing runs (contact episodes, :mod:`daebench.stepping.episodes`): the state at
  the start of the episode's first step (v⁻), after that step (v⁺) and that step's impulse
  (``impact_impulse``). The step also carries the smooth forces over h (a Moreau step's
  impulse holds the weight m g h of the step as well as the impact's (1 + e) m |ġ⁻|), so
  these errors are O(h): the cost of resolving the impact inside a step.

Checked are the records with a state (q, v⁻, v⁺) and an impulse; others (a continuous-law
episode, a record without state, an impact under the Liu–Zhao–Brogliato multiple-impact
law, whose outcome is not Newton's) are counted as skipped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable, NamedTuple

import numpy as np
import scipy.linalg as sl
from scipy.optimize import nnls

from daebench.core.params import ParamError

TOUCH = 1e-9  # m: a contact within this of its surface at the impact takes part in it


@dataclass(frozen=True)
class ImpactCheck:
    """One impact record against the oracle."""

    t: float
    contact: int
    dv_rel: float             # ‖Δv_run − Δv_exact‖_M / max(‖Δv_exact‖_M, ‖Δv_run‖_M)
    impulse_run: float        # Λ of the run [N s]
    impulse_exact: float      # Λ of the exact law at the run's pre-impact state [N s]

    @property
    def impulse_err(self) -> float:
        return abs(self.impulse_run - self.impulse_exact)


class ExactImpact(NamedTuple):
    """Newton's unilateral law at one state: v⁺, and per taking-part contact Λ, vn⁻, vn⁺."""

    v_plus: np.ndarray
    contacts: np.ndarray
    impulse: np.ndarray
    vn_minus: np.ndarray
    vn_plus: np.ndarray


def exact_impact(system: Any, q: np.ndarray, v_minus: np.ndarray, contact: int, restitution: float,
                 t: float = 0.0) -> ExactImpact:
    """Newton's unilateral law at (q, v⁻) with restitution e for ``contact`` and the contacts
    that take part with it (module docstring), the system's bilateral constraints
    C_q v = 0 kept; solved by the oracle's own route (null space, non-negative least squares)."""
    e = float(restitution)
    if not (math.isfinite(e) and 0.0 <= e <= 1.0):
        raise ParamError(f"the restitution of the impact oracle must lie in [0, 1], got {restitution!r}")
    q = np.asarray(q, float)
    v = np.asarray(v_minus, float)
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise ParamError("the impact oracle needs a finite pre-impact state (q, v⁻)")
    M = np.atleast_2d(system.mass(q))
    n = M.shape[0]
    G = np.atleast_2d(system.gap_jacobian(q))
    if not 0 <= int(contact) < G.shape[0]:
        raise ParamError(f"contact {contact} does not exist: the system has {G.shape[0]} contact point(s)")
    B = np.atleast_2d(system.constraint_jacobian(t, q)).reshape(-1, n)
    part, held = _taking_part(system, q, v, G, int(contact))
    N = sl.null_space(np.vstack([B, G[held]])) if (B.shape[0] or held) else np.eye(n)
    Minv = N @ np.linalg.solve(N.T @ M @ N, N.T)          # M_B⁻¹ on the constraint-respecting velocities
    Gp = G[part]
    W = Gp @ Minv @ Gp.T
    vn = Gp @ v
    c = (1.0 + e) * vn
    L = np.linalg.cholesky(W + 1e-300 * np.eye(len(part)))
    lam, _ = nnls(L.T, -np.linalg.solve(L, c))            # min ½ΛᵀWΛ + cᵀΛ, Λ ≥ 0
    v_plus = v + Minv @ Gp.T @ lam
    return ExactImpact(v_plus, np.array(part), lam, vn, Gp @ v_plus)


def _taking_part(system: Any, q: np.ndarray, v: np.ndarray, G: np.ndarray, contact: int
                 ) -> tuple[list[int], list[int]]:
    """(contacts that take part in the impact, touching contacts held as bilateral rows)."""
    gap = getattr(system, "gap", None)
    g = np.atleast_1d(gap(q)) if gap is not None else np.zeros(G.shape[0])
    vn = G @ v
    touching = [c for c in range(G.shape[0]) if c != contact and abs(g[c]) <= TOUCH and vn[c] <= 0.0]
    law = getattr(system, "contact_law", None)
    if getattr(law, "impact_law", "simultaneous") == "sequential":
        return [contact], touching
    return sorted([contact] + touching), []


def _m_norm(M: np.ndarray, x: np.ndarray) -> float:
    return math.sqrt(max(float(x @ M @ x), 0.0))


def run_impulse(record: Any) -> float:
    """The impulse of the impact itself in a record: ``impact_impulse`` when given (an
    event-capturing episode's first step), else ``impulse`` (the driver's map)."""
    ii = float(getattr(record, "impact_impulse", math.nan))
    return ii if math.isfinite(ii) else float(getattr(record, "impulse", math.nan))


def check_impact(system: Any, record: Any, restitution: float) -> ImpactCheck | None:
    """The oracle at one record's own pre-impact state; None when the record cannot be
    checked (no state, no impulse, or no jump in either the run or the law)."""
    q, vm, vp = (getattr(record, k, None) for k in ("q", "v_minus", "v_plus"))
    if q is None or vm is None or vp is None:
        return None
    q, vm, vp = (np.asarray(x, float) for x in (q, vm, vp))
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(vm)) and np.all(np.isfinite(vp))):
        return None
    P = run_impulse(record)
    if not math.isfinite(P) or getattr(record, "law", "") == "lzb":
        return None  # a continuous-law episode (no impulse), or the multiple-impact law (not Newton's)
    e_rec = float(getattr(record, "restitution", math.nan))
    res = exact_impact(system, q, vm, int(record.contact), e_rec if math.isfinite(e_rec) else restitution,
                       float(record.t))
    M = np.atleast_2d(system.mass(q))
    dv_exact, dv_run = res.v_plus - vm, vp - vm
    scale = max(_m_norm(M, dv_exact), _m_norm(M, dv_run))
    if not scale > 0.0:
        return None  # no jump, none made
    k = int(np.flatnonzero(res.contacts == int(record.contact))[0])
    return ImpactCheck(float(record.t), int(record.contact), _m_norm(M, dv_run - dv_exact) / scale, P,
                       float(res.impulse[k]))


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
    with np.errstate(divide="ignore", invalid="ignore"):
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
