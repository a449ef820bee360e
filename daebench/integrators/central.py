"""The ``central`` integrator: explicit central differences (velocity Verlet) for
lumped-mass models; the scheme, its order, stability bound and references are in
:mod:`daebench.stepping.central`."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from daebench.integrators.base import STEP_SETTINGS, Capabilities, IntegratorError, Setting
from daebench.integrators.compiled import CompiledIntegrator
from daebench.stepping.central import FAIL_MESSAGES, CentralMethod, CentralWork, workspace
from daebench.stepping.stability import CENTRAL, NewmarkMember


def method_for(system) -> CentralMethod:
    """The method data for a system with a lumped mass (IntegratorError otherwise)."""
    m = getattr(system, "lumped_mass", None)
    if m is None:
        raise IntegratorError(
            f"explicit central differences need a model with a constant lumped (diagonal) mass that declares "
            f"'lumped_mass' ({type(system).__name__} does not); use hht or newmark")
    m = np.asarray(m, float)
    if np.any(m <= 0.0):
        raise IntegratorError("central differences need positive nodal masses")
    return CentralMethod(1.0 / m)


class CentralDifference(CompiledIntegrator):
    """Explicit central differences (velocity Verlet) for lumped-mass models.

    Settings
    --------
    h, h_contact : float
        Fixed step sizes (h_contact while a penalty contact penetrates); both must
        satisfy h ω_max ≤ 2 — checked before the first step against the scene's ω_max
        (a refusal names the limit); ``h = auto`` takes the largest stable step.

    Notes
    -----
    Order 2; conditionally stable (h ω_max ≤ 2); no numerical dissipation; O(n) per
    step. See the module docstring for the scheme, its model requirement and references.
    """

    name: ClassVar[str] = "central"
    description: ClassVar[str] = "explicit central differences (velocity Verlet) for lumped-mass models, O(n) a step"
    capabilities: ClassVar[Capabilities] = Capabilities(order=2, fixed_step=True, adaptive=False, constraints=False)
    settings_spec: ClassVar[tuple[Setting, ...]] = STEP_SETTINGS
    fail_messages = FAIL_MESSAGES

    def method(self) -> CentralMethod:
        return method_for(self.problem.system)

    def workspace(self, n: int, m: int) -> CentralWork:
        return workspace(n)

    def stability_model(self) -> NewmarkMember:
        return CENTRAL
