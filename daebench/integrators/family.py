"""The Newmark family, public: a member is a coefficient set (α_m, α_f, β, γ) with GGL
stabilization on or off and a choice of averaging — Newmark-β, HHT-α and generalized-α
are three small subclasses, and a plugin may add its own.

The step is :mod:`daebench.stepping.newmark` (formulation, scaled Newton, convergence
test, Zienkiewicz–Xie error estimate and references are in its docstring); it runs
compiled on every model, fixed or adaptive (:class:`~daebench.integrators.compiled.CompiledIntegrator`).
"""

from __future__ import annotations

from typing import NamedTuple

from daebench.integrators.base import Setting
from daebench.integrators.compiled import CompiledIntegrator
from daebench.stepping import newmark as _nm
from daebench.stepping.stability import NewmarkMember

NEWTON_SETTINGS = (
    Setting("newton_tol", float, 1e-12, "Newton tolerance on the scaled displacement increment and "
            "the normalized constraint residuals", low=1e-15, high=1e-3),
    Setting("newton_maxiter", int, 8, "Newton iterations per attempt before the matrix is rebuilt / "
            "the step fails", low=1, high=100),
    Setting("reuse_jacobian", bool, True, "modified Newton: keep the factorized iteration matrix across "
            "iterations and steps while the contraction rate is good"),
)


class Coefficients(NamedTuple):
    """A member of the family (see :mod:`daebench.stepping.newmark`)."""

    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float
    ggl: bool = False
    accel_avg: bool = False  # Arnold–Brüls acceleration averaging (else force averaging)


def hht_coefficients(alpha: float, ggl: bool = True) -> Coefficients:
    """HHT-α, α ∈ [−1/3, 0]: α_m = 0, α_f = −α, β = (1−α)²/4, γ = ½ − α (force averaging)."""
    return Coefficients(0.0, -alpha, 0.25 * (1.0 - alpha) ** 2, 0.5 - alpha, ggl, False)


def chung_hulbert(rho_inf: float) -> Coefficients:
    """Generalized-α of Chung & Hulbert (1993) for spectral radius ρ∞ ∈ [0, 1] at h ω → ∞:
    α_m = (2ρ∞ − 1)/(ρ∞ + 1), α_f = ρ∞/(ρ∞ + 1), γ = ½ − α_m + α_f, β = ¼(1 − α_m + α_f)²
    (second order, unconditionally stable, high-frequency dissipation maximal for the
    given ρ∞ and low-frequency dissipation minimal)."""
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    return Coefficients(am, af, 0.25 * (1.0 - am + af) ** 2, 0.5 - am + af, False, True)


_DENSE_SCRATCH = ("LU", "M", "Kq", "Kv", "KM", "KC")


def _dense_scratch_kept(ws: _nm.NewmarkWork, previous: _nm.NewmarkWork | None) -> _nm.NewmarkWork:
    """A new phase's workspace with the last phase's dense scratch in it where the shapes
    agree: the iteration matrix and the n × n matrices M, K_q, K_v, K_M, K_C, which a step
    writes before it reads (they are allocated uninitialised). Why: at n = 4 738 each is
    180 MB, which the system maps afresh at every phase start (an impact, a contact that
    closes) and faults in a page per row on its first write. The history arrays are new."""
    if previous is None:
        return ws
    kept = {k: getattr(previous, k) for k in _DENSE_SCRATCH if getattr(previous, k).shape == getattr(ws, k).shape}
    return ws._replace(**kept)


class NewmarkFamily(CompiledIntegrator):
    """Base of the Newmark-family integrators: subclasses implement :meth:`coefficients`."""


    fail_messages = {k: v.replace("{maxiter}", "{newton_maxiter}") for k, v in _nm.FAIL_MESSAGES.items()}

    def coefficients(self) -> Coefficients:
        raise NotImplementedError

    def method(self) -> _nm.NewmarkMethod:
        c = self.coefficients()
        s = self.settings
        return _nm.NewmarkMethod(float(c.alpha_m), float(c.alpha_f), float(c.beta), float(c.gamma), bool(c.ggl),
                                 bool(c.accel_avg), float(s["newton_tol"]), int(s["newton_maxiter"]),
                                 bool(s["reuse_jacobian"]))

    def workspace(self, n: int, m: int) -> _nm.NewmarkWork:
        declared = getattr(self.problem.system, "sparsity", None)  # a model's Sparsity, if it declares one
        ws = _nm.workspace(n, m, bool(self.coefficients().ggl) and m > 0, declared() if declared else None)
        return _dense_scratch_kept(ws, getattr(self, "_ws", None))

    def stability_model(self) -> NewmarkMember:
        c = self.coefficients()
        return NewmarkMember(c.alpha_m, c.alpha_f, c.beta, c.gamma, bool(c.accel_avg), type(self).__name__)
