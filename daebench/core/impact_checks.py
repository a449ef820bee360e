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

An event-capturing episode is held to rule 1 and to rule 4 in the form its record allows
(:func:`capturing_violations`): its ġ⁺ is read at its end, so it carries the steps' smooth
forces and is off Newton's law by O(h) — the oracle scores that
(:mod:`daebench.harness.scoring.oracle`) —, but with e ≤ 1 (or no restitution of the
scheme's own) a contact makes no energy:

5. **no energy made at an impact** — for an episode whose record states its impact step
   (``impact_impulse``) and that began approaching, the energy that step's impact made.
   Where the stepper books the impact's own work (``impact_work``, Moreau–Jean: Σ P (U⁻ +
   U⁺)/2 of the contact's impulses in that step, normal and tangential — their kinetic-energy
   change by Kelvin's theorem, no smooth force and no scheme error in it) and the normal
   velocity U⁻ its law used (``u_law``, approaching: U⁻ < 0), that work is ≤ 0 to
   round-off (:data:`REL_TOL` of P|U⁻| plus :data:`ENERGY_ROUNDOFF` of the run's energy
   scale). Measured with Moreau–Jean at h = 1e-4 and 4e-5: frictionless impacts (ball,
   spring-wall and Housner's block with e = 1) ≤ 2.2e-16 P|U⁻|; Housner's block with e = 1,
   μ = 1 makes 4.48e-4 and 4.46e-4 P|U⁻| at every impact — the same at both steps, so the
   law's, not the scheme's; the slider-crank's positive impulse work (2.6e-5 J) is on
   contacts with U⁻ ≥ 0, which its index set holds shut (no impact: rule 6 bounds them).
   Where the impulse carries a smooth force's share (nonsmooth generalized-α: λ's, no
   ``impact_work``), the energy change over the impact step (``energy_loss``) is a loss, to
   :data:`CAPTURE_REL` of P|ġ⁻| plus :data:`CAPTURE_ENERGY_TOL` of the run's energy scale —
   the scheme's own energy error at the impact step is in it (spring-wall, e = 1 and no
   friction, 1.1e-4 P|ġ⁻| at h = 1e-4 and 1.3e-3 P|ġ⁻| at h = 1e-3 with ρ∞ = 1; the
   falling rod's 9.7 J is 0.11 P|ġ⁻|);
