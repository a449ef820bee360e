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


def diverging(resid: float | np.ndarray, scale: float) -> bool | np.ndarray:
    """Whether an energy residual says the run diverged: not finite, or beyond
    ``DIVERGENCE_ENERGY`` × the run's energy scale (elementwise for an array)."""
    return ~np.isfinite(resid) | (np.abs(resid) > DIVERGENCE_ENERGY * scale)


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
          work: Mapping[str, float], E0: float, d_impacts: float, observables: Iterable[str] | None,
          n_active: int | None) -> Block:
    """The rows at output times ``t`` of one stretch without events (:func:`columns` over arrays)."""
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
