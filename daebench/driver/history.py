"""The run's history table: rows the driver writes one at a time, and blocks of rows
written at once.

A compiled loop hands the driver the states of every output time its quiet steps passed
(:class:`daebench.integrators.base.RecordedAdvance`): between two events nothing but the
state changes from one of those rows to the next — the work booked, the energy lost at
impacts, the active set are the same — so their columns are built as arrays in one pass
(:func:`block`) instead of a dict per row. :func:`frame` joins rows and blocks, in order,
into the table ``pandas.DataFrame(list_of_rows)`` would give for the history's numeric
columns: the same columns in the same order (first seen first), the same values to the
bit, the same dtypes (int64 where every row has an int, float64 with NaN where a part lacks
the column).
"""

from __future__ import annotations

from typing import Iterable, Mapping

import numpy as np
import pandas as pd

DIVERGENCE_ENERGY = 10.0  # energy residual beyond this × energy scale means the run diverged (energy from nowhere)


class Block(dict):
    """Columns of consecutive history rows: name → 1-D array, or a scalar shared by all."""

    def head(self, k: int) -> "Block":
        """The first ``k`` rows."""
        return Block({c: (v[:k] if isinstance(v, np.ndarray) else v) for c, v in self.items()})


#: works that can only take energy out of the system (their laws are passive): a gain the
#: energy shows beyond the other works' input is energy made from nowhere, whatever they booked
DISSIPATIVE_WORK = ("contact", "friction", "damping")


def divergence(E: float | np.ndarray, resid: float | np.ndarray, work: Mapping[str, float | np.ndarray], E0: float,
               energy_scale: float, d_impacts: float) -> tuple[np.ndarray, str]:
    """The one divergence rule, for every integrator and both contact families (elementwise
    over output rows): the run diverged where

    * the energy-balance residual is not finite, or beyond ``DIVERGENCE_ENERGY`` × the
      bookkeeping scale (the start's energy scale, every work booked and the impact loss), or
    * the energy grew beyond ``DIVERGENCE_ENERGY`` × (the start's scale + the input works)
      more than the input works supplied: E − E0 − Σ W_input — the input works being all
      but :data:`DISSIPATIVE_WORK`, whose booking cannot excuse a gain (an unstable contact
      step books its own energy as contact work: the residual closes, the energy grows).

    ``work`` gives each effect's work for all rows or one per row.
    Returns the mask and the reason of its first row ("" where none diverged)."""
    resid = np.asarray(resid, dtype=float)
    inputs = sum(w for k, w in work.items() if k not in DISSIPATIVE_WORK)
    scale = energy_scale + sum(abs(w) for w in work.values()) + d_impacts
    in_scale = energy_scale + sum(abs(w) for k, w in work.items() if k not in DISSIPATIVE_WORK)
    gain = np.asarray(E, dtype=float) - E0 - inputs
    bad_resid = ~np.isfinite(resid) | (np.abs(resid) > DIVERGENCE_ENERGY * scale)
    bad_gain = ~np.isfinite(gain) | (gain > DIVERGENCE_ENERGY * in_scale)
    bad = bad_resid | bad_gain
    if not bad.any():
        return bad, ""
    i = int(np.argmax(bad.ravel()))
    at = lambda x: float(np.broadcast_to(x, bad.shape).ravel()[i])  # noqa: E731  (row i's value)
    if bad_resid.ravel()[i]:
        why = (f"energy residual {at(resid):.3g} J exceeds {DIVERGENCE_ENERGY:g} × the energy scale "
               f"{at(scale):.3g} J")
    else:
        why = (f"the energy grew by {at(gain):.3g} J beyond what the input works supplied, over "
               f"{DIVERGENCE_ENERGY:g} × the energy scale {at(in_scale):.3g} J (energy from nowhere)")
    return bad, why


#: a capturing step whose gap falls below −PENETRATION × the scene's length scale
#: (:meth:`daebench.core.system.MechanicalSystem.length_scale`) has gone through a rigid obstacle
PENETRATION = 0.5


