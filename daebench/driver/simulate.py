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

import math
import time
import traceback
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import pandas as pd

from daebench.core import coulomb, impact_checks, interrupt
from daebench.core.contact import Impact
from daebench.driver.events import (ContactState, apply_event, find_event, impact_law_name,
                                    project_resting, settle)
from daebench.driver.history import (Block, block, columns, divergence, frame, penetration, state_row,
                                     states_arrays)
from daebench.driver.stickslip import PAINLEVE_SLIP
from daebench.integrators.applicability import check_fits
from daebench.integrators.base import Advance, Integrator, IntegratorError, StepFailure
from daebench.core.problem import Problem
from daebench.stepping import dense as _dense, watch as _watch
from daebench.stepping.watch import NEAR_STEPS, Watch
from daebench.core.system import MechanicalSystem, State
from daebench.core.energyscale import energy_scale

# the compiled loops' own rules (which output times are due, which state serves one, the
# end), called here as plain Python: one source, no dispatch per call
_output_due, _source, _end_reached = (getattr(f, "py_func", f) for f in (_watch.output_due, _dense.source,
                                                                          _watch.end_reached))

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


class _Diverged(Exception):
    pass


class Driver:
    """Runs one integrator on one system from t = 0 to ``t_end`` (the contacts' state, event
    location and the impact map: :mod:`daebench.driver.events`)."""

    def __init__(self, system: MechanicalSystem, integrator: Integrator, t_end: float,
                 output_dt: float, observables: list[str] | None = None,
                 progress: Callable[[float], None] | None = None, record_states: bool = False):
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
        law = system.contact_law
        check_fits(type(integrator), system, integrator.adaptive)
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
        if self.integ.step_size(True) < self.integ.step_size(False):
            cs.near_h = NEAR_STEPS * self.integ.step_size(False)
        self.rows: list[dict[str, float] | Block] = []
        self._states: list[tuple] = []
        self.cmax = {"C": 0.0, "Cdot": 0.0, "Cddot": 0.0}
        self._current = cs.phase(sys_)
        self.work: dict[str, float] = {k: 0.0 for k in self._power_terms(0.0, q, v)}  # W(0) = 0, not NaN
        if self.integ.capabilities.contacts:
            self.work["contact"] = 0.0  # booked from Advance.contact_work; the t = 0 row too
        if cs.mu.any():
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
        except _Diverged as exc:
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
        if self.integ.capabilities.contacts:   # rules 5 and 6: a capturing contact makes no energy
            e = None if law is None or getattr(law, "restitution", None) is None else float(law.restitution)
            broken += (impact_checks.capturing_violations(cs.impacts, self.energy_scale, e)
                       + self._work_book.violations(self.energy_scale, e))
        if broken and status == "completed":
            status, message = "failed", impact_checks.verdict(broken)
        hist = frame(self.rows)
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
        if cs.constraint and not cs.mu.any() and settle(cs, state.t, state.q, state.v):
            # the acceleration-level contact law changed the closed set: start that phase
            q, v = project_resting(cs, cs.phase(self.system), state.t, state.q, state.v)
            return State(state.t, q, v)
        problem = self._current = cs.phase(self.system)
        a, lam = problem.acceleration(state.t, state.q, state.v)
        cs.update_near(problem, state.q, state.v, a)
        state = State(state.t, state.q, state.v, a, lam)
        if cs.constraint and cs.active and cs.mu.any():
            # frictional contacts: a closed contact that would pull (λ < 0) opens before the phase starts
            k = problem.n_bilateral
            tensile = [c for j, c in enumerate(cs.active) if lam[k + j] < 0.0]
            if tensile:
                if cs.slip:
                    self._painleve(state, [c for c in tensile if c in cs.slip])
                cs.release(tensile, state.t, state.q)
                return state
            # a stick group whose force is outside the cone slips (the direction its force fails)
            failing = [(c, lt) for c, (margin, lt) in cs.cone_margins(problem, lam).items() if margin < 0.0]
            if failing:
                for c, lam_t in failing:
                    for m in cs.groups[c]:
                        del cs.stick[m]
                        cs.slip[m] = math.copysign(1.0, lam_t)
                cs.regroup(state.t, state.q)
                return state
        h = self.integ.step_size(cs.in_contact) * 0.5 ** cs.halvings
        cs.step = 0.0 if self.integ.adaptive else h  # an adaptive step resolves what it must itself
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
        trial = ContactState(cs.constraint, cs.continuous, cs.armed, cs.last_impact_t, cs.last_release_t,
                             cs.approach_speed, rest, base=cs.base, mu=cs.mu,
                             stick={c: a for c, a in cs.stick.items() if c in rest},
                             slip={c: s for c, s in cs.slip.items() if c in rest})
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
                           float(self.t_out[self.out_i]), self.t_end, cs.near_h, near)

    def _advance(self, watch: Watch | None) -> Advance:
        """One call of the integrator; adopt its quiet steps' bookkeeping and the contact
        episodes it resolved itself."""
        cs = self.contacts
        recording = watch is not None and getattr(self.integ, "records_outputs", False)
        try:
            adv = self.integ.advance(self.t_end, watch, **({"outputs": self.t_out[self.out_i:]} if recording else {}))
        except StepFailure as exc:  # the rows of the quiet steps before the failing one are kept
            self._rows(getattr(exc, "outputs", ()), self._current)
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

    # -- bookkeeping -------------------------------------------------------------------
    def _power(self, s: State) -> dict[str, float]:
        return self._power_terms(s.t, s.q, s.v)

    def _power_terms(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        """The model's own non-conservative powers, and the continuous contact dissipation
        while a contact penetrates."""
        out = self.system.power(t, q, v)
        if self._continuous_contacts and self.contacts.penetrating:
            out = {**out, "contact": self._current.contact_power(q, v)}
        if self._current.slips:
            out = {**out, "friction": self._current.slip_power(t, q, v)}
        return out

    def _booked_friction(self, problem: Problem, adv: Advance, powers0: dict) -> dict:
        """After a compiled call in a slipping phase: the slip friction's work at the start of
        its last step and the power there, as the loop booked them over its quiet steps
        (:func:`daebench.core.coulomb.book_step`); the driver books the last step itself."""
        book = problem.kernel.friction.book
        if adv.steps > 1 and int(book[4]) != adv.steps:
            raise StepFailure(f"{type(self.integ).__name__} took {adv.steps} steps in one call of a slipping "
                              f"phase without booking their friction work (daebench.core.coulomb.book_step)")
        self.work["friction"] = float(book[0])
        return {**powers0, "friction": float(book[1])}

    def _output_work(self, problem: Problem, k: int) -> list[dict[str, float]]:
        """The work booked at each of the first ``k`` output rows a compiled call wrote: the
        slip friction's from the loop (:func:`daebench.core.coulomb.book_rows`), the rest unchanged."""
        if not problem.slips:
            return [dict(self.work) for _ in range(k)]
        rows = problem.kernel.friction.row_work
        return [{**self.work, "friction": float(rows[i])} for i in range(k)]

    def _accumulate_work(self, prev: State, end: State, p0: dict, p1: dict, problem: Problem) -> None:
        dt = end.t - prev.t
        base = dict(self.work)
        cw = self._contact_work
        if cw is not None and dt > 0.0:
            # the contact work of an integrator that resolves contacts itself, W(prev.t) and
            # W(new.t) [, power at prev.t]: as end "powers" whose trapezoid gives W(new.t)
            # exactly, interpolated at output times as the quadratic through W(prev.t) with
            # that power (or linearly)
            base["contact"] = cw[0]
            mean = (cw[1] - cw[0]) / dt
            r0 = cw[2] if len(cw) > 2 else mean
            p0, p1 = {**p0, "contact": r0}, {**p1, "contact": 2.0 * mean - r0}
        for k in set(p0) | set(p1):
            self.work[k] = base.get(k, 0.0) + 0.5 * dt * (p0.get(k, 0.0) + p1.get(k, 0.0))
        self._record_until(prev, end, problem, dt, base, p0, p1)

    def _record_until(self, prev: State, end: State, problem: Problem, dt: float,
                      base: dict | None = None, p0: dict | None = None, p1: dict | None = None) -> None:
        """Write history rows for the output times in (prev.t, end.t] (t = 0 included once)."""
        while self.out_i < len(self.t_out) and _output_due(self.t_out[self.out_i], end.t, self.t_end):
            to = float(self.t_out[self.out_i])
            src = _source(to, prev.t, end.t)
            s = end if src == _dense.END else prev if src == _dense.START else self.integ.dense(to)
            if base is None:
                work = dict(self.work)
            else:
                th = 0.0 if dt == 0.0 else (to - prev.t) / dt
                work = dict(base)
                for k in set(p0) | set(p1):
                    pk = p0.get(k, 0.0) + th * (p1.get(k, 0.0) - p0.get(k, 0.0))
                    work[k] = base.get(k, 0.0) + 0.5 * (to - prev.t) * (p0.get(k, 0.0) + pk)
            self._row(to, s, work, problem)

    def _rows(self, outputs: list[tuple[float, State]], problem: Problem) -> None:
        """:meth:`_row` of (output time, state) pairs, the work unchanged between them; the
        model's ``output_rows`` (:class:`~daebench.core.system.MechanicalSystem`), if any, in one call."""
        batch = getattr(self.system, "output_rows", None)
        works = self._output_work(problem, len(outputs))   # (the rows of a slipping phase: closed contacts)
        if batch is None or len(outputs) < 2:
            for (to, s), work in zip(outputs, works):
                self._row(to, s, work, problem)
            return
        t = np.array([to for to, _ in outputs])
        obs, terms = batch(t, np.array([s.q for _, s in outputs]), np.array([s.v for _, s in outputs]))
        cs, sys_ = self.contacts, self.system
        if cs.continuous or (problem.m and cs.active):  # per-row contact forces or constraint residuals
            obs_cols, term_cols = ({k: c.tolist() for k, c in d.items()} for d in (obs, terms))
            for i, (to, s) in enumerate(outputs):
                self._row(to, s, works[i], problem, {k: c[i] for k, c in obs_cols.items()},
                          {k: c[i] for k, c in term_cols.items()})
            return
        # a stretch without events: the rows as one block of columns (driver.history)
        b = block(t, obs, terms, self.work, self.E0, cs.d_impacts, self.observables, self._n_active())
        bad, _ = divergence(b["E"], b["energy_residual"], self.work, self.E0, self.energy_scale, cs.d_impacts)
        bad = np.broadcast_to(bad, (len(outputs),))
        if self._length_scale is not None:
            bad = bad | penetration(np.array([sys_.gap(s.q) for _, s in outputs]), self._length_scale)[0]
        k = int(np.argmax(bad)) if bad.any() else len(outputs)
        if k:
            self.rows.append(b.head(k) if k < len(outputs) else b)
            if self.record_states:
                self._states.extend(state_row(to, s, sys_.n, sys_.n_bilateral) for to, s in outputs[:k])
            self.out_i += k
        if k < len(outputs):  # the first diverging row ends the run as the row path ends it
            to, s = outputs[k]
            self._row(to, s, dict(self.work), problem, {c: v[k] for c, v in obs.items()},
                      {c: v[k] for c, v in terms.items()})

    def _row(self, to: float, s: State, work: dict[str, float], problem: Problem,
             obs: dict[str, float] | None = None, terms: dict[str, float] | None = None) -> None:
        """Write the history row of output time ``to`` from the state ``s`` there and the
        work booked until then (``obs``, ``terms``: the model's observables and energy
        terms there, when already computed); the next output time is the following one."""
        sys_, cs = self.system, self.contacts
        obs = sys_.observables(to, s.q, s.v) if obs is None else obs
        terms = sys_.energy(s.q, s.v) if terms is None else terms
        row = columns(to, obs, {k: float(x) for k, x in terms.items()}, work, self.E0, cs.d_impacts,
                      self.observables, self._n_active())
        self._check_divergence(to, s, row["E"], row["energy_residual"], work)
        if cs.continuous:
            F = problem.contact_forces(s.q, s.v)
            for i in range(sys_.n_contacts):
                row[f"contact_force_{i}"] = float(F[i])
        if problem.m and cs.active:
            C, Cd, Cdd = problem.constraint_residuals(s.t, s.q, s.v, s.a)
            row.update({"C": C, "Cdot": Cd, "Cddot": Cdd})
            k = problem.n_bilateral
            for j, c in enumerate(cs.active):
                row[f"lambda_{c}"] = float(s.lam[k + j]) if s.lam.size > k + j else math.nan
        self.rows.append(row)
        if self.record_states:
            self._states.append(state_row(to, s, sys_.n, sys_.n_bilateral))
        self.out_i += 1

    def _track_constraints(self, s: State, problem: Problem) -> None:
        if problem.m == 0:
            return
        C, Cd, Cdd = problem.constraint_residuals(s.t, s.q, s.v, s.a)
        self.cmax["C"] = max(self.cmax["C"], C)
        self.cmax["Cdot"] = max(self.cmax["Cdot"], Cd)
        if np.isfinite(Cdd):
            self.cmax["Cddot"] = max(self.cmax["Cddot"], Cdd)

    def _check_finite(self, s: State) -> None:
        # one sum per array: NaN and ±inf propagate (and a sum overflowing 1e308 has diverged
        # anyway); a quarter of np.all(np.isfinite(...))'s cost, paid on every step
        if not math.isfinite(float(s.q.sum()) + float(s.v.sum())):
            raise _Diverged(f"t = {s.t:.6g} s: the state became non-finite")

    def _n_active(self) -> int | None:
        """The history's n_active: contacts in force (closed or penetrating), when watched."""
        cs = self.contacts
        return len(cs.active) + len(cs.penetrating) if cs.watched else None

    def _check_divergence(self, t: float, s: State, E: float, resid: float, work: dict) -> None:
        """The one divergence rule (:func:`daebench.driver.history.divergence`), and for a
        capturing step the penetration rule (:func:`daebench.driver.history.penetration`), at
        each output time (where the energy is computed anyway). Its scales are fixed by the start and the
        booked work — never by the current energy, which grows with a blow-up. A diverged row
        ends the run there (also one of a batch of rows the integrator's loop wrote beyond it)."""
        bad, why = divergence(E, resid, work, self.E0, self.energy_scale, self.contacts.d_impacts)
        if not bad.any() and self._length_scale is not None:
            bad, why = penetration(self.system.gap(s.q), self._length_scale)
        if bad.any():
            self._t_last, self._last_state = max(self._t_last, t), s
            raise _Diverged(f"t = {t:.6g} s: {why}")


def simulate(system: MechanicalSystem, integrator: Integrator, t_end: float, output_dt: float,
             observables: list[str] | None = None,
             progress: Callable[[float], None] | None = None, record_states: bool = False) -> RunResult:
    """Run ``integrator`` on ``system`` over [0, t_end] with events; see :class:`Driver`.

    ``progress(t)`` is called with the simulated time reached, at most every
    ``PROGRESS_EVERY`` seconds of wall time (for progress bars). With ``record_states``
    the result's ``states`` holds the integrator's own (t, q, v, a, λ_bilateral) at every
    output time, as arrays."""
    return Driver(system, integrator, t_end, output_dt, observables, progress, record_states).run()
