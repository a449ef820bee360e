"""Base of the event-capturing integrators (Moreau–Jean, nonsmooth generalized-α): compiled
steppers that resolve the contacts themselves and report contact episodes.

The driver leaves contacts to an integrator that declares ``capabilities.contacts``
(:func:`daebench.integrators.applicability.check_capabilities`): it watches no gap and applies no
impact map. :class:`CapturingIntegrator` adds to
:class:`~daebench.integrators.compiled.CompiledIntegrator`:

* the restitution e of the scene's ``constraint`` law (no law — ``complementarity`` —
  is e = 0, a plastic contact);
* after every compiled call, the episode log of the stepper
  (:mod:`daebench.stepping.episodes`) becomes :class:`daebench.core.contact.Impact` records,
  reported with :meth:`~daebench.integrators.base.Integrator.report_contact`, one per
  episode (consecutive steps with a positive impulse), in the driver's columns:
  ``t`` the start of the first step with a positive impulse, ``vn_minus`` ġ there,
  ``energy_loss`` the energy lost over that step (the impact step: the counterpart of
  the impact map's kinetic-energy loss; later steps of a persistent contact exchange no
  energy with an ideal constraint), ``v_minus``/``v_plus`` the velocities before and
  after it, ``impact_impulse`` the impulse of that step, ``impact_work`` the work of the
  contact impulses in it (below); completed when the episode
  ends with ``vn_plus`` (ġ after its last step),
  ``t_end``, ``impulse`` (the sum over its steps), ``min_gap`` (smallest gap at its step
  boundaries, < 0: penetration) and ``closed`` (it lasted more than one step). An
  episode still open at the end of the run keeps NaN in ``vn_plus`` and ``t_end``;
* the cumulative work of the contact impulses, Σ P (U⁻ + U⁺)/2 per step (the impact's
  energy change by Kelvin's theorem, U = g_q v before and after the step), handed to the
  driver in :class:`~daebench.integrators.base.Advance` (``contact_work``) and booked as
  ``W_contact``: the energy residual is then the scheme's own error (exactly zero for
  Moreau θ = ½ on linear systems), as the event-driven runs' is with the exact impact map;
* :meth:`dense`: the scheme's own interpolant — v linear, q quadratic with q(t_k) = q_k,
  q̇(t_k) = v_k, q(t_{k+1}) = q_{k+1}, or linear across a step with an impulse — never a
  curve through the wall (a linear gap stays ≥ the smaller of its step-end values).

Subclasses implement ``method()`` and ``capture_workspace(n, m, nc, steps_per_call)``.
"""

from __future__ import annotations

import math
from typing import Any

from daebench.stepping import episodes as _ep
from daebench.core.contact import Impact
from daebench.core.kernels import friction_coefficients
from daebench.integrators.applicability import friction_refusal
from daebench.integrators.base import STEP_SETTINGS, Advance, IntegratorError, Setting
from daebench.integrators.compiled import CompiledIntegrator
from daebench.core.system import State

STEPS_PER_CALL = 500   # a compiled call's step limit (bounds the episode log)

#: the step settings of an event-capturing integrator: h; h_contact accepted (the paper's
#: protocol passes it) but unused — no phase is "in contact" for the driver
CAPTURE_STEP_SETTINGS = (
    STEP_SETTINGS[0],
    Setting("h_contact", float, 0.0, "accepted for the paper's protocol and unused: contacts are resolved "
            "inside the steps of size h", low=0.0, high=1.0),
)


