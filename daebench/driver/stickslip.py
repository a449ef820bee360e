"""Stick and slip of the driver's closed contacts with Coulomb friction (μ > 0): the phase an
integrator sees while such contacts are closed, and the rules that switch them.

The mechanism, and why it is this one
-------------------------------------
A closed contact is already a constraint row of the phase (C = −g, :mod:`daebench.core.phase`);
friction adds, per closed frictional contact, either

* **stick** — a second constraint row, the contact point's tangential position held at
  its place at the start of the stick phase: C_T(q) = s(q) − s(q*), whose Jacobian is the
  model's tangent row t_q (kernel ``tangent``). The position s is not a kernel; it is the
  line integral of t_q from the anchor q* to q (Gauss–Legendre, :data:`QUAD_NODES` nodes,
  exact to round-off for the smooth rows of a point sliding on a fixed surface, whose
  t_q is the gradient of that point's tangential coordinate), so C_T = 0, C_q = t_q and
  γ_T = −(t_q)_q[v] v hold like any bilateral row; or
* **slip** — a force −μ λ_N s t_qᵀ along the tangent row (s = sign of the slip velocity
  t_q v, fixed for the phase), λ_N the contact's normal force. λ_N is the consistent
  multiplier of the phase at (t, q, v): the augmented system with the friction columns,
  [[M, C_qᵀ + μ s t_qᵀ e_Nᵀ], [C_q, 0]] [a; λ] = [Q; γ], solved wherever the force is
  evaluated, so the phase is one smooth DAE (a force that depends on the state).

Both are data of the phase (:class:`daebench.core.problem.Problem`'s ``friction``): the
compiled phase appends the stick rows to the bilateral constraints and adds the slip
force to the applied force (:mod:`daebench.core.coulomb`), so every integrator that takes
constraints runs the frictional phases unchanged and compiled, as fast as a frictionless
phase apart from the rows' own cost (``daebench perf`` reports it); the compiled loop
watches the switches below and books the slip friction's work on the steps it takes on
its own; a frictionless phase carries no friction data.

The switches (:mod:`daebench.driver.events` locates them on the dense output like every
other event, by the rules of :mod:`daebench.core.coulomb` the compiled watch applies too):

* slip → stick: the slip velocity t_q v of a slipping contact reaches zero ("stop");
  the contact sticks, anchored there; at the start of the next phase the cone is checked;
* stick → slip: the stick force leaves the cone, |λ_T| > μ λ_N ("slide", or found at a
  phase start): the contact slips in the direction s = sign(λ_T) (the friction force
  −λ_T can no longer hold it).

Contacts whose stick rows are parallel (the two bottom corners of a block flat on the
ground) keep one row; the group's cone is |Σ λ_T| ≤ μ Σ λ_N, the one test that does not
depend on the statically indeterminate split of the tangential force. A stick row that is
dependent but parallel to none is refused (StepFailure, named).

A slipping contact that would pull (λ_N < 0) while opening it would let it penetrate
(g̈ < 0) has no consistent motion — Painlevé's paradox: the run ends with that verdict
(:data:`PAINLEVE_SLIP`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from daebench.core import kernels
from daebench.core.coulomb import CONE_TOL, GAMMA_STEP, QUAD_NODES, SLIP_MIN, slip_rate  # noqa: F401 (the rules)
from daebench.core.problem import Problem

PARALLEL_COS = 1.0 - 1e-9  # two tangent rows with |cos| above this are parallel (one stick row)

PAINLEVE_SLIP = ("a slipping contact would pull (λ_N < 0) while opening it lets it penetrate: no consistent "
                 "motion — an inconsistent frictional contact (Painlevé's paradox)")


def tangent_row(md: Any, j: int, q: np.ndarray, v: np.ndarray | None = None) -> np.ndarray:
    """The tangent Jacobian row t_q of contact j at q (the model's ``tangent`` kernel)."""
    tq = np.zeros(q.shape[0])
    kernels.tangent(md, int(j), np.ascontiguousarray(q, float),
                    np.zeros(q.shape[0]) if v is None else np.ascontiguousarray(v, float), tq)
    return tq


def slip_velocity(md: Any, j: int, q: np.ndarray, v: np.ndarray) -> float:
    """The slip velocity t_q(q) v of contact j (:func:`daebench.core.coulomb.slip_rate`, the
    rule the compiled watch applies)."""
    n = q.shape[0]
    return float(slip_rate(md, int(j), np.ascontiguousarray(q, float), np.ascontiguousarray(v, float),
                           np.zeros(n), np.zeros(n)))


def phase_friction(active: list[int], stick: dict[int, np.ndarray], groups: dict[int, list[int]],
                   slip: dict[int, float], mu: np.ndarray) -> dict | None:
    """The ``friction`` of the phase (:class:`daebench.core.problem.Problem`) whose closed
    contacts ``active`` stick (anchors ``stick``, rows kept ``groups``) or slip (``slip``):
    None when none does."""
    if not groups and not slip:
        return None
    return {"groups": {c: list(groups[c]) for c in groups}, "anchors": {c: stick[c] for c in groups},
            "slip": dict(slip), "mu": mu}


def stick_groups(base: Problem, md: Any, t: float, q: np.ndarray, active: list[int],
                 sticking: list[int]) -> dict[int, list[int]]:
    """{kept contact: its parallel group} of the sticking contacts: a row is kept when it
    is independent of the bilateral, normal and kept rows; a dependent row joins the kept
    row it is parallel to. Raises ValueError for a dependent row parallel to none."""
    _, Bq, _, _ = base.constraint_rows(t, q)
    G = base.gap_jacobian(q)[active] if active else np.zeros((0, q.size))
    rows = np.vstack([Bq, G])
    groups: dict[int, list[int]] = {}
    kept_rows: dict[int, np.ndarray] = {}
    for j in sorted(sticking):
        tj = tangent_row(md, j, q)
        trial = np.vstack([rows, *kept_rows.values(), tj])
        if np.linalg.matrix_rank(trial) == trial.shape[0]:
            groups[j], kept_rows[j] = [j], tj
            continue
        for k, tk in kept_rows.items():
            if abs(tj @ tk) >= PARALLEL_COS * np.linalg.norm(tj) * np.linalg.norm(tk):
                groups[k].append(j)
                break
        else:
            raise ValueError(f"statically indeterminate stick: the tangent row of contact {j} depends on the "
                             f"other constraint rows but is parallel to no stick row")
    return groups
