"""Velocity Verlet on the acceleration-level (index-1) equations: a one-file plugin.

Order 2, explicit, symplectic for unconstrained conservative systems with
velocity-independent forces; constraints are enforced at acceleration level only,
so position and velocity drift (no stabilization). For testing the plugin path.
"""

from daebench.core.system import State
from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator
from daebench.stepping.control import land


class Verlet(Integrator):
    name = "verlet"
    description = "velocity Verlet, acceleration-level constraints (test plugin)"
    capabilities = Capabilities(order=2, fixed_step=True, constraints=True, index=1)
    settings_spec = STEP_SETTINGS

    def _start(self) -> None:
        pass

    def _step_impl(self, t_stop: float) -> State:
        s, p = self.state, self.problem
        h, t1 = land(s.t, t_stop, self.h)   # the step, stretched to end exactly on t_stop when near it
        q = s.q + h * s.v + 0.5 * h * h * s.a
        v_pred = s.v + h * s.a
        a1, lam1 = p.acceleration(t1, q, v_pred)
        v = s.v + 0.5 * h * (s.a + a1)
        return State(t1, q, v, a1, lam1)


class ShadowHHT(Verlet):
    """Registered under a built-in's name on purpose: daebench refuses it (tests)."""

    name = "hht"