def penetration(gaps: np.ndarray, length_scale: float) -> tuple[np.ndarray, str]:
    """The penetration rule of event-capturing runs, over output rows (``gaps``: rows ×
    contacts, or one row's contacts): a row diverged where a rigid contact's gap is below
    −PENETRATION × ``length_scale``. Returns the mask over rows and the reason of its
    first row ("" where none diverged)."""
    g = np.asarray(gaps, dtype=float)
    g = g.reshape(1, -1) if g.ndim < 2 else g
    if g.shape[1] == 0:
        return np.zeros(g.shape[0], dtype=bool), ""
    worst = np.nanmin(np.where(np.isnan(g), np.inf, g), axis=1)
    limit = -PENETRATION * length_scale
    bad = worst < limit
    if not bad.any():
        return bad, ""
    i = int(np.argmax(bad))
    c = int(np.argmin(g[i]))
    return bad, (f"contact {c} is {-worst[i]:.3g} m inside its rigid obstacle, deeper than {PENETRATION:g} × the "
                 f"scene's length scale {length_scale:.3g} m (the step went through it)")


def columns(t, obs: Mapping, terms: Mapping, work: Mapping[str, float], E0: float, d_impacts: float,
            observables: Iterable[str] | None, n_active: int | None) -> dict:
    """The history's own columns at output time ``t``: the model's observables (those asked
    for) and energy terms there, E, the work booked and the impact loss so far, the energy
    residual E − E0 − ΣW + D, the contacts in force. One rule for one row (scalars) and for a
    block (arrays over t; work, loss and contacts constant): each value is the same to the bit."""
    c = {"t": t}
    c.update(obs if observables is None else {k: obs[k] for k in observables if k in obs})
    c.update({f"E_{k}": x for k, x in terms.items()})
    E = sum(terms.values())
    c["E"] = E
    for k, w in work.items():
        c[f"W_{k}"] = w
    c["D_impacts"] = d_impacts
    c["energy_residual"] = E - E0 - sum(work.values()) + d_impacts
    if n_active is not None:
        c["n_active"] = n_active
    return c


def block(t: np.ndarray, obs: Mapping[str, np.ndarray], terms: Mapping[str, np.ndarray],
          work: Mapping[str, float | np.ndarray], E0: float, d_impacts: float, observables: Iterable[str] | None,
          n_active: int | None) -> Block:
    """The rows at output times ``t`` of one stretch without events (:func:`columns` over
    arrays; each effect's ``work`` one value for all rows or one per row)."""
    return Block(columns(np.asarray(t, dtype=float), obs, {k: np.asarray(x, dtype=float) for k, x in terms.items()},
                         work, E0, d_impacts, observables, n_active))


def frame(rows: list[dict | Block]) -> pd.DataFrame:
    """The history table of dict rows and :class:`Block` s, in order: each column joined from
    per-part arrays (a run of dict rows is one part), NaN where a part lacks the column."""
    parts: list[tuple[int, dict]] = []   # (rows, columns) of each part
    run: list[dict] = []

    def close_run() -> None:
        if run:
            keys = dict.fromkeys(k for r in run for k in r)
            parts.append((len(run), {k: np.array([r.get(k, np.nan) for r in run]) for k in keys}))
            run.clear()

    for r in rows:
        if isinstance(r, Block):
            close_run()
            parts.append((len(r["t"]), r))
        else:
            run.append(r)
    close_run()
    columns = dict.fromkeys(k for _, cols in parts for k in cols)
    table = {}
    for k in columns:
        pieces = []
        for n, cols in parts:
            v = cols.get(k, np.nan)
            pieces.append(v if isinstance(v, np.ndarray) else np.full(n, v))
        table[k] = np.concatenate(pieces) if pieces else np.empty(0)
    return pd.DataFrame(table)


def state_row(t: float, s, n: int, nb: int) -> tuple:
    """(t, q, v, a, λ of the ``nb`` bilateral constraints) of an output state ``s``; NaN where
    the integrator's state does not carry a or λ."""
    a = s.a if s.a.size == n else np.full(n, np.nan)
    lam = s.lam[:nb] if s.lam.size >= nb else np.full(nb, np.nan)
    return t, s.q.copy(), s.v.copy(), np.array(a, float), np.array(lam, float)


def states_arrays(rows: list[tuple], n: int, nb: int) -> dict[str, np.ndarray]:
    """The :func:`state_row` s as arrays: t, q, v, a, lam (one row per output time)."""
    return {"t": np.array([r[0] for r in rows]),
            **{k: (np.array([r[j] for r in rows]) if rows else np.zeros((0, size)))
               for j, (k, size) in enumerate((("q", n), ("v", n), ("a", n), ("lam", nb)), start=1)}}
