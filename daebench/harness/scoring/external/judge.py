"""The verdict of an external trajectory, by the rules a daebench run is held to.

A file is ``completed`` only when none of these rules finds its physics broken (the first
that does gives the status and the reason; the row's errors are then NaN, as a run's that
did not complete):

1. **Penetration** (:func:`daebench.driver.history.penetration`): a ``gap`` column below
   −PENETRATION × the case's length scale — the trajectory went through a rigid obstacle:
   ``diverged``.
2. **Divergence** (:func:`daebench.driver.history.divergence`) with the case's own energy
   scale (:func:`daebench.core.energyscale.energy_scale` at the case's start, never the
   file's values, which garbage inflates), when the file holds energy terms: ``diverged``.
3. **No energy made at an impact** (:mod:`daebench.core.impact_checks`, rule 4) when the
   case's restitution is ≤ 1: the cumulative ``D_impacts`` falling, or ``E`` rising across
   the two rows of an impact, by more than round-off of the energy scale: ``failed``.
4. **Values beyond the case** — for every file, energy terms or not: a scored observable
   farther than :data:`BEYOND` × its range from the truth's values (a noise file, |x|
   3 900 m on a 1 m pendulum): ``diverged``.
5. **A trajectory that does not move** where the truth does (a constant or all-zero file):
   ``failed``.

In rules 4 and 5 a truth's range counts from its round-off, :data:`ROUNDOFF` × its size
(the largest of its values, the case's length scale for a column in metres, one radian for
an angle): a block resting on its ground has a gap and a tilt of 0 that a reference holds to
±1e-16, and a file holding them at 0 exactly has not failed to move.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from daebench.core.energyscale import energy_scale
from daebench.core.impact_checks import ENERGY_ROUNDOFF, REL_TOL
from daebench.driver.history import DIVERGENCE_ENERGY, divergence, penetration
from daebench.harness.scoring.graphdist import value_scale
from daebench.harness.scoring.pipeline import restitution

#: a value farther than this × the truth's range from the truth's interval is beyond the case
BEYOND = DIVERGENCE_ENERGY
#: relative round-off of a truth's values: a range below ROUNDOFF × their size is none
ROUNDOFF = 1e-12
#: the size of a column by its unit, beside its values (metres: the case's length scale)
UNIT_SIZE = {"rad": 1.0, "deg": 180.0 / math.pi}


def case_energy_scale(system: Any) -> float:
    """The energy scale of the case's start [J] (the one rule of the driver)."""
    q0, v0 = system.initial_state()
    return energy_scale(system, np.asarray(q0, float), np.asarray(v0, float))


def _energy(hist: pd.DataFrame, scale: float) -> str:
    """The driver's divergence rule row by row (it takes one row's works and loss), from the
    file's E, W_<effect> and D_impacts."""
    E = hist["E"].to_numpy(float)
    work = {c[2:]: hist[c].to_numpy(float) for c in hist.columns if c.startswith("W_")}
    d_imp = hist["D_impacts"].to_numpy(float) if "D_impacts" in hist.columns else np.zeros_like(E)
    resid = E - E[0] - sum(work.values(), np.zeros_like(E)) + d_imp
    for i in range(E.size):
        bad, why = divergence(E[i], resid[i], {k: float(w[i]) for k, w in work.items()}, float(E[0]), scale,
                              float(d_imp[i]))
        if bad.any():
            return f"diverged: {why} at t = {hist['t'].iloc[i]:.6g} s"
    return ""


def _impact_energy(hist: pd.DataFrame, scale: float, e: float) -> str:
    if not (math.isfinite(e) and e <= 1.0):
        return ""
    t = hist["t"].to_numpy(float)
    tol = ENERGY_ROUNDOFF * scale
    if "D_impacts" in hist.columns:
        d = np.diff(hist["D_impacts"].to_numpy(float))
        lim = tol + REL_TOL * np.abs(hist["D_impacts"].to_numpy(float)[1:])
        if (d < -lim).any():
            k = int(np.flatnonzero(d < -lim)[0])
            return (f"failed: D_impacts (the energy lost at impacts, cumulative) falls by {-d[k]:.3e} J at "
                    f"t = {t[k + 1]:.9g} s: an impact made energy, which the case's restitution e = {e:g} ≤ 1 "
                    f"does not allow")
    if "E" in hist.columns:
        E = hist["E"].to_numpy(float)
        pairs = np.flatnonzero(np.diff(t) == 0)
        gain = E[pairs + 1] - E[pairs]
        bad = gain > tol + REL_TOL * np.abs(E[pairs])
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            return (f"failed: the impact at t = {t[pairs[k]]:.9g} s made {gain[k]:.3e} J of energy (E before "
                    f"{E[pairs[k]]:.6g} J, after {E[pairs[k] + 1]:.6g} J; e = {e:g} ≤ 1)")
    return ""


def _still(ref: np.ndarray, unit: str, length: float) -> float:
    """The round-off of a truth's values (module docstring)."""
    size = length if unit == "m" else UNIT_SIZE.get(unit, 0.0)
    return ROUNDOFF * max(float(np.max(np.abs(ref))), size)


def _values(hist: pd.DataFrame, truth: pd.DataFrame, columns: Sequence[str], units: Mapping[str, str],
            length: float) -> str:
    """Rules 4 and 5 (module docstring), column by column; ``units`` by column, ``length``
    the case's length scale [m]."""
    for c in columns:
        if c not in hist.columns or c not in truth.columns:
            continue
        ref = truth[c].to_numpy(float)
        ref = ref[np.isfinite(ref)]
        if not ref.size:
            continue
        y, lo, hi = hist[c].to_numpy(float), float(ref.min()), float(ref.max())
        still = _still(ref, units.get(c, ""), length)
        rng = max(value_scale(ref), still)
        if ((y > hi + BEYOND * rng) | (y < lo - BEYOND * rng)).any():
            k = int(np.argmax(np.abs(y - np.clip(y, lo, hi))))
            return (f"diverged: '{c}' reaches {y[k]:.4g} at t = {hist['t'].iloc[k]:.6g} s, more than {BEYOND:g} × "
                    f"its range {rng:.3g} outside the case's values [{lo:.4g}, {hi:.4g}]")
        if np.ptp(y) == 0.0 and hi - lo > still:
            return (f"failed: '{c}' is {y[0]:.6g} at every row while the case's varies over [{lo:.4g}, {hi:.4g}]: "
                    f"not a trajectory of the case")
    return ""


def verdict(hist: pd.DataFrame, truth: pd.DataFrame, system: Any, columns: Sequence[str],
            units: Mapping[str, str] | None = None) -> tuple[str, str]:
    """(status, reason) of an external history against its truth (module docstring):
    ('completed', '') or ('diverged' | 'failed', why). ``columns``: the scored observables,
    ``units``: their units by column (none: sized by their values alone)."""
    scale = case_energy_scale(system)
    found = ""
    if "gap" in hist.columns and int(getattr(system, "n_contacts", 0)):
        bad, why = penetration(hist[["gap"]].to_numpy(float), float(system.length_scale()))
        found = f"diverged: {why} at t = {hist['t'].iloc[int(np.argmax(bad))]:.6g} s" if bad.any() else ""
    if not found and "E" in hist.columns:
        found = _energy(hist, scale)
    found = found or _impact_energy(hist, scale, restitution(system))
    found = found or _values(hist, truth, columns, units or {}, float(system.length_scale()))
    if not found:
        return "completed", ""
    status, _, why = found.partition(": ")
    return status, why
