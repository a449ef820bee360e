"""Events of the event-driven driver (:mod:`daebench.driver.simulate`): where in a step a gap
closes, a contact force turns tensile or a penetrating contact separates — located on the
integrator's dense output by Brent's method — and what each does to the state: the Newton
impact map with restitution for the ``constraint`` law (closing the contact when the
rebound is too slow to resolve), the start and end of a continuous-law episode, and the
projection back onto the constraints of the phase that ends.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from daebench.core.contact import Impact, impact_map
from daebench.core.problem import Problem
from daebench.stepping.watch import GAP_BAND, gap_event
from daebench.core.system import State

EVENT_TOL = 1e-13        # event times located to this (seconds)
REBOUND_MIN = 1e-9       # a rebound slower than this (m/s) is treated as plastic (ends Zeno chatter)
REIMPACT_MIN_DT = 1e-10  # a second impact of a contact within this time closes it (Zeno)
PROJECTION_ITERS = 3     # Newton iterations of the position projection onto C(q) = 0


class EventLogic:
    """The event methods of :class:`daebench.driver.simulate.Driver`; they read and update the
    driver's contact bookkeeping (active, armed, penetrating, impacts, hold, work)."""

    def _find_event(self, prev: State, new: State, problem: Problem):
        """Earliest event in (prev.t, new.t]: (t, kind, contact) or None."""
        sys_ = self.system
        cands = []
        if self.constraint_contacts or self.continuous_contacts:
            # the previous step's new state is usually this step's prev: reuse its gaps
            gc = self._gap_cache
            g0 = gc[2] if gc is not None and gc[0] is prev.q and gc[1] == prev.t else sys_.gap(prev.q)
            g1 = sys_.gap(new.q)
            self._gap_cache = (new.q, new.t, g1)
            for i in range(sys_.n_contacts):
                if i in self.active:
                    continue
                if self.continuous_contacts and i in self.penetrating:
                    if g1[i] > 0.0:
                        cands.append((self._root(lambda t: sys_.gap(self.integ.dense(t).q)[i], prev, new),
                                      "separate", i))
                    continue
                closes, arms = gap_event(g1[i], self.armed[i])
                off = 0.0 if self.armed[i] else GAP_BAND
                if closes and g0[i] >= -off:
                    # the band decides whether the contact closed; where is g = 0 when the
                    # step started on or above the plane
                    at = 0.0 if g0[i] >= 0.0 else off
                    cands.append((self._root(lambda t: sys_.gap(self.integ.dense(t).q)[i] + at, prev, new),
                                  "close", i))
                elif closes:
                    # the step started already (numerically) closed — e.g. a grazing re-contact
                    # right after a separation: contact at its start
                    cands.append((prev.t, "close", i))
                elif arms:
                    self.armed[i] = True
        if self.constraint_contacts and self.active:
            k = sys_.n_bilateral
            for j, c in enumerate(self.active):
                if new.lam[k + j] < 0.0 <= prev.lam[k + j]:
                    cands.append((self._root(lambda t: self.integ.dense(t).lam[k + j], prev, new),
                                  "open", c))
                elif new.lam[k + j] < 0.0 and c in self.hold:
                    cands.append((new.t, "open", c))  # still tensile after the held step
            self.hold.clear()
        return min(cands, key=lambda c: c[0]) if cands else None

    def _root(self, f, prev: State, new: State) -> float:
        fa, fb = f(prev.t), f(new.t)
        if fa == 0.0:
            return prev.t
        if np.sign(fa) == np.sign(fb):
            # the dense output disagrees with the step endpoints in sign: take the step end
            return new.t
        return brentq(f, prev.t, new.t, xtol=EVENT_TOL, rtol=4 * np.finfo(float).eps)

    def _apply_event(self, event, state: State, problem: Problem) -> State:
        t, kind, i = event
        sys_ = self.system
        # the event state comes from the dense output: put it back on the constraints of
        # the phase it ends (closed contacts: g = 0, ġ = 0) before switching
        q, v = project(problem, t, state.q, state.v)
        if kind == "close" and self.constraint_contacts:
            M = sys_.mass(q)
            Gq = sys_.gap_jacobian(q)
            bil = [sys_.constraint_jacobian(t, q).reshape(-1, sys_.n)]
            bil += [Gq[[c]] for c in self.active]
            e = sys_.contact_law.restitution
            # a re-impact within REIMPACT_MIN_DT (Zeno chatter) or a contact found already
            # penetrating with a separating velocity closes plastically
            zeno = t - self.last_impact_t[i] < REIMPACT_MIN_DT or float(Gq[i] @ v) >= 0.0
            res = impact_map(M, Gq[[i]], v, 0.0 if zeno else e, np.vstack(bil))
            closed = zeno or e == 0.0 or res.vn_plus[0] < REBOUND_MIN
            if closed and not (zeno or e == 0.0):
                res = impact_map(M, Gq[[i]], v, 0.0, np.vstack(bil))
            self.last_impact_t[i] = t
            self.d_impacts += res.energy_loss
            self.impacts.append(Impact(t, i, float(res.vn_minus[0]), float(res.vn_plus[0]), res.energy_loss,
                                       closed, float(res.impulse[0]), q=q.copy(), v_minus=v.copy(),
                                       v_plus=res.v_plus.copy()))
            v = res.v_plus
            if closed:
                self.active.append(i)
                if t - self.last_release_t[i] <= self.h:
                    self.hold.add(i)
                # the impact was located on g = 0 (or −GAP_BAND): start the closed phase on it
                q, v = project(self._problem(), t, q, v)
            self.armed[i] = False
        elif kind == "open":
            self.active.remove(i)
            self.armed[i] = False
            self.last_release_t[i] = t
            for imp in reversed(self.impacts):  # the closed episode of contact i ends here
                if imp.contact == i:
                    if imp.closed and math.isnan(imp.t_end):
                        imp.t_end = t
                    break
        elif kind == "close":  # continuous law: first touch
            vn = float(sys_.gap_jacobian(q)[i] @ v)
            self.approach_speed[i] = max(-vn, 1e-12)
            self.penetrating.add(i)
            self.episode_start_W[i] = self.work.get("contact", 0.0)
            self.impacts.append(Impact(t, i, vn, math.nan, math.nan))
        elif kind == "separate":
            self.penetrating.discard(i)
            self.armed[i] = False  # a release like any other: re-closing goes by the band rule
            vn = float(sys_.gap_jacobian(q)[i] @ v)
            for imp in reversed(self.impacts):
                if imp.contact == i and math.isnan(imp.vn_plus):
                    imp.vn_plus = vn
                    imp.energy_loss = self.episode_start_W.pop(i, math.nan) - self.work.get("contact", 0.0)
                    imp.t_end = t
                    break
        return State(t, q, v)


def project(problem: Problem, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mass-weighted projection of (q, v) onto C(t, q) = 0 and C_q v + C_t = 0 of the
    problem's active constraints (no-op when none are active)."""
    if problem.m == 0:
        return q, v
    M = problem.mass(q)
    q = q.copy()
    for _ in range(PROJECTION_ITERS):
        C = problem.constraint(t, q)
        if np.max(np.abs(C)) < 1e-15:
            break
        Cq = problem.constraint_jacobian(t, q)
        MiCt = np.linalg.solve(M, Cq.T)
        q -= MiCt @ np.linalg.solve(Cq @ MiCt, C)
    Cq = problem.constraint_jacobian(t, q)
    MiCt = np.linalg.solve(M, Cq.T)
    v = v - MiCt @ np.linalg.solve(Cq @ MiCt, Cq @ v + problem.constraint_t(t, q))
    return q, v
