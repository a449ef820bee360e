"""The event-driven driver every integrator shares.

A run is a sequence of smooth phases with a fixed active set. Within a phase the
integrator steps freely; after each accepted step the driver looks for events in the
step just taken, on the integrator's dense output:

* a contact gap closing (g: + → −; after a release or rebound, once the gap has left a
  ``GAP_BAND`` zero band) — with the ``constraint`` law an *impact*: the
  Newton impact map with restitution e is applied, and the contact is closed
  (e = 0, or a rebound too slow to resolve) or left open with ġ⁺ = −e ġ⁻;
  with a continuous law (Hertz, penalty) the approach speed v₀ is recorded and the
  step size switches to ``h_contact``;
* a closed contact's force λ turning tensile (λ: + → −): the contact opens;
* a penetrating contact separating (continuous laws: g: − → +);
* with Coulomb friction (μ > 0) at closed contacts: a slipping contact's slip velocity
  through zero, a sticking one's force leaving the cone (:mod:`daebench.driver.stickslip`).

Where several contacts close at once the declared impact law applies (``contact.impact_law``:
simultaneous, the default, or sequential; with friction Newton–Coulomb in the manner of
Pfeiffer & Glocker); the run record names it (``RunResult.impact_law``).

The earliest event is located to ``EVENT_TOL`` seconds by Brent's method on the dense
output; the run is cut there, the event applied, and the integrator restarted on the
new phase (multistep methods rebuild their history).

Bookkeeping for honest metrics, on every step: the work of non-conservative effects
(trapezoidal rule over the integrator's own steps), the energy lost at impacts
(exact), and while contacts are closed the constraint residuals C, Ċ, C̈.
The energy-balance residual is  E(t) − E(0) − W_nc(t) + D_impacts(t).
"""

from __future__ import annotations

import dataclasses
import math
import time
import traceback
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import pandas as pd

from daebench.core import coulomb, impact_checks, interrupt
from daebench.core.contact import Impact
from daebench.driver.contact_state import ContactState, Friction
from daebench.driver.events import find_event
from daebench.driver.transitions import apply_event, impact_law_name, project_resting, settle
from daebench.driver.books import Books, Diverged
from daebench.driver.history import Block, frame, states_arrays
from daebench.driver.stickslip import PAINLEVE_SLIP
from daebench.integrators.applicability import check_fits
from daebench.integrators.base import Advance, Integrator, IntegratorError, StepFailure
from daebench.core.problem import Problem
from daebench.stepping import watch as _watch
from daebench.driver.step_policy import StepPolicy
from daebench.stepping.watch import Watch
from daebench.core.system import MechanicalSystem, State
from daebench.core.energyscale import energy_scale

# the compiled loops' own rule of the end, called here as plain Python: one source, no dispatch per call
_end_reached = getattr(_watch.end_reached, "py_func", _watch.end_reached)

MAX_STALLED_PHASES = 100 # consecutive phases that do not advance time: the event logic is stuck
PROGRESS_EVERY = 0.25    # s of wall time between two progress reports


@dataclass
class RunResult:
    """Everything one run produced."""

    status: str                       # completed | diverged | failed
    message: str
    t_final: float
    wall_s: float
    counters: dict[str, int]
    history: pd.DataFrame
    impacts: list[Impact] = field(default_factory=list)
    constraint_max: dict[str, float] = field(default_factory=lambda: {"C": 0.0, "Cdot": 0.0, "Cddot": 0.0})
    energy_residual: float = math.nan
    final: State | None = None
    phases: int = 0
    states: dict[str, np.ndarray] | None = None  # with record_states: t, q, v, a, lam at the output times
    impact_law: str = ""              # the driver's impact law, e.g. "newton, simultaneous" ("": none applied)
    traceback: str = ""               # where the exception that ended the run was raised ("" if none did)
    refused: bool = False             # the integrator refused this system before its first step (IntegratorError)


    @property
    def ok(self) -> bool:
        return self.status == "completed"


