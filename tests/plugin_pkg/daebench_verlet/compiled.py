"""Velocity Verlet written against daebench's compiled interfaces: a one-file plugin that
runs at the built-ins' speed on every model.

The step (index-1 form, as :class:`daebench_verlet.Verlet`)::

    q₁ = q₀ + h v₀ + ½h² a₀,   ṽ = v₀ + h a₀,   (a₁, λ₁) from M(q₁) a₁ + C_qᵀλ₁ = Q(q₁, ṽ), C_q a₁ = γ,
    v₁ = v₀ + ½h (a₀ + a₁)

is a compiled stepper (``daebench.stepping.methods``: a data and a workspace NamedTuple and
three registered functions); the model is reached only through the phase
(``daebench.core.phase.solve_augmented`` calls the model's kernels), so the plugin imports no
model and runs compiled on hub–beam, pendulum, Andrews or any kernel model. Order 2,
explicit, fixed step.
"""

from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import phase
from daebench.integrators.base import STEP_SETTINGS, Capabilities
from daebench.integrators.compiled import CompiledIntegrator
from daebench.stepping import methods
from daebench.stepping.methods import C_LU, C_RES


class VerletMethod(NamedTuple):
    h: float


class VerletWork(NamedTuple):
    aug: phase.AugmentedWork
    vt: np.ndarray


@njit(cache=True)
def _start(meth, ws, ph, t, cur, cnt):
    return 0


@njit(cache=True)
def _step(meth, ws, ph, ctl, t, h, cur, new, cnt):
    n = cur.q.shape[0]
    for i in range(n):
        new.q[i] = cur.q[i] + h * cur.v[i] + 0.5 * h * h * cur.a[i]
        ws.vt[i] = cur.v[i] + h * cur.a[i]
    cnt[C_RES] += 1
    cnt[C_LU] += 1
    if phase.solve_augmented(ph, t + h, new.q, ws.vt, 0.0, 0.0, ws.aug, new.a, new.lam):
        return 1, 0.0
    for i in range(n):
        new.v[i] = cur.v[i] + 0.5 * h * (cur.a[i] + new.a[i])
    return 0, 0.0


@njit(cache=True)
def _accept(meth, ws, h, prev, cur):
    pass


methods.start.register(VerletMethod, _start)
methods.step.register(VerletMethod, _step)
methods.accept.register(VerletMethod, _accept)


class CompiledVerlet(CompiledIntegrator):
    name = "verlet-compiled"
    description = "velocity Verlet, acceleration-level constraints, compiled stepper (test plugin)"
    capabilities = Capabilities(order=2, fixed_step=True, constraints=True, index=1)
    settings_spec = STEP_SETTINGS
    fail_messages = {1: "singular augmented mass matrix"}

    def method(self) -> VerletMethod:
        return VerletMethod(float(self.h))

    def workspace(self, n: int, m: int) -> VerletWork:
        return VerletWork(phase.augmented_work(n, m), np.empty(n))