6. **no energy made by contact work** — the cumulative work of the contact impulses the
   integrator books (``W_contact``, Σ P (U⁻ + U⁺)/2 with the tangential impulses: the
   impulses' kinetic-energy change by Kelvin's theorem) never rises above its running
   minimum by more than :data:`CAPTURE_WORK_TOL` of the energy scale
   (:class:`ContactWork`; a persistent contact's steps let it drift: +1.6e-5 J, 3e-6 of
   the scale, over 0.6 s of Housner's block rocking at h = 1e-4, e = 0, μ = 1). Only a
   work of impulses booked per step (Moreau–Jean, nonsmooth generalized-α); a contact force's
   work booked with its power (lcp-avg's time-averaged gap) gives energy back within an
   episode as the contact expands, and is held to the energy balance instead;
7. **no net energy made across contacts** — for an event-capturing run, E − E0 − W (W: the
   work of the forces other than the contact's; the energy residual plus any booked contact
   work) read at the output times where no contact episode is open, and at a step's end (the
   driver drops the rows its dense output serves from inside a step: Moreau–Jean on
   spring-wall at h·ω = 1 keeps E0 to 1e-13 at the step ends while its interpolant dips 92 %
   below), never rises above its
   running minimum over such times by more than :data:`CAPTURE_GAIN_TOL` of the energy scale
   (:func:`energy_made`). It holds the schemes that book no contact work: the
   interactive-mode method's lagged contact force gains energy over a burst of episodes
   although no single one shows it (rod-wall, 50 elements, h = 2e-7 s: +0.0328 J, 8.4 % of
   ½mv0² = 0.3925 J; a single 8.6 µs episode moves the energy by −7.7e-4 … +3.0e-3 J against
   |P ġ⁻| ≈ 0.038 J, both signs, so no per-episode rule can tell). Measured on the same scene:
   Moreau–Jean 2.3e-12, the nonsmooth generalized-α 1.6e-8 of the scale (slider-slot, h = 1e-7 s:
   Moreau–Jean 1.3e-5). Between two contact-free times the scheme's own drift is in it too: a
   run that gains energy with every contact open has not run the physics either.

Newton's law with Coulomb friction and e > 0 can make energy at a step of Moreau–Jean or a
nonsmooth generalized-α (Glocker; Studer, *Numerics of Unilateral Contacts and Friction*,
2009): that is the law's, not a bug of the step — and a run that makes it is not a run of
the physics it was asked for, so it fails and says where and how much.
Continuous-law episodes (Hertz, penalty: no impulse) are not impacts and are not checked.

Tolerances are the driver's round-off: :data:`REL_TOL` relative to each record's own
scales (|ġ⁻|, P|ġ⁻|), :data:`ABS_VN` on normal velocities and :data:`ENERGY_ROUNDOFF` of
the run's energy scale. :func:`violations` returns one line per broken rule; the driver
turns a non-empty list into a run that did not complete.
"""

from __future__ import annotations

import math
from typing import Iterable

import numpy as np

from daebench.core.contact import Impact

REL_TOL = 1e-8     # relative tolerance of the equalities and inequalities below
ABS_VN = 1e-12     # m/s: normal velocities below this are zero
ENERGY_ROUNDOFF = 1e-12    # energy changes below this × the run's energy scale are round-off
MAX_LINES = 5      # violations listed in a message (the count says how many in all)
CAPTURE_REL = 1e-2          # rule 5: energy an impact step may make, × its P|ġ⁻| ...
CAPTURE_ENERGY_TOL = 1e-7   # ... plus this × the run's energy scale
CAPTURE_WORK_TOL = 1e-3     # rule 6: rise of the booked contact work allowed, × the run's energy scale
CAPTURE_GAIN_TOL = 1e-3     # rule 7: net rise of E − E0 − W across contacts allowed, × the energy scale


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


def capturing_violations(impacts: Iterable[Impact], energy_scale: float, restitution: float | None) -> list[str]:
    """Rule 5 (module docstring) on the episodes an event-capturing integrator reported, whose
    scene has restitution ``restitution`` (None: the scheme has none of its own, ≤ 1 by
    its physics); [] for e > 1, which may make energy."""
    if restitution is not None and restitution > 1.0:
        return []
    e = "" if restitution is None else f", e = {restitution:g} ≤ 1"
    floor = CAPTURE_ENERGY_TOL * energy_scale
    out, advised = [], False
    for imp in impacts:
        if not _finite(imp.impact_impulse):
            continue   # no impact step recorded (lcp, lcp-avg: the episode's change, its smooth forces in it)
        if _finite(imp.impact_work) and _finite(imp.u_law):   # the impact's own work: round-off only
            if imp.u_law < -ABS_VN and imp.impact_work > (REL_TOL * abs(imp.impact_impulse * imp.u_law)
                                                          + ENERGY_ROUNDOFF * energy_scale):
                advice = "" if advised else ("; Newton's law with Coulomb friction can make energy where e > 0: "
                                             "lower contact.restitution or contact.friction")
                advised = True
                out.append(f"t = {imp.t:.9g} s, contact {imp.contact}: the impact's impulses made "
                           f"{imp.impact_work:.4g} J of energy, {imp.impact_work / abs(imp.impact_impulse * imp.u_law):.3g}"
                           f" of P|U⁻| (U⁻ = {imp.u_law:+.4g} m/s{e}{advice})")
            continue
        own = CAPTURE_REL * abs(imp.impact_impulse * imp.vn_minus)
        if _finite(imp.impulse) and not _finite(imp.restitution) and _finite(imp.energy_loss) \
                and imp.vn_minus < -ABS_VN and imp.energy_loss < -floor - own:   # an impact: it approached
            out.append(f"t = {imp.t:.9g} s, contact {imp.contact}: the contact step made {-imp.energy_loss:.4g} J "
                       f"of energy (ġ⁻ = {imp.vn_minus:+.4g} m/s{e})")
    return out


class ContactWork:
    """Rule 6 (module docstring): the cumulative contact work an event-capturing integrator
    books, seen after each of its calls (:meth:`add`); :meth:`violations` names the largest
    rise above the running minimum, with the times of both, when it exceeds the tolerance."""

    def __init__(self) -> None:
        self.low, self.t_low = 0.0, 0.0
        self.rise, self.span = 0.0, (0.0, 0.0)

    def add(self, t: float, work: float) -> None:
        """The cumulative contact work ``work`` [J] at time ``t`` [s]."""
        if not _finite(work):
            return
        if work < self.low:
            self.low, self.t_low = work, t
        elif work - self.low > self.rise:
            self.rise, self.span = work - self.low, (self.t_low, t)

    def violations(self, energy_scale: float, restitution: float | None) -> list[str]:
        if (restitution is not None and restitution > 1.0) or self.rise <= CAPTURE_WORK_TOL * energy_scale:
            return []
        e = "" if restitution is None else f" with e = {restitution:g} ≤ 1"
        a, b = self.span
        return [f"t = {a:.9g} … {b:.9g} s: the contact impulses did {self.rise:+.4g} J of work{e} "
                f"(energy made by contact; {self.rise / energy_scale:.2g} of the energy scale)"]


def energy_made(t: np.ndarray, balance: np.ndarray, impacts: Iterable[Impact], energy_scale: float,
                restitution: float | None) -> list[str]:
    """Rule 7 (module docstring): ``balance`` = E − E0 − W at the output times ``t`` of an
    event-capturing run, read where no episode of ``impacts`` is open (t in [start, end]; an
    episode open at the run's end stays open). From such a time t_j to the first such time t_k
    after a burst of episodes ends, the balance may rise by :data:`CAPTURE_GAIN_TOL` of
    ``energy_scale`` plus rule 5's band of the impact steps in between (:data:`CAPTURE_REL` × P|ġ⁻| of each episode that records one: the
    scheme's own error at an impact step); the largest excess, with both times, is a
    violation. [] for e > 1, which may make energy."""
    if restitution is not None and restitution > 1.0:
        return []
    t, balance = np.asarray(t, float), np.asarray(balance, float)
    free = np.isfinite(balance)
    starts, bands = [], []
    for imp in impacts:
        end = imp.t_end if _finite(imp.t_end) else math.inf
        free &= ~((t >= imp.t) & (t <= end))
        if _finite(imp.impact_impulse) and _finite(imp.vn_minus):
            starts.append(imp.t)
            bands.append(CAPTURE_REL * abs(imp.impact_impulse * imp.vn_minus))
    if free.sum() < 2:
        return []
    tf, bf = t[free], balance[free]
    # judged after a burst of episodes (the first contact-free time after one ends), against any
    # contact-free time before it: a step's preparation of an impact (a projection out of the
    # wall the step before) belongs to its burst
    ends = np.sort([imp.t_end for imp in impacts if _finite(imp.t_end)])
    after = np.diff(np.searchsorted(ends, tf, side="right"), prepend=0) > 0
    order = np.argsort(starts)
    allowed = np.concatenate(([0.0], np.cumsum(np.asarray(bands)[order])))[
        np.searchsorted(np.asarray(starts)[order], tf, side="left")] if starts else np.zeros_like(tf)
    excess_of = bf - allowed                     # the balance net of the impacts' band so far
    low = np.minimum.accumulate(excess_of)
    if not after.any():
        return []
    k = int(np.argmax(np.where(after, excess_of - low, -np.inf)))
    j = int(np.flatnonzero(excess_of[:k + 1] == low[k])[-1])
    excess = float(excess_of[k] - low[k])
    if excess <= CAPTURE_GAIN_TOL * energy_scale:
        return []
    rise, band = float(bf[k] - bf[j]), float(allowed[k] - allowed[j])
    e = "" if restitution is None else f" with e = {restitution:g} ≤ 1"
    within = f", {band:.3g} J of it the impact steps' band" if band > 0.0 else ""
    return [f"t = {tf[j]:.9g} … {tf[k]:.9g} s: E − E0 − W rose by {rise:+.4g} J between these times, no contact "
            f"open at either ({excess / energy_scale:.2g} of the energy scale beyond the allowance{within}; energy "
            f"made across contacts{e}; a contact force that lags a step makes less at a smaller step)"]
