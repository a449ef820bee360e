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
8.6e-13 of a value apart at most on beam-impact); it records, per dropped column, a
fingerprint of the rebuilt values (:func:`fingerprint`: the values at :data:`SAMPLES`
evenly spaced rows, the largest magnitude, the sum of magnitudes, the count of NaN) and
the largest difference from the stored ones. :func:`rebuild` computes them again and
refuses a column that does not match its fingerprint to :data:`REBUILD_RTOL` of its largest
magnitude (another model: then the reference is not the one that was checked, and
:func:`daebench.harness.references.reference.install_shipped` refuses it).

Why a tolerance and not the bits: the rebuilt columns come from the model's compiled
kernels, whose last bits depend on the CPU numba compiles for (vector width, the order of
sums, the math library). A SHA-256 of the bits refused the shipped beam-impact reference on
an AMD EPYC machine — every rebuilt column differed in its last bits — so a fresh install
there computed it again (about 30 s of the first `daebench compare`). The reference itself
is trusted to 1e-4 of each observable's range (its own check runs); 1e-12 of a column's
magnitude is arithmetic, not another model.

beam-impact (N = 5, 20 001 rows, 36 columns): 3.53 MB stored whole, 1.71 MB thin (16 columns
rebuilt, the largest difference 2.6e-13 J in E_kinetic).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

#: the sidecar field of a thin reference: {dropped column: its fingerprint and "max_difference"}
DERIVED_KEY = "derived_columns"
#: a column is dropped when the states rebuild it to this fraction of its largest magnitude
REBUILD_RTOL = 1e-12
#: the sidecar field holding the whole history's column order
ORDER_KEY = "columns_whole"
#: rows of a rebuilt column whose values its fingerprint keeps (evenly spaced, ends included)
SAMPLES = 65
_FINGERPRINT = ("samples", "scale", "sum_abs", "nan")


def _sample_rows(n: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, SAMPLES)).round().astype(np.int64)) if n else np.zeros(0, np.int64)


def fingerprint(values: np.ndarray) -> dict[str, Any]:
    """What a thin reference keeps of a rebuilt column: {"samples" (its values at the rows
    :func:`_sample_rows` picks for its length, None for NaN), "scale" (largest magnitude),
    "sum_abs" (sum of magnitudes), "nan" (count)}."""
    v = np.asarray(values, float)
    finite = np.isfinite(v)
    return {"samples": [None if np.isnan(x) else float(x) for x in v[_sample_rows(len(v))]],
            "scale": float(np.abs(v[finite]).max(initial=0.0)), "sum_abs": float(np.abs(v[finite]).sum()),
            "nan": int(np.isnan(v).sum())}


def mismatch(values: np.ndarray, fp: dict[str, Any]) -> str:
    """Why ``values`` do not match fingerprint ``fp`` to :data:`REBUILD_RTOL` of its scale
    ("" when they do): the sampled values each within it, the sum of magnitudes within it
    times the rows, the same count of NaN."""
    v = np.asarray(values, float)
    rows = _sample_rows(len(v))
    if int(np.isnan(v).sum()) != fp["nan"]:
        return f"{int(np.isnan(v).sum())} NaN instead of {fp['nan']}"
    if len(rows) != len(fp["samples"]):
        return f"{len(fp['samples'])} sampled values for {len(v)} rows (another history length)"
    tol = REBUILD_RTOL * fp["scale"] + np.finfo(float).tiny   # a column of zeros: subnormals are arithmetic too
    want = np.array([np.nan if x is None else x for x in fp["samples"]], float)
    got = v[rows]
    if not np.array_equal(np.isnan(got), np.isnan(want)) or np.nan_to_num(np.abs(got - want)).max(initial=0.0) > tol:
        return f"at a sampled row it differs by {np.nan_to_num(np.abs(got - want)).max(initial=0.0):.3g} (allowed {tol:.3g})"
    total = float(np.abs(v[np.isfinite(v)]).sum())
    if abs(total - fp["sum_abs"]) > tol * max(len(v), 1):
        return f"the sum of its magnitudes differs by {abs(total - fp['sum_abs']):.3g} (allowed {tol * len(v):.3g})"
    return ""


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
    """(the history without the columns the states determine, {dropped column:
    :func:`fingerprint` of the rebuilt values and "max_difference": largest |rebuilt − stored|}).

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
            derived[c] = {**fingerprint(v), "max_difference": worst}
    return hist.drop(columns=list(derived)), derived


def rebuild(system: Any, kept: pd.DataFrame, derived: dict[str, dict[str, Any]], order: list[str]
            ) -> pd.DataFrame:
    """The whole history from its thin form ``kept``: the ``derived`` columns computed
    again, checked against their fingerprints, in the column ``order`` of the whole history.

    Raises
    ------
    ValueError
        A derived column that the model does not compute, or whose rebuilt values do not
        match their fingerprint (the message names it and says by how much), or an
        ``order`` that is not kept ∪ derived.
    """
    if not all(isinstance(d, dict) and all(k in d for k in _FINGERPRINT) for d in derived.values()):
        raise ValueError(f"the sidecar's {DERIVED_KEY} are not {{column: {{{', '.join(_FINGERPRINT)}, "
                         f"max_difference}}}} (a reference shipped by an older daebench: reship it)")
    if sorted(order) != sorted(list(kept.columns) + list(derived)):
        raise ValueError("the recorded column order is not the kept and derived columns")
    got = _rebuilt(system, kept)
    missing = [c for c in derived if c not in got]
    if missing:
        raise ValueError(f"today's model does not compute the column(s) {', '.join(missing)} from the states")
    wrong = {c: why for c in derived if (why := mismatch(got[c], derived[c]))}
    if wrong:
        raise ValueError("the column(s) rebuilt from the states differ from the computed ones (another model): "
                         + "; ".join(f"{c}: {why}" for c, why in wrong.items()))
    whole = kept.assign(**{c: got[c] for c in derived})
    return whole[list(order)]
