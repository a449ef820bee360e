"""The event-driven driver's books: the history rows at the output times, the work of the
non-conservative effects, the constraint residuals and the divergence rule
(:class:`Books`, which :class:`daebench.driver.simulate.Driver` is).

Reads the driver's system, integrator, contacts (:class:`daebench.driver.contact_state.ContactState`),
output times and energy scale; writes ``rows``, ``work``, ``cmax``, ``out_i`` and ``inside``
(the output times a step's dense output served from strictly inside it; the integrator's own
states with ``record_states``). A diverged row ends the run (:class:`Diverged`).
"""

from __future__ import annotations

import math

import numpy as np

from daebench.core.problem import Problem
from daebench.core.system import State
from daebench.driver.history import block, columns, divergence, penetration, state_row
from daebench.integrators.base import Advance, StepFailure
from daebench.stepping import dense as _dense, watch as _watch

# the compiled loops' own rules (which output times are due, which state serves one), called
# here as plain Python: one source, no dispatch per call
_output_due, _source = (getattr(f, "py_func", f) for f in (_watch.output_due, _dense.source))


#: an output time farther than this fraction of its step from both of the step's ends is
#: served by the dense output (``Books.inside``); nearer, it is the step's end to rounding
INSIDE_REL = 1e-6


class Diverged(Exception):
    pass


class Books:
    """The driver's bookkeeping methods (module docstring)."""

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

    def _output_work(self, problem: Problem, k: int) -> dict[str, float | np.ndarray]:
        """The work booked at each of the first ``k`` output rows a compiled call wrote, by
        effect (a value for all rows, or one per row): the slip friction's from the loop
        (:func:`daebench.core.coulomb.book_rows`), the rest unchanged."""
        if not problem.slips:
            return dict(self.work)
        return {**self.work, "friction": np.array(problem.kernel.friction.row_work[:k], dtype=float)}

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
        """Write history rows for the output times in (prev.t, end.t] (t = 0 included once):
        the states there (a step's ends, else its dense output) and the work booked until
        then (the trapezoid of the powers ``p0``, ``p1`` from ``base``, the power linear over
        the step), all rows of the step at once (:meth:`_rows`)."""
        i, n_out = self.out_i, len(self.t_out)
        while i < n_out and _output_due(self.t_out[i], end.t, self.t_end):
            i += 1
        times = self.t_out[self.out_i:i].tolist()
        if not times:
            return
        src = [_source(to, prev.t, end.t) for to in times]
        inner = [to for to, k in zip(times, src) if k == _dense.INSIDE]
        dense = iter(self.integ.dense_many(inner) if inner else ())
        outputs = [(to, end if k == _dense.END else prev if k == _dense.START else next(dense))
                   for to, k in zip(times, src)]
        # (an output time a rounding away from a step's end is that end)
        self.inside += [to for to in inner if min(to - prev.t, end.t - to) > INSIDE_REL * dt]
        if base is None:
            work: dict[str, float | np.ndarray] = dict(self.work)
        else:
            # each row's work as the scalar rule would give it, elementwise (the same operations)
            el = np.array([to for to, _ in outputs]) - prev.t
            th = np.zeros(len(outputs)) if dt == 0.0 else el / dt
            work = dict(base)
            for k in set(p0) | set(p1):
                a, b = p0.get(k, 0.0), p1.get(k, 0.0)
                work[k] = base.get(k, 0.0) + 0.5 * el * (a + (a + th * (b - a)))
        self._rows(outputs, problem, work)

    def _rows(self, outputs: list[tuple[float, State]], problem: Problem,
              work: dict[str, float | np.ndarray] | None = None) -> None:
        """The history rows of (output time, state) pairs with the work booked at each (by
        effect: one value, or one per row; default: what a compiled call booked,
        :meth:`_output_work`): one block of columns (:func:`daebench.driver.history.block`;
        the model's ``output_rows`` of :class:`~daebench.core.system.MechanicalSystem` if it
        has them, its ``observables``/``energy`` per row otherwise) — by :meth:`_row` one at a
        time for a single row and where closed constraints add their residuals per row. The
        first diverging row ends the run as :meth:`_row` ends it."""
        if not outputs:
            return
        work = self._output_work(problem, len(outputs)) if work is None else work
        cs, sys_ = self.contacts, self.system
        cols = None
        if len(outputs) > 1 and not (problem.m and cs.active):   # (constraint residuals: per row)
            t = np.array([to for to, _ in outputs])
            Q, V = np.array([s.q for _, s in outputs]), np.array([s.v for _, s in outputs])
            batch = getattr(sys_, "output_rows", None)
            cols = batch(t, Q, V) if batch is not None else _model_rows(sys_, outputs)
        if cols is None:   # one row, constraint residuals per row, or names that differ between rows
            for i, (to, s) in enumerate(outputs):
                self._row(to, s, _work_row(work, i), problem)
            return
        obs, terms = cols
        b = block(t, obs, terms, work, self.E0, cs.d_impacts, self.observables, self._n_active())
        if cs.continuous:
            F = problem.contact_forces_rows(Q, V)
            for c in range(sys_.n_contacts):
                b[f"contact_force_{c}"] = F[:, c]
        bad, _ = divergence(b["E"], b["energy_residual"], work, self.E0, self.energy_scale, cs.d_impacts)
        bad = np.broadcast_to(bad, (len(outputs),))
        if self._length_scale is not None:
            bad = bad | penetration(sys_.gap_rows_of(Q), self._length_scale)[0]
        k = int(np.argmax(bad)) if bad.any() else len(outputs)
        if k:
            self.rows.append(b.head(k) if k < len(outputs) else b)
            if self.record_states:
                self._states.extend(state_row(to, s, sys_.n, sys_.n_bilateral) for to, s in outputs[:k])
            self.out_i += k
        if k < len(outputs):
            to, s = outputs[k]
            self._row(to, s, _work_row(work, k), problem, {c: v[k] for c, v in obs.items()},
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
            raise Diverged(f"t = {s.t:.6g} s: the state became non-finite")

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
            raise Diverged(f"t = {t:.6g} s: {why}")


def _work_row(work: dict[str, float | np.ndarray], i: int) -> dict[str, float]:
    """Row ``i`` of work given by effect (one value for all rows, or one per row)."""
    return {k: (float(w[i]) if isinstance(w, np.ndarray) else w) for k, w in work.items()}


def _model_rows(system, outputs: list[tuple[float, State]]) -> tuple[dict, dict] | None:
    """(observables, energy terms) as columns from the model's per-row methods; None when
    the rows do not all have the same names."""
    obs = [system.observables(to, s.q, s.v) for to, s in outputs]
    terms = [system.energy(s.q, s.v) for _, s in outputs]
    if any(o.keys() != obs[0].keys() for o in obs) or any(e.keys() != terms[0].keys() for e in terms):
        return None
    return ({k: np.array([o[k] for o in obs]) for k in obs[0]},
            {k: np.array([float(e[k]) for e in terms]) for k in terms[0]})
