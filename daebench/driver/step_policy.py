"""The run's step rules in one place (as diffrax's step-size controller): the free step, the
contact step, whether the integrator adapts its step, and what the driver derives from
them — the step a phase starts with (halved after a failed restart), the proximity time
of the contact step and the Zeno rule's time scale.

Built once for a run from the integrator's validated settings (:meth:`StepPolicy.of`,
after ``h = auto`` is resolved: :func:`daebench.harness.running.checks.check_step`) and
handed to the driver unchanged; the driver reads the steps from here, never from the
integrator.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from daebench.stepping.watch import NEAR_STEPS


@dataclass(frozen=True)
class StepPolicy:
    """``h`` the free step, ``h_contact`` the step while a contact is closed or near (default
    ``h``: no contact step of its own), ``adaptive`` whether the integrator chooses its steps
    itself (then ``h`` is its first)."""

    h: float
    h_contact: float | None = None
    adaptive: bool = False

    @classmethod
    def of(cls, integrator: Any) -> "StepPolicy":
        """The policy of an integrator's validated settings (its free and contact steps,
        :meth:`daebench.integrators.base.Integrator.step_size`, and ``adaptive``)."""
        return cls(float(integrator.step_size(False)), float(integrator.step_size(True)), bool(integrator.adaptive))

    def __post_init__(self) -> None:
        if self.h_contact is None:
            object.__setattr__(self, "h_contact", self.h)
        if not (self.h > 0.0 and self.h_contact > 0.0):
            raise ValueError(f"a step policy needs steps > 0 (got h = {self.h}, h_contact = {self.h_contact})")

    def start_step(self, in_contact: bool, halvings: int = 0) -> float:
        """The step a phase starts with, halved once per failed restart."""
        return (self.h_contact if in_contact else self.h) * 0.5 ** halvings

    @property
    def near_h(self) -> float:
        """The proximity time: an open contact within NEAR_STEPS free steps of its surface is
        near and runs the contact step (0 when the contact step is not the smaller)."""
        return NEAR_STEPS * self.h if self.h_contact < self.h else 0.0

    def zeno_step(self, h: float) -> float:
        """The Zeno rule's time scale for a phase run at ``h``: that step when fixed, 0 when
        the integrator adapts (an adaptive step resolves what it must itself)."""
        return 0.0 if self.adaptive else h
