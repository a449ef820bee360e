"""A reference stored thin: its states and what they do not determine, the rest rebuilt.

A shipped reference (:mod:`daebench.harness.references.shipped`) travels inside the
package, so its size matters. Most of its columns are functions of the stored states
alone — the model's observables and energy terms, and E, which the model's
``output_rows`` (:class:`daebench.core.system.MechanicalSystem`) computes from
(t, q, v) — while the states (``q_*``, ``v_*``), the time, the work booked, the impact
loss, the energy residual and the contact columns are not. :func:`thin` keeps the latter
and drops a column only where ``output_rows`` gives its stored values to within
:data:`REBUILD_RTOL` of the column's largest magnitude (the run wrote some of them by
another code path: IDA's compiled output loop sums the kinetic energy in another order,
8.6e-13 of a value apart at most on beam-impact); it records, per dropped column, the
SHA-256 of the rebuilt values and the largest difference from the stored ones.
:func:`rebuild` computes them again and refuses a column whose values are not the
recorded ones to the last bit (another model, or another machine's arithmetic: then the
reference is not the one that was checked, and
:func:`daebench.harness.references.reference.install_shipped` refuses it).

beam-impact (N = 5, 20 001 rows, 36 columns): 3.53 MB stored whole, 1.71 MB thin (16 columns
rebuilt, the largest difference 2.6e-13 J in E_kinetic).
"""

from __future__ import annotations

import hashlib
from typing import Any

import numpy as np
import pandas as pd

#: the sidecar field of a thin reference: {dropped column: {"sha256", "max_difference"}}
DERIVED_KEY = "derived_columns"
#: a column is dropped when the states rebuild it to this fraction of its largest magnitude
REBUILD_RTOL = 1e-12
#: the sidecar field holding the whole history's column order
ORDER_KEY = "columns_whole"


def digest(values: np.ndarray) -> str:
    """SHA-256 of a column's values as contiguous little-endian float64."""
    return hashlib.sha256(np.ascontiguousarray(values, dtype="<f8").tobytes()).hexdigest()


def _rebuilt(system: Any, hist: pd.DataFrame) -> dict[str, np.ndarray]:
    """The columns ``system.output_rows`` computes from the stored states of ``hist``
    (observables other than the states, E_<term>, and E as the history writes it:
    :func:`daebench.driver.history.columns`); empty when the model has no ``output_rows``
    or the history lacks a state column."""
    batch = getattr(system, "output_rows", None)
    names = list(getattr(system, "coordinate_names", []) or [])
    qc, vc = [f"q_{c}" for c in names], [f"v_{c}" for c in names]
    if batch is None or not names or not set(qc + vc + ["t"]) <= set(hist.columns):
        return {}
    obs, terms = batch(hist["t"].to_numpy(float), hist[qc].to_numpy(float), hist[vc].to_numpy(float))
    out = {k: np.asarray(v, float) for k, v in obs.items() if k not in qc + vc}
    out.update({f"E_{k}": np.asarray(v, float) for k, v in terms.items()})
    out["E"] = sum(np.asarray(v, float) for v in terms.values())  # the history's order of the sum
    return out


def thin(system: Any, hist: pd.DataFrame) -> tuple[pd.DataFrame, dict[str, dict[str, Any]]]:
    """(the history without the columns the states determine, {dropped column: {"sha256":
    digest of the rebuilt values, "max_difference": largest |rebuilt − stored|}}).

    A column is dropped only when :func:`_rebuilt` gives its stored values to within
    :data:`REBUILD_RTOL` × its largest magnitude (NaN where they are NaN)."""
    derived = {}
    for c, v in _rebuilt(system, hist).items():
        if c not in hist.columns:
            continue
        stored = hist[c].to_numpy(float)
        same_nan = np.array_equal(np.isnan(stored), np.isnan(v))
        worst = float(np.abs(np.nan_to_num(v - stored)).max(initial=0.0))
        scale = float(np.nanmax(np.abs(stored))) if np.isfinite(stored).any() else 0.0
        if same_nan and worst <= REBUILD_RTOL * scale:
            derived[c] = {"sha256": digest(v), "max_difference": worst}
    return hist.drop(columns=list(derived)), derived


def rebuild(system: Any, kept: pd.DataFrame, derived: dict[str, dict[str, Any]], order: list[str]
            ) -> pd.DataFrame:
    """The whole history from its thin form ``kept``: the ``derived`` columns computed
    again, checked against their digests, in the column ``order`` of the whole history.

    Raises
    ------
    ValueError
        A derived column that the model does not compute, or whose rebuilt values differ
        from the recorded ones (the message names it; only their digest was kept), or an
        ``order`` that is not kept ∪ derived.
    """
    if not all(isinstance(d, dict) and isinstance(d.get("sha256"), str) for d in derived.values()):
        raise ValueError(f"the sidecar's {DERIVED_KEY} are not {{column: {{sha256, max_difference}}}}")
    if sorted(order) != sorted(list(kept.columns) + list(derived)):
        raise ValueError("the recorded column order is not the kept and derived columns")
    got = _rebuilt(system, kept)
    missing = [c for c in derived if c not in got]
    if missing:
        raise ValueError(f"today's model does not compute the column(s) {', '.join(missing)} from the states")
    wrong = [c for c in derived if digest(got[c]) != derived[c]["sha256"]]
    if wrong:
        raise ValueError(f"the column(s) {', '.join(wrong)} rebuilt from the states differ from the computed ones "
                         f"(another model, or this machine's arithmetic differs in the last bit)")
    whole = kept.assign(**{c: got[c] for c in derived})
    return whole[list(order)]
