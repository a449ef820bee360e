r"""The source's own complementarity scheme: a force-level LCP on the time-averaged gap
inside every right-hand side of an adaptive Dormand–Prince 5(4).

Method (seed 003, eqs. 4–22; docs/sources.md §F)
-----------------------------------------
The gap is expanded to second order over the window [t, t + h] that *starts* at the
current time and averaged over it:

    ḡ = (1/h) ∫_t^{t+h} g dξ = g + (h/2) ġ + (h²/6) g̈,

and the Signorini condition is imposed on the average, 0 ≤ ḡ ⟂ f ≥ 0. With independent
coordinates M q̈ = F + K_f f (K_f = g_qᵀ, one column per contact) and g̈ = g_q q̈ − γ_g
(γ_g = −K̇_fᵀq̇ the gap kernel's curvature term), this is the standard LCP

    ḡ = A f + b,   A = (h²/6) K_fᵀ M⁻¹ K_f,
    b = g + (h/2) ġ + (h²/6)(K_fᵀ M⁻¹ F − γ_g),        0 ≤ ḡ ⟂ f ≥ 0,

solved for the contact forces f at every evaluation of q̈ = M⁻¹(F + K_f f). The ODE
y = (q, v), ẏ = (v, q̈) is integrated by Dormand–Prince 5(4) (FSAL, 7 stages, 6 new
right-hand sides per step) with its embedded error estimate and the project's step
controller (:mod:`daebench.stepping.control`, exponent 1/5 for the 4th-order estimate) —
the method of MATLAB's ode45, which the source used (RelTol 1e-4, AbsTol 1e-6: the
defaults here). ``h_avg`` (the window h) is a physical setting of the contact model,
not the Runge–Kutta step.

LCP solver. The source solves the LCP "through its equivalent nonlinear equations" and
names no NCP function. Here it is solved exactly by Murty's least-index principal
pivoting (:func:`daebench.core.lcp.solve_lcp`, shared with the event-capturing
steppers; one contact in closed form, f = max(0, −b/A)): A is
symmetric positive definite for independent contact Jacobians, so the solution is unique
and any exact method — a semismooth Newton on min(ḡ, f) = 0 or on Fischer–Burmeister
included, at convergence — gives the same f. With one contact (or decoupled contacts: a
lumped mass and node-to-foundation gaps make A diagonal) the first pivot is the answer.

Closed form for one contact (the unit tests)
--------------------------------------------
One contact with effective mass m = (K_fᵀM⁻¹K_f)⁻¹ and free gap acceleration g̈_free:
f = m · max(0, −(6/h²)(g + (h/2)ġ) − g̈_free). While f > 0 the gap obeys

    g̈ + (3/h) ġ + (6/h²) g = 0 :   ω_n = √6 / h,  ζ = (3/h) / (2 ω_n) = √6/4 ≈ 0.612,

a unilateral spring–dashpot k = 6m/h², c = 3m/h whose damping ratio does not depend on
h. A rigid mass approaching rigid ground at speed v₀ (g̈_free = 0) feels the force from
g + (h/2)ġ = 0, i.e. **g = h v₀/2, h/2 before contact**. From there, with ω_d = ω_n√(1−ζ²)
= √15/(2h) and τ measured from the switch-on,

    g(τ) = e^{−ζω_nτ} [g₀ cos ω_dτ + ((ġ₀ + ζω_n g₀)/ω_d) sin ω_dτ],  g₀ = h v₀/2, ġ₀ = −v₀,

and the force f = −m(6/h²)(g + (h/2)ġ) returns to zero (the switch-off) after
**1.622 h**; its peak is **1.209 m v₀/h**, the deepest penetration **0.0726 v₀ h**, and the
mass leaves at ġ⁺ = 0.0877 v₀ (**e = 0.0877**): nearly plastic. (Numbers: the roots of
these expressions, computed in tests/integrators/test_lcp_avg.py and compared with the runs.)

Capabilities and output
-----------------------
Order 5 on contact-free motion; explicit, so conditionally stable (h ω_max ≲ 3.3 on the
imaginary axis) — the adaptive control keeps the step stable. It resolves the contacts
itself (``contacts=True``): systems whose contact law is ``complementarity`` and, per the
driver's rules, the ``constraint`` law (whose restitution it does not use: the scheme has
none — the rebound follows from the bodies and from h). ODE models only (no bilateral
constraints). Each contact episode (force > 0, start and end interpolated where b changes
sign between stages) is reported with its ġ⁻, ġ⁺, impulse, energy lost (−∫fġ dt, the
step's own quadrature) and smallest gap; the cumulative contact work goes to the driver's
energy balance as W_contact (``Advance.contact_work``). The force at any recorded state
is :func:`contact_forces` (the same compiled right-hand side).

References
----------
Zhang Xingang, Qi Zhaohui, Wang Gang, Guo Shudong, Wu Zhigang (seed 003): the
time-averaged-gap LCP (its equations, reconstructed where the printed forms were lost:
docs/sources.md §F).
J. R. Dormand, P. J. Prince, "A family of embedded Runge–Kutta formulae", J. Comput.
Appl. Math. 6 (1980) 19–26. L. F. Shampine, M. W. Reichelt, "The MATLAB ODE suite",
SIAM J. Sci. Comput. 18 (1997) 1–22 (ode45).
K. G. Murty, "Note on a Bard-type scheme for solving the complementarity problem",
Opsearch 11 (1974) 123–130. R. W. Cottle, J.-S. Pang, R. E. Stone, The Linear
Complementarity Problem, SIAM 2009, §4.2 (principal pivoting).
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from daebench.core.contact import Impact
from daebench.integrators.base import Advance, Capabilities, IntegratorError, Setting, STEP_SETTINGS
from daebench.integrators.compiled import MAX_STEPS_PER_CALL, CompiledIntegrator
from daebench.core.problem import Problem
from daebench.stepping import control, lcp_avg as _lcp_avg
from daebench.stepping.methods import N_COUNTERS


class LcpAvg(CompiledIntegrator):
    """Dormand–Prince 5(4) + the time-averaged-gap contact LCP in every right-hand side
    (see the module docstring).

    Settings
    --------
    h_avg : float
        The averaging window h of the gap [s]; the source recommends the order of the
        physical contact duration.
    adaptive, rtol, atol : error control (defaults: ode45 as the source ran it, 1e-4 / 1e-6).
    h : first step (adaptive) or the fixed step.
    """

    name: ClassVar[str] = "lcp-avg"
    description: ClassVar[str] = ("the source's scheme: contact LCP on the gap averaged over h_avg inside each "
                                  "right-hand side of adaptive Dormand–Prince 5(4)")
    capabilities: ClassVar[Capabilities] = Capabilities(order=5, fixed_step=True, adaptive=True,
                                                        constraints=False, contacts=True)
    contact_laws: ClassVar[tuple[str, ...]] = ("complementarity",)  # no restitution: its own law only
    settings_spec: ClassVar[tuple[Setting, ...]] = STEP_SETTINGS + (
        Setting("adaptive", bool, True, "choose the step from the embedded 4th-order error estimate"),
        Setting("rtol", float, 1e-4, "relative tolerance (adaptive; the source's ode45 RelTol)", low=1e-14, high=1.0),
        Setting("atol", float, 1e-6, "absolute tolerance (adaptive; the source's ode45 AbsTol)", low=1e-16, high=1.0),
        Setting("h_avg", float, 1e-3, "averaging window h of the gap, ḡ = g + (h/2)ġ + (h²/6)g̈ [s]",
                low=1e-12, high=10.0),
    )
    fail_messages = {k: v.replace("{lcp_pivots}", str(_lcp_avg.LCP_MAX_PIVOTS))
                     for k, v in _lcp_avg.FAIL_MESSAGES.items()}  # the message's braces are not settings

    def method(self) -> _lcp_avg.LcpAvgMethod:
        return _lcp_avg.LcpAvgMethod(float(self.settings["h_avg"]))

    def workspace(self, n: int, m: int) -> _lcp_avg.LcpAvgWork:
        nc = self.problem.n_contacts
        ws = _lcp_avg.workspace(n, nc, 3 * nc * MAX_STEPS_PER_CALL + nc)
        old = getattr(self, "_ws", None)
        if old is not None and old.ep.shape == ws.ep.shape:  # a restart: open episodes go on
            ws.ep[:] = old.ep
            ws.cw[:] = old.cw
        return ws

    def step_control(self) -> control.StepControl:
        """Error control for the 4th-order embedded estimate (exponent 1/5), as ode45."""
        if self.adaptive:
            return control.adaptive(self.h, self.settings["rtol"], self.settings["atol"], 4)
        return control.fixed(self.h)

    def _start(self) -> None:
        p = self.problem
        if p.n_contacts == 0:
            raise IntegratorError("integrator 'lcp-avg' resolves the contacts of the system itself, but this "
                                  "system has none; use `--set effects.contact=true` with "
                                  "`--set contact.law=complementarity`, or another integrator.")
        law = p.contact_law
        if law is not None and law.continuous:
            raise IntegratorError(f"integrator 'lcp-avg' resolves contacts itself; the system has the continuous "
                                  f"contact law '{law.name}', which would count the contact twice. Use "
                                  f"`--set contact.law=complementarity`.")
        if p.m:
            raise IntegratorError("integrator 'lcp-avg' integrates ODE models only (independent coordinates, "
                                  "no bilateral constraints)")
        super()._start()
        self._log_taken = 0

    # -- episodes ---------------------------------------------------------------------------
    def _run(self, t_stop: float, w, max_steps: int):
        try:
            return super()._run(t_stop, w, max_steps)
        finally:
            self._drain()

    def _drain(self) -> None:
        ws = self._ws
        k = int(ws.nlog[0])
        for row in ws.log[:min(k, ws.log.shape[0])]:
            self.report_contact(Impact(float(row[1]), int(row[0]), float(row[2]), float(row[3]), float(row[4]),
                                       impulse=float(row[5]), t_end=float(row[6]), min_gap=float(row[7])))
        ws.nlog[0] = 0

    def _flush_open(self) -> None:
        """Report episodes still open at the end of the run (t_end and ġ⁺ unknown: NaN)."""
        for i, ep in enumerate(self._ws.ep):
            if ep[0] != 0.0:
                self.report_contact(Impact(float(ep[1]), i, float(ep[2]), math.nan, -float(ep[4]),
                                           impulse=float(ep[3]), min_gap=float(ep[5])))
                ep[0] = 0.0

    def advance(self, t_stop: float, watch=None) -> Advance:
        adv = super().advance(t_stop, watch)
        if self.state.t >= t_stop:
            self._flush_open()
            adv.events.extend(self._take_events())
        adv.contact_work = (float(self._ws.cw[0]), float(self._ws.cw[1]), float(self._ws.cw[2]))
        return adv


def contact_forces(problem: Problem, h_avg: float, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The contact forces f the scheme applies at (t, q, v) with window ``h_avg`` (the same
    compiled right-hand side the integrator evaluates)."""
    n, nc = problem.n, problem.n_contacts
    ws = _lcp_avg.workspace(n, nc, 1)
    y = np.concatenate([np.asarray(q, float), np.asarray(v, float)])
    cnt = np.zeros(N_COUNTERS, dtype=np.int64)
    status = _lcp_avg.rhs(_lcp_avg.LcpAvgMethod(float(h_avg)), ws, problem.kernel, float(t), y, np.empty(2 * n), 0,
                         cnt)
    if status:
        raise RuntimeError(_lcp_avg.FAIL_MESSAGES.get(status, f"status {status}"))
    return ws.sf[0, :nc].copy()