class Driver(Books):
    """Runs one integrator on one system from t = 0 to ``t_end`` (the contacts' state:
    :mod:`daebench.driver.contact_state`; event location: :mod:`daebench.driver.events`; the
    impact map and the other transitions: :mod:`daebench.driver.transitions`)."""

    def __init__(self, system: MechanicalSystem, integrator: Integrator, t_end: float,
                 output_dt: float, observables: list[str] | None = None,
                 progress: Callable[[float], None] | None = None, record_states: bool = False,
                 policy: StepPolicy | None = None):
        if t_end <= 0:
            raise ValueError(f"t_end must be positive, got {t_end}")
        if output_dt <= 0:
            raise ValueError(f"output dt must be positive, got {output_dt}")
        self.system = system
        self.integ = integrator
        self.t_end = float(t_end)
        n_out = int(round(t_end / output_dt))
        self.t_out = np.linspace(0.0, t_end, n_out + 1) if abs(n_out * output_dt - t_end) < 1e-9 * t_end \
            else np.append(np.arange(0.0, t_end, output_dt), t_end)
        self.observables = observables
        self.progress = progress
        self.record_states = record_states
        self._progress_wall = 0.0
        self.policy = policy if policy is not None else StepPolicy.of(integrator)
        law = system.contact_law
        check_fits(type(integrator), system, self.policy.adaptive)
        # contacts the driver treats (none when the integrator resolves them itself)
        mine = law is not None and system.n_contacts > 0 and not integrator.capabilities.contacts
        self._constraint_contacts = mine and not law.continuous
        self._continuous_contacts = mine and law.continuous

    # -- public -----------------------------------------------------------------
    def run(self) -> RunResult:
        with interrupt.signals_counted():
            return self._run()

    def _run(self) -> RunResult:
        wall0 = time.perf_counter()
        sys_ = self.system
        q, v = sys_.initial_state()
        q = np.asarray(q, float)
        v = np.asarray(v, float)
        cs = self.contacts = ContactState.start(Problem(sys_), q, self._constraint_contacts,
                                                self._continuous_contacts, v)
        cs.rules.near_h = self.policy.near_h
        self.rows: list[dict[str, float] | Block] = []
        self.inside: list[float] = []
        self._states: list[tuple] = []
        self.cmax = {"C": 0.0, "Cdot": 0.0, "Cddot": 0.0}
        self._current = cs.phase(sys_)
        self.work: dict[str, float] = {k: 0.0 for k in self._power_terms(0.0, q, v)}  # W(0) = 0, not NaN
        if self.integ.capabilities.contacts:
            self.work["contact"] = 0.0  # booked from Advance.contact_work; the t = 0 row too
        if cs.friction.mu.any():
            self.work["friction"] = 0.0  # slip friction at closed contacts (the t = 0 row too)
        self._contact_work: tuple[float, ...] | None = None
        self._work_book = impact_checks.ContactWork()   # rule 6 of core.impact_checks
        terms0 = sys_.energy(q, v)
        self.E0 = float(sum(terms0.values()))
        # energy scale of the run: the size of the initial energy terms (a system starting
        # at E0 = 0 with large opposite terms still has a scale)
        self.energy_scale = energy_scale(sys_, q, v)  # core.energyscale: the one rule (zero starts too)
        # the penetration rule of capturing steps (driver.history.penetration): rigid contacts only
        law = sys_.contact_law
        self._length_scale = (sys_.length_scale() if self.integ.capabilities.contacts and sys_.n_contacts
                              and (law is None or not law.continuous) else None)
        self.out_i = 0
        status, message, refused = "completed", "", False
        state = State(0.0, q, v)
        phases = 0
        signals = interrupt.signal_count()
        try:
            stalled = 0
            while not _end_reached(state.t, self.t_end):
                phases += 1
                t_before = state.t
                state = self._phase(state)
                stalled = stalled + 1 if state.t <= t_before else 0
                if stalled > MAX_STALLED_PHASES:
                    raise StepFailure(f"no progress: {stalled} consecutive events at t = {state.t:.12g} s "
                                      f"(contact set {cs.active}); the event logic cannot resolve this state")
        except Diverged as exc:
            status, message = "diverged", str(exc)
        except StepFailure as exc:
            msg = str(exc)
            status = "diverged" if msg.lower().startswith("diverged") else "failed"
            if exc.t is not None:
                self._t_last = max(self._t_last, float(exc.t))
            message = f"t = {self._t_last:.6g} s: {msg}"
        except BaseException as exc:  # noqa: BLE001 - a run is a boundary its code cannot cross
            if interrupt.from_signal(exc, signals):
                raise     # Ctrl-C, SIGTERM or the wall-time cap: the caller's business
            status, message = "failed", f"t = {self._t_last:.6g} s: {interrupt.describe_raised(exc)}"
            # not applicable: the integrator said so (its type of error) before it took a step
            steps = getattr(getattr(self.integ, "counters", None), "steps", 0)   # a plugin may lack counters
            refused = isinstance(exc, IntegratorError) and self._t_last == 0.0 and not steps
            if getattr(self.integ, "failure", None) is None:
                self.integ.failure = exc  # its traceback, for `run --traceback` and RunOutput.traceback
        failure = getattr(self.integ, "failure", None)
        where = "".join(traceback.format_exception(failure)) if failure is not None and status != "completed" else ""
        broken = impact_checks.violations(cs.impacts, self.energy_scale)
        hist = frame(self.rows)
        if self.integ.capabilities.contacts:   # rules 5 to 7: a capturing contact makes no energy
            e = None if law is None or getattr(law, "restitution", None) is None else float(law.restitution)
            broken += (impact_checks.capturing_violations(cs.impacts, self.energy_scale, e)
                       + self._work_book.violations(self.energy_scale, e))
            if status == "completed" and len(hist):
                # at step ends only: an interpolant's energy inside a step is not the scheme's
                at = ~np.isin(hist["t"].to_numpy(), self.inside)
                balance = np.asarray(hist["energy_residual"].to_numpy() + hist.get("W_contact", 0.0), float)[at]
                broken += impact_checks.energy_made(hist["t"].to_numpy()[at], balance, cs.impacts,
                                                    self.energy_scale, e)
        if broken and status == "completed":
            status, message = "failed", impact_checks.verdict(broken)
        res = float(np.nanmax(np.abs(hist["energy_residual"]))) if len(hist) else math.nan
        return RunResult(status, message, self._t_last, time.perf_counter() - wall0,
                         self.integ.counters_snapshot(), hist, cs.impacts, dict(self.cmax), res,
                         self._last_state, phases,
                         states_arrays(self._states, sys_.n, sys_.n_bilateral) if self.record_states else None,
                         impact_law_name(cs), where, refused)

    _t_last = 0.0
    _last_state: State | None = None

    # -- one smooth phase ----------------------------------------------------------
    def _phase(self, state: State) -> State:
        cs = self.contacts
        if cs.constraint and not cs.friction.mu.any() and settle(cs, state.t, state.q, state.v):
            # the acceleration-level contact law changed the closed set: start that phase
            q, v = project_resting(cs, cs.phase(self.system), state.t, state.q, state.v)
            return State(state.t, q, v)
        problem = self._current = cs.phase(self.system)
        a, lam = problem.acceleration(state.t, state.q, state.v)
        cs.update_near(problem, state.q, state.v, a)
        state = State(state.t, state.q, state.v, a, lam)
        if cs.constraint and cs.active and cs.friction.mu.any():
            # frictional contacts: a closed contact that would pull (λ < 0) opens before the phase starts
            k = problem.n_bilateral
            tensile = [c for j, c in enumerate(cs.active) if lam[k + j] < 0.0]
            if tensile:
                if cs.friction.slip:
                    self._painleve(state, [c for c in tensile if c in cs.friction.slip])
                cs.release(tensile, state.t, state.q)
                return state
            # a stick group whose force is outside the cone slips (the direction its force fails)
            failing = [(c, lt) for c, (margin, lt) in cs.cone_margins(problem, lam).items() if margin < 0.0]
            if failing:
                for c, lam_t in failing:
                    for m in cs.friction.groups[c]:
                        del cs.friction.stick[m]
                        cs.friction.slip[m] = math.copysign(1.0, lam_t)
                cs.regroup(state.t, state.q)
                return state
        h = self.policy.start_step(cs.in_contact, cs.memory.halvings)
        cs.rules.step = self.policy.zeno_step(h)
        self.integ.start(problem, state, h)
        if self.out_i == 0 and state.t == 0.0:
            self._record_until(state, state, problem, 0.0)
        powers0 = self._power(state)
        batch = self._batch_ok(problem)
        while True:
            # the compiled loop books the slip friction's work itself (core.coulomb): no other power
            watch = self._watch(problem) if (batch and not set(powers0) - {"friction"}
                                             and self.out_i < len(self.t_out)) else None
            if watch is not None and problem.slips:
                coulomb.start_book(problem.kernel.friction, self.work["friction"], powers0["friction"])
            adv = self._advance(watch)
            if watch is not None and problem.slips:
                powers0 = self._booked_friction(problem, adv, powers0)
            interrupt.check()  # a safe point: a wall-time cap's request is honoured here
            prev, new = adv.prev, adv.new
            self._t_last = new.t
            self._last_state = new
            self._report_progress(new.t)
            self._check_finite(new)
            event = find_event(cs, prev, new, problem, self.integ.dense)
            end = new if event is None else self.integ.dense(event.t)
            if event is not None:
                end = State(event.t, end.q, end.v, end.a, end.lam)
            powers1 = self._power(end)
            self._accumulate_work(prev, end, powers0, powers1, problem)
            self._track_constraints(new, problem)  # at the integrator's own step, not an interpolant
            powers0 = powers1
            if event is not None:
                return apply_event(cs, event, end, problem, self.work.get("contact", 0.0))
            if _end_reached(new.t, self.t_end):
                return new

    def _painleve(self, state: State, pulling: list[int]) -> None:
        """A slipping contact that pulls, and would penetrate when opened: Painlevé's paradox."""
        cs = self.contacts
        rest = [c for c in cs.active if c not in pulling]
        kept = Friction(cs.friction.mu, {c: a for c, a in cs.friction.stick.items() if c in rest},
                        {c: s for c, s in cs.friction.slip.items() if c in rest})
        trial = dataclasses.replace(cs, active=rest, penetrating=set(), near=set(), impacts=[], friction=kept)
        trial.regroup(state.t, state.q)
        a, _ = trial.phase(self.system).acceleration(state.t, state.q, state.v)
        g, G, gam = cs.base.gap_rows(state.q, state.v)
        gdd = G[pulling] @ a - gam[pulling]
        if (gdd < 0.0).any():
            raise StepFailure(f"{PAINLEVE_SLIP} (contacts {pulling} at t = {state.t:.9g} s)", state.t)

    def _report_progress(self, t: float) -> None:
        """Tell the caller the simulated time, at most every PROGRESS_EVERY seconds of wall time."""
        if self.progress is None:
            return
        now = time.perf_counter()
        if now - self._progress_wall >= PROGRESS_EVERY:
            self._progress_wall = now
            self.progress(t)

    # -- fast path: many quiet steps per call ----------------------------------------------
    def _batch_ok(self, problem: Problem) -> bool:
        """Whether this phase may run many steps per call of ``integ.advance``.

        Only when the model declares that it has no non-conservative power outside
        contact (``system.power_free``) and no continuous contact is penetrating. Within such a phase the per-step driver work on a step
        without event, output time or sign change is exactly what the runner does itself
        (re-arming gaps, constraint maxima); the step that needs more is handed back and
        processed below like any other step, so results do not depend on the path."""
        return self.system.power_free and not self.contacts.penetrating

    def _watch(self, problem: Problem) -> Watch:
        cs = self.contacts
        k = problem.n_bilateral
        inactive = np.array([i for i in range(problem.n_contacts) if i not in cs.active], dtype=np.int64) \
            if cs.watched else np.zeros(0, dtype=np.int64)
        lam_rows = np.array([k + j for j in range(len(cs.active))], dtype=np.int64) \
            if cs.constraint else np.zeros(0, dtype=np.int64)
        armed = cs.armed if cs.armed.size else np.zeros(1, dtype=bool)
        cmax = np.array([self.cmax["C"], self.cmax["Cdot"], self.cmax["Cddot"]])
        near = np.zeros(armed.size, dtype=bool)
        near[list(cs.near)] = True
        return _watch.make(problem.n, problem.m, inactive, lam_rows, armed.copy(), problem.m > 0, cmax,
                           float(self.t_out[self.out_i]), self.t_end, cs.rules.near_h, near)

    def _advance(self, watch: Watch | None) -> Advance:
        """One call of the integrator; adopt its quiet steps' bookkeeping and the contact
        episodes it resolved itself."""
        cs = self.contacts
        recording = watch is not None and getattr(self.integ, "records_outputs", False)
        try:
            adv = self.integ.advance(self.t_end, watch, **({"outputs": self.t_out[self.out_i:]} if recording else {}))
        except StepFailure as exc:  # the rows of the quiet steps before the failing one are kept
            self._rows(exc.outputs, self._current)
            raise
        # rows of the output times its quiet steps passed (integrators with records_outputs, e.g. IDA;
        # a power-free phase: the work is unchanged)
        self._rows(getattr(adv, "outputs", ()), self._current)
        if watch is not None:
            if cs.armed.size:
                cs.armed = np.asarray(adv.armed, dtype=bool)[:cs.armed.size].copy()
            c = adv.cmax
            self.cmax.update(C=float(c[0]), Cdot=float(c[1]), Cddot=float(c[2]))
        cs.impacts.extend(adv.events)
        self._contact_work = adv.contact_work
        if adv.contact_work is not None and len(adv.contact_work) == 2:
            # impulse work, booked per step (rule 6); a work booked with its power is a force's,
            # which gives energy back within an episode as it expands (lcp-avg's averaged gap)
            self._work_book.add(adv.new.t, adv.contact_work[1])
        return adv



def simulate(system: MechanicalSystem, integrator: Integrator, t_end: float, output_dt: float,
             observables: list[str] | None = None,
             progress: Callable[[float], None] | None = None, record_states: bool = False,
             policy: StepPolicy | None = None) -> RunResult:
    """Run ``integrator`` on ``system`` over [0, t_end] with events; see :class:`Driver`.

    ``progress(t)`` is called with the simulated time reached, at most every
    ``PROGRESS_EVERY`` seconds of wall time (for progress bars). With ``record_states``
    the result's ``states`` holds the integrator's own (t, q, v, a, λ_bilateral) at every
    output time, as arrays. ``policy``: the run's step rules (default: the integrator's
    settings, :meth:`StepPolicy.of`)."""
    return Driver(system, integrator, t_end, output_dt, observables, progress, record_states, policy).run()
