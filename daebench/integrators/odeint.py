"""A second method family for references: an explicit Runge–Kutta code (scipy's DOP853,
order 8, Dormand–Prince) or Radau IIA (order 5) on the index-1 ODE of the model.

Formulation: y = (q, q̇), ẏ = (q̇, q̈(t, q, q̇)), q̈ and λ from the augmented system
[[M, C_qᵀ], [C_q, 0]] [q̈; λ] = [Q; γ] of the current phase (no stabilization, no
projection: C and C_q q̇ + C_t drift only by the integration error — fine for the short,
smooth runs of the IVP test-set models that declare this solver, checked per run by the
driver's constraint maxima). Not registered as a public integrator: the reference module
uses it for models that declare ``reference_solver = "dop853"`` (or ``"radau"``).

Error weights follow each component's scale, as the IVP test set's drivers set them:
atol_i = rtol × s_i with s = the model's ``state_scale()`` (q scales, q̇ scales), or the
uniform ``atol`` when the model declares none. Why not IDA for those models: on the slider
crank IDA (BDF, GGL index-2 form) at rtol 1e-11 gives 5.8–6.3 digits in the elastic
coordinates q3, q4 (≈ 1e-5 m) with these weights (atol_i = 10 or 100 × rtol × s_i; at
1 × it fails at t = 0 with repeated corrector failures), in 200 s; DOP853 at the same
rtol gives ≥ 9.3 digits in every position in 25 s (daebench.studies.ivptest).

Dense output: scipy's continuous extension of the last step (order 7 for DOP853).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import DOP853, Radau

from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator, Setting, StepFailure
from daebench.core.system import State

SOLVERS = {"dop853": DOP853, "radau": Radau}


class IndexOneODE(Integrator):
    """scipy's DOP853 or Radau IIA on the index-1 ODE (module docstring).

    Parameters
    ----------
    rtol, atol : float
        Tolerances; with ``scaled`` the absolute tolerance of component i is
        rtol × s_i (s: the model's ``state_scale()``), else ``atol``.
    method : {"dop853", "radau"}
    scaled : bool
        Per-component absolute tolerances from the model's declared scales.
    """

    name = "ode-index1"
    description = "scipy DOP853 / Radau IIA on the index-1 ODE (reference solver of smooth IVP test-set models)"
    capabilities = Capabilities(order=8, fixed_step=False, adaptive=True, constraints=True,
                                index=1, dense_output=True)
    settings_spec = STEP_SETTINGS + (
        Setting("adaptive", bool, True, "always true"),
        Setting("rtol", float, 1e-11, "relative tolerance", low=1e-14, high=1e-2),
        Setting("atol", float, 1e-13, "absolute tolerance (without scales)", low=1e-20, high=1.0),
        Setting("method", str, "dop853", "scipy solver", choices=tuple(SOLVERS)),
        Setting("scaled", bool, True, "atol_i = rtol × the model's declared scale of component i"),
    )

    def _start(self) -> None:
        self._solver = None
        self._dense = None
        self._bound = math.nan
        st = self.state
        st.a, st.lam = self.problem.acceleration(st.t, st.q, st.v)

    def tolerances(self) -> np.ndarray:
        """The absolute tolerance of each component of y = (q, q̇)."""
        n = self.problem.n
        scale = getattr(self.problem.system, "state_scale", None)
        if self.settings["scaled"] and scale is not None:
            qs, vs = scale()
            return self.settings["rtol"] * np.concatenate([np.asarray(qs, float), np.asarray(vs, float)])
        return np.full(2 * n, self.settings["atol"])

    def _rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        n = self.problem.n
        a, _ = self.problem.acceleration(t, y[:n], y[n:])
        return np.concatenate([y[n:], a])

    def _state(self, t: float, y: np.ndarray) -> State:
        n = self.problem.n
        q, v = y[:n].copy(), y[n:].copy()
        a, lam = self.problem.acceleration(t, q, v)
        return State(float(t), q, v, a, lam)

    def _step_impl(self, t_stop: float) -> State:
        st = self.state
        if self._solver is None or t_stop != self._bound:
            y0 = np.concatenate([st.q, st.v])
            cls = SOLVERS[self.settings["method"]]
            self._solver = cls(self._rhs, float(st.t), y0, float(t_stop), rtol=self.settings["rtol"],
                               atol=self.tolerances())
            self._bound = t_stop
        s = self._solver
        msg = s.step()
        if s.status == "failed" or msg is not None:
            raise StepFailure(f"{self.settings['method']} at t = {st.t:.9g}: {msg}")
        y = np.asarray(s.y, float)
        if not math.isfinite(float(y.sum())):
            raise StepFailure(f"{self.settings['method']} produced non-finite values at t = {s.t:.9g}")
        self._dense = s.dense_output()
        return self._state(s.t, y)

    def dense(self, t: float) -> State:
        """State at t within the last step from the solver's continuous extension."""
        s0, s1 = self.prev, self.state
        if s0 is None or self._dense is None or t >= s1.t:
            return s1.copy()
        return self._state(float(t), np.asarray(self._dense(float(t)), float))
