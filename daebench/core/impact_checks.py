"""The unilateral contact law's invariants, checked on every run's impact records.

A run record (its :class:`daebench.core.contact.Impact` list) satisfies the unilateral
law when, for every record with an impulse (an impact of the event-driven driver, or an
episode an event-capturing integrator resolved):

1. **no pull** — the impulse is ≥ 0 (the episode's and its first step's);
2. **Newton's law** — for an impacting contact (ġ⁻ < 0): ġ⁺ + e ġ⁻ ≥ 0, with equality
   for the driver's impacts (whose record states the restitution e it applied: the
   scene's, or 0 where it closed a rebound too slow or too short to resolve) — the
   complementarity of an impulse P > 0;
3. **no impact on a separating contact** — the driver records no impulse where ġ⁻ > 0
   (a contact at rest, ġ⁻ = 0, can be pushed shut by another contact's impulse in a
   simultaneous impact; an event-capturing episode may start on a contact already
   closed: that is a contact episode, whose impulse carries the step's forces);
4. **no energy made** — for e ≤ 1 the kinetic energy lost at an impact is ≥ 0.

Continuous-law episodes (Hertz, penalty: no impulse) are not impacts and are not checked;
the episodes of an integrator that resolves contacts by a force law over time (declared
``Capabilities.impact_law = "force"``: the time-averaged-gap LCP, the interactive-mode
method) are held to rules 1 and 4.
Tolerances are relative to each record's own scales (|ġ⁻|, P|ġ⁻|): round-off passes,
a law broken by more than :data:`REL_TOL` does not. An event-capturing scheme meets
Newton's law at the end of its impact step to its Newton tolerance on the step's
displacement (1e-12 by default, so ≈ 1e-12/h on the velocity): its records are held to
:data:`CAPTURE_REL` of |ġ⁻| plus :data:`CAPTURE_VN` instead, and its episodes' energy,
which includes the step's smooth work, to :data:`CAPTURE_ENERGY_REL` of P|ġ⁻|. :func:`violations` returns one line
per broken rule; the driver turns a non-empty list into a run that did not complete.
"""

from __future__ import annotations

import math
from typing import Iterable

from daebench.core.contact import Impact

REL_TOL = 1e-8     # relative tolerance of the equalities and inequalities below
ABS_VN = 1e-12     # m/s: normal velocities below this are zero
CAPTURE_REL = 1e-6  # Newton's inequality of an event-capturing episode: relative to |ġ⁻| …
CAPTURE_VN = 1e-8   # … plus this (m/s): the schemes' Newton tolerance on the step's velocity
CAPTURE_ENERGY_REL = 1e-3  # an episode's step also carries the smooth forces over h: its kinetic
                           # energy balance holds to O(h) (nonsmooth generalized-α on spring-wall,
                           # h = 1e-4 s: 1.1e-4 of P|ġ⁻|); a pulling or energy-making law is O(1)
MAX_LINES = 5      # violations listed in a message (the count says how many in all)


def _finite(x: float) -> bool:
    return x is not None and math.isfinite(x)


def record_violations(imp: Impact, restitution: float, newton: bool = True) -> list[str]:
    """The rules (module docstring) one record breaks, as short sentences. ``newton``: the
    record's contact law is Newton's at velocity level (else a force law over time — a
    compliant or force-level treatment an integrator resolves itself — whose episodes are
    held to rules 1 and 4 only)."""
    out = []
    P = imp.impulse
    if not _finite(P):
        return out  # a continuous-law episode: no impulse, not an impact
    vn_m, vn_p = imp.vn_minus, imp.vn_plus
    where = f"t = {imp.t:.9g} s, contact {imp.contact}"
    scale_p = REL_TOL * max(abs(P), abs(imp.impact_impulse) if _finite(imp.impact_impulse) else 0.0) + 1e-300
    for name, p in (("impulse", P), ("impact impulse", imp.impact_impulse)):
        if _finite(p) and p < -scale_p:
            out.append(f"{where}: {name} {p:.3e} N s < 0 (the contact pulls)")
    driver = _finite(imp.restitution)
    if driver and vn_m > ABS_VN:
        out.append(f"{where}: impact on a separating contact (ġ⁻ = {vn_m:+.3e} m/s)")
    e = imp.restitution if driver else restitution
    if newton and _finite(e) and _finite(vn_p) and (vn_m < -ABS_VN or (driver and P > 0.0)):
        # impacting (ġ⁻ < 0), or at rest and pushed shut by another contact's impulse (ġ⁻ = 0)
        tol = REL_TOL * max(abs(vn_m), abs(vn_p)) + ABS_VN if driver else CAPTURE_REL * abs(vn_m) + CAPTURE_VN
        resid = vn_p + e * vn_m
        if resid < -tol:
            out.append(f"{where}: ġ⁺ = {vn_p:+.6e} m/s below −e ġ⁻ = {-e * vn_m:+.6e} m/s (e = {e:g})")
        elif driver and P > 0.0 and resid > tol:
            out.append(f"{where}: ġ⁺ = {vn_p:+.6e} m/s ≠ −e ġ⁻ = {-e * vn_m:+.6e} m/s with an impulse (e = {e:g})")
    if _finite(imp.energy_loss) and _finite(e) and e <= 1.0 and vn_m < 0.0:
        if imp.energy_loss < -(REL_TOL if driver else CAPTURE_ENERGY_REL) * abs(P * vn_m) - 1e-300:
            out.append(f"{where}: the impact made {-imp.energy_loss:.3e} J of kinetic energy (e = {e:g} ≤ 1)")
    return out


def violations(impacts: Iterable[Impact], restitution: float, newton: bool = True) -> list[str]:
    """Every rule broken by the records ``impacts`` of a run whose contacts have the
    restitution ``restitution`` (NaN: none declared; the driver's records carry theirs) and
    whose integrator resolves them by Newton's law (``newton``, else by a force law)."""
    out: list[str] = []
    for imp in impacts:
        out += record_violations(imp, restitution, newton)
    return out


def verdict(found: list[str]) -> str:
    """The message of a run whose records break the law ('' when none does)."""
    if not found:
        return ""
    more = f" (and {len(found) - MAX_LINES} more)" if len(found) > MAX_LINES else ""
    return (f"the run's impacts break the unilateral contact law in {len(found)} place(s): "
            + "; ".join(found[:MAX_LINES]) + more)