class CapturingIntegrator(CompiledIntegrator):
    """Compiled event-capturing integrator (see the module docstring)."""


    def __init__(self, **settings: Any) -> None:
        super().__init__(**settings)
        self._episodes: dict[int, Impact] = {}  # contact → its open episode

    # -- phase data ----------------------------------------------------------------------
    def restitution(self) -> float:
        """e of the scene's constraint law; 0 without a law (complementarity)."""
        law = self.problem.contact_law
        if law is None:
            return 0.0
        if law.continuous:
            raise IntegratorError(f"integrator '{self.name}' resolves contacts itself and cannot run with the "
                                  f"continuous contact law '{law.name}'; use `--set contact.law=constraint`.")
        return float(law.restitution)

    def workspace(self, n: int, m: int) -> Any:
        return self.capture_workspace(n, m, self.problem.n_contacts, STEPS_PER_CALL)

    def capture_workspace(self, n: int, m: int, nc: int, steps_per_call: int) -> Any:
        raise NotImplementedError

    def _start(self) -> None:
        p = self.problem
        if p.n_contacts == 0:
            raise IntegratorError(f"integrator '{self.name}' resolves contacts and needs a system with contact "
                                  f"points (`--set effects.contact=true`)")
        if p.m:
            raise IntegratorError(f"integrator '{self.name}' does not treat bilateral constraints (this system "
                                  f"has {p.m}); use hht, genalpha or ida")
        if not self.capabilities.friction and (friction_coefficients(p.kernel.model, p.n_contacts, self.state.q,
                                                                    self.state.v) > 0.0).any():
            raise IntegratorError(friction_refusal(self.name, "this system"))
        self._episodes = {}
        ws = getattr(self, "_ws", None)
        carried = float(ws.ep.work[1]) if ws is not None else 0.0  # the contact work goes on over restarts
        super()._start()
        self._ws.ep.work[:2] = carried

    # -- stepping: drain the episode log after each compiled call -----------------------------
    def _run(self, t_stop: float, w, max_steps: int) -> tuple[int, float, float]:
        try:
            return super()._run(t_stop, w, min(int(max_steps), STEPS_PER_CALL))
        finally:
            self._drain()

    def _drain(self) -> None:
        ep = self._ws.ep
        k = int(ep.nlog[0])
        n = self.problem.n
        energy = self.problem.energy
        for row, x in zip(ep.log[:k], ep.logx[:k]):
            i = int(row[_ep.L_CONTACT])
            q0, v0 = x[:n].copy(), x[n:2 * n].copy()
            if row[_ep.L_KIND] == _ep.START:
                q1, v1 = x[2 * n:3 * n].copy(), x[3 * n:].copy()
                imp = Impact(float(row[_ep.L_T]), i, float(row[_ep.L_GDOT]), math.nan,
                             energy(q0, v0) - energy(q1, v1), impulse=float(row[_ep.L_IMPULSE]),
                             min_gap=float(row[_ep.L_GMIN]), impact_impulse=float(row[_ep.L_IMPULSE]),
                             impact_work=float(row[_ep.L_WORK]), u_law=float(row[_ep.L_ULAW]), q=q0, v_minus=v0, v_plus=v1)
                self._episodes[i] = imp
                self.report_contact(imp)
            elif i in self._episodes:
                imp = self._episodes.pop(i)
                imp.vn_plus = float(row[_ep.L_GDOT])
                imp.t_end = float(row[_ep.L_T])
                imp.impulse = float(row[_ep.L_IMPULSE])
                imp.min_gap = float(row[_ep.L_GMIN])
                imp.closed = int(row[_ep.L_STEPS]) > 1
        ep.nlog[0] = 0
        for i, imp in self._episodes.items():  # still open: impulse and smallest gap so far
            o = ep.open[i]
            imp.impulse = float(o[_ep.O_IMPULSE])
            imp.min_gap = float(o[_ep.O_GMIN])
            imp.closed = o[_ep.O_STEPS] > 1

    def advance(self, t_stop: float, watch=None) -> Advance:
        """As the compiled base, with the cumulative work of the contact impulses at the last
        step's start and end (booked by the driver as ``W_contact``)."""
        adv = super().advance(t_stop, watch)
        w = self._ws.ep.work
        adv.contact_work = (float(w[0]), float(w[1]))
        return adv

    # -- output -------------------------------------------------------------------------------
    def dense(self, t: float) -> State:
        """v linear; q quadratic through q_k (slope v_k) and q_{k+1} — linear in a step with
        an impulse, where v_k says nothing about the motion after the impact (the quadratic
        would dip through the wall)."""
        s0, s1 = self.prev, self.state
        if s0 is None or s1.t <= s0.t:
            return s1.copy()
        h = s1.t - s0.t
        tau = float(t) - s0.t
        if self._ws.ep.step[:, _ep.S_IN].any():
            q = s0.q + (tau / h) * (s1.q - s0.q)
        else:
            q = s0.q + tau * s0.v + (tau * tau / (h * h)) * (s1.q - s0.q - h * s0.v)
        v = s0.v + (tau / h) * (s1.v - s0.v)
        return State(float(t), q, v, s1.a.copy(), s1.lam.copy())
