"""The unilateral contact law's invariants, checked on every run's impact records.

A run record (its :class:`daebench.core.contact.Impact` list) satisfies the unilateral
law when

1. **no pull** — every impulse is ≥ 0: the driver's impacts, and every episode an
   event-capturing integrator resolved (the episode's impulse and its first step's);

and, for the driver's Newton impacts (whose record states the restitution e it applied:
the scene's, or 0 where it closed a rebound too slow or too short to resolve), exactly
(under the Liu–Zhao–Brogliato multiple-impact law, whose outcome is not Newton's, rules 3
and 4):

2. **Newton's law** — ġ⁺ + e ġ⁻ = 0 for a contact with an impulse (the complementarity of
   P > 0), ≥ 0 for the others;
3. **no impact on a separating contact** — no impulse where ġ⁻ > 0 (a contact at rest,
   ġ⁻ = 0, can be pushed shut by another contact's impulse in a simultaneous impact);
4. **no energy made** — for e ≤ 1 the kinetic energy lost at an impact is ≥ 0.

An event-capturing episode is held to rule 1 only: its ġ⁺ is read at its end and its
energy change spans its steps, so both carry the steps' smooth forces, inputs (a crank's
drive) and friction, and are off Newton's law by O(h) — the oracle scores that
(:mod:`daebench.harness.scoring.oracle`), and the driver's divergence rule catches energy
made from nowhere over the run (:func:`daebench.driver.history.divergence`).
Continuous-law episodes (Hertz, penalty: no impulse) are not impacts and are not checked.

Tolerances are the driver's round-off: :data:`REL_TOL` relative to each record's own
scales (|ġ⁻|, P|ġ⁻|), :data:`ABS_VN` on normal velocities and :data:`ENERGY_ROUNDOFF` of
the run's energy scale. :func:`violations` returns one line per broken rule; the driver
turns a non-empty list into a run that did not complete.
"""

from __future__ import annotations

import math
from typing import Iterable

from daebench.core.contact import Impact

REL_TOL = 1e-8     # relative tolerance of the equalities and inequalities below
ABS_VN = 1e-12     # m/s: normal velocities below this are zero
ENERGY_ROUNDOFF = 1e-12    # energy changes below this × the run's energy scale are round-off
MAX_LINES = 5      # violations listed in a message (the count says how many in all)


def _finite(x: float) -> bool:
    return x is not None and math.isfinite(x)


def record_violations(imp: Impact, energy_scale: float = 0.0) -> list[str]:
    """The rules (module docstring) one record breaks, as short sentences; ``energy_scale``:
    the run's (the round-off floor of rule 4). A driver's record carries the restitution
    it applied; an event-capturing episode's has none (NaN)."""
    out = []
    P = imp.impulse
    if not _finite(P):
        return out  # a continuous-law episode: no impulse, not an impact
    where = f"t = {imp.t:.9g} s, contact {imp.contact}"
    scale_p = REL_TOL * max(abs(P), abs(imp.impact_impulse) if _finite(imp.impact_impulse) else 0.0) + 1e-300
    for name, p in (("impulse", P), ("impact impulse", imp.impact_impulse)):
        if _finite(p) and p < -scale_p:
            out.append(f"{where}: {name} {p:.3e} N s < 0 (the contact pulls)")
    vn_m, vn_p = imp.vn_minus, imp.vn_plus
    if getattr(imp, "law", "") == "lzb":  # the multiple-impact law: no Newton equality; rules 3, 4
        if vn_m > ABS_VN:
            out.append(f"{where}: impact on a separating contact (ġ⁻ = {vn_m:+.3e} m/s)")
        if _finite(imp.energy_loss) and imp.energy_loss < -REL_TOL * abs(P * vn_m) - ENERGY_ROUNDOFF * energy_scale:
            out.append(f"{where}: the impact made {-imp.energy_loss:.3e} J of kinetic energy (LZB)")
        return out
    e = imp.restitution
    if not _finite(e):
        return out  # an event-capturing episode: rule 1 only
    if vn_m > ABS_VN:
        out.append(f"{where}: impact on a separating contact (ġ⁻ = {vn_m:+.3e} m/s)")
    tol = REL_TOL * max(abs(vn_m), abs(vn_p)) + ABS_VN
    resid = vn_p + e * vn_m
    if resid < -tol:
        out.append(f"{where}: ġ⁺ = {vn_p:+.6e} m/s below −e ġ⁻ = {-e * vn_m:+.6e} m/s (e = {e:g})")
    elif P > 0.0 and resid > tol:
        out.append(f"{where}: ġ⁺ = {vn_p:+.6e} m/s ≠ −e ġ⁻ = {-e * vn_m:+.6e} m/s with an impulse (e = {e:g})")
    if _finite(imp.energy_loss) and e <= 1.0:
        if imp.energy_loss < -REL_TOL * abs(P * vn_m) - ENERGY_ROUNDOFF * energy_scale - 1e-300:
            out.append(f"{where}: the impact made {-imp.energy_loss:.3e} J of kinetic energy (e = {e:g} ≤ 1)")
    return out


def violations(impacts: Iterable[Impact], energy_scale: float = 0.0) -> list[str]:
    """Every rule broken by the records ``impacts`` of a run whose energy scale is
    ``energy_scale`` (module docstring)."""
    out: list[str] = []
    for imp in impacts:
        out += record_violations(imp, energy_scale)
    return out


def verdict(found: list[str]) -> str:
    """The message of a run whose records break the law ('' when none does)."""
    if not found:
        return ""
    more = f" (and {len(found) - MAX_LINES} more)" if len(found) > MAX_LINES else ""
    return (f"the run's impacts break the unilateral contact law in {len(found)} place(s): "
            + "; ".join(found[:MAX_LINES]) + more)
