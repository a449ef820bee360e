"""The interactive-mode method (IMM) of seed 001 for flexible bodies in contact.

Wang, Liu & Hong, "Dynamic modeling method of flexible bodies with contact/impact based
on interactive mode", Acta Phys. Sin. 66(15) 154501 (2017) (docs/sources.md §D): the model is
split into a **global dynamics module** — the whole lumped-mass FE model on floating
frames, M q̈ = f + f_c — and a **local statics module** — the elements around the
contact, inertia neglected, f(p) + G_pᵀλ = 0, G(p) = 0 solved by Newton with the
contact constraint exact. Displacements go global → local (the local region's boundary
follows the global state), the contact force goes local → global and acts in the
**next** step (the paper's one-step lag).

What the paper states and what this implementation chose where it is silent
-------------------------------------------------------------------------------
* Global integrator (not stated): ``global_method`` = ``central`` (explicit central
  differences, :mod:`daebench.integrators.central`: O(n) a step with the lumped mass)
  or ``hht`` (HHT-α, the integrator of the ACM runs, for a like-for-like cost
  comparison). Fixed step ``h`` (not stated).
* Local region (stated: the elements containing nodes within the a-priori Hertz
  contact radius, rebuilt when the contact moves): every element with a node within
  ``radius`` of a contact point, in the reference configuration of its body, plus all
  elements of the slave node and of the master segment's nodes (so that the contact
  nodes are free even when the radius is below the element size); rebuilt at every
  step in contact from the current contact points (``stats['region_rebuilds']`` counts
  the steps whose element set changed). ``radius`` = 0 takes the scene's estimate
  (``imm.radius``, else the layout's Hertz estimate).
* Boundary (stated: displacement boundary from the global module): the region's
  interface nodes (those with an element outside it) keep their global positions; the
  free nodes and λ are the unknowns. The global coordinates are *not* overwritten by the
  static solution (kinematics come from the global module only).
* Both bodies (not stated): for a flexible master the region spans both bodies and one
  Newton system couples them through the gap constraints.
* Newton (eq. 22; tolerance and iteration cap not stated): iteration matrix
  [[−K_L, G_pᵀ], [G_p, 0]] with K_L assembled from the element matrices in the frames
  of the global state (the gap curvature λ ∂G_pᵀ/∂p is left out); converged when the
  position update and the gaps are below ``tol`` × the smallest element size.
* Active set (stated only as "by the signs of λ and g"): start from the pairs that
  penetrate in the global state; drop the pair with the most negative λ, else add a
  candidate whose slave node is free and whose gap at the local solution is negative;
  repeat.
* Force map (f_c(λ) not stated): f_c = Σ λ_i g_q,iᵀ at the local solution — the slave
  node gets λ n, the master nodes −λ(1 − ξ) n and −λ ξ n.
* Lag: f_c computed at t_{n+1} acts, constant, over the step t_{n+1} → t_{n+2} (with
  central differences the stepper's acceleration is corrected so that both half-kicks
  of that step use it).

Consequences (measured in the issue-15 note): IMM is a penalty method whose stiffness is
the condensed stiffness of the local patch — no user parameter, no velocity jump, no
index-3 DAE — but the lagged force is an explicit coupling: stable only while h ω_c ≲ 2,
ω_c² ≈ k_patch/m_node, i.e. about the explicit stability step of the mesh, whatever the
global integrator. The contact node penetrates by ~ |ġ| h before it is pushed back.

Counters: ``newton_iterations`` and ``lu_factorizations`` count the local statics
module's (plus HHT's own when it is the global method); ``stats`` holds the steps in
contact, region rebuilds, active-set changes and the largest local region.

Contact episodes (first to last step with λ_i > 0 of contact point i) are reported to
the driver: start and end time, ġ at both ends, impulse Σλh, smallest global gap.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar


from daebench.core.contact import Impact
from daebench.integrators.base import Capabilities, IntegratorError, Setting
from daebench.integrators.central import method_for, workspace as central_workspace
from daebench.integrators.compiled import CompiledIntegrator
from daebench.integrators.family import hht_coefficients
from daebench.stepping import newmark as _nm
from daebench.stepping.stability import CENTRAL, NewmarkMember


class InteractiveMode(CompiledIntegrator):
    """Interactive-mode contact (global dynamics + local statics, one-step lag).

    Settings
    --------
    h : float
        Fixed step [s].
    global_method : 'central' | 'hht'
        Integrator of the global dynamics module.
    alpha : float in [−1/3, 0]
        HHT-α of the global module (global_method = 'hht').
    radius : float ≥ 0
        Local region radius [m]; 0 = the scene's (``imm.radius`` or the Hertz estimate).
    tol, maxiter : local Newton tolerance (× smallest element size) and iteration cap.
    max_local_nodes : int
        Capacity of the local statics module (free nodes).

    Notes
    -----
    Order 1 in the contact force (one-step lag), the global method's order elsewhere.
    See the module docstring for the method, the paper's open points and the choices.
    """

    name: ClassVar[str] = "imm"
    description: ClassVar[str] = ("interactive mode: global dynamics + local statics contact module, force "
                                  "lagged one step (planar FE models, contact.law = complementarity)")
    capabilities: ClassVar[Capabilities] = Capabilities(order=1, fixed_step=True, adaptive=False,
                                                        constraints=False, contacts=True)
    settings_spec: ClassVar[tuple[Setting, ...]] = (
        Setting("h", float, 1e-7, "fixed step size [s]", low=1e-12, high=1.0),
        Setting("global_method", str, "central", "integrator of the global dynamics module",
                choices=("central", "hht")),
        Setting("alpha", float, 0.0, "HHT-α of the global module (global_method = hht)", low=-1.0 / 3.0, high=0.0),
        Setting("radius", float, 0.0, "local region radius [m]; 0 = the scene's", low=0.0, high=1.0),
        Setting("tol", float, 1e-9, "local Newton tolerance × smallest element size", low=1e-14, high=1e-2),
        Setting("maxiter", int, 20, "local Newton iterations", low=1, high=200),
        Setting("max_local_nodes", int, 400, "capacity of the local statics module (free nodes)", low=1, high=100000),
    )
    fail_messages = dict(_nm.FAIL_MESSAGES)   # + the local module's, once the model is known (_local)

    def __init__(self, **settings: Any) -> None:
        super().__init__(**settings)
        self.stats: dict[str, int] = {}

    def _local(self) -> Any:
        """The model's local statics module (a module with ImmMethod, workspace,
        smallest_element, FAIL_MESSAGES and the S_* statistics slots): the local region's
        statics is the model's own FE structure, so the model provides it
        (``local_statics_module()``) and this integrator imports no model."""
        provide = getattr(self.problem.system, "local_statics_module", None)
        if provide is None:
            raise IntegratorError(f"integrator 'imm' runs the planar FE models (rod-wall, rod-plate, slider-slot); "
                                  f"{type(self.problem.system).__name__} is not one (it provides no local statics "
                                  f"module)")
        loc = provide()
        self.fail_messages = {**_nm.FAIL_MESSAGES, **loc.FAIL_MESSAGES}
        return loc

    def method(self) -> Any:
        loc = self._local()
        md = self.problem.system.kernel_data()
        s = self.settings
        if s["global_method"] == "central":
            inner = method_for(self.problem.system)
        else:
            c = hht_coefficients(float(s["alpha"]), ggl=False)
            inner = _nm.NewmarkMethod(c.alpha_m, c.alpha_f, c.beta, c.gamma, False, False, 1e-12, 8, True)
        radius = float(s["radius"]) or float(getattr(self.problem.system, "imm_radius", 0.0))
        return loc.ImmMethod(inner, radius, float(s["tol"]), int(s["maxiter"]), 4 * md.slave.shape[0] + 8,
                             loc.smallest_element(md), md)

    def stability_model(self) -> NewmarkMember:
        """The global module's method: explicit central differences (checked before the first
        step against the scene's ω_max; the lagged contact force is stable about as far) or HHT."""
        if self.settings["global_method"] == "central":
            return CENTRAL
        c = hht_coefficients(float(self.settings["alpha"]), ggl=False)
        return NewmarkMember(c.alpha_m, c.alpha_f, c.beta, c.gamma, False, "HHT-α")

    def workspace(self, n: int, m: int) -> Any:
        loc = self._local()
        md = self.problem.system.kernel_data()
        inner_ws = central_workspace(n) if self.settings["global_method"] == "central" else _nm.workspace(n, 0, False)
        return loc.workspace(inner_ws, md, int(self.settings["max_local_nodes"]))

    # -- episodes and statistics after every compiled call -----------------------------------
    def _run(self, t_stop: float, w, max_steps: int):
        try:
            return super()._run(t_stop, w, max_steps)
        finally:
            self._harvest()

    def _start(self) -> None:
        try:
            super()._start()
        finally:
            self._harvest()

    def _harvest(self) -> None:
        ws = getattr(self, "_ws", None)
        if ws is None:
            return
        for row in ws.log[:int(ws.n_log[0])]:
            i, t0, t1, vn0, vn1, imp, gmin = row
            self.report_contact(Impact(float(t0), int(i), float(vn0), float(vn1), math.nan, closed=False,
                                       impulse=float(imp), t_end=float(t1), min_gap=float(gmin)))
        ws.n_log[0] = 0
        st, loc = ws.stats, self._local()
        self.stats = {"contact_steps": int(st[loc.S_CONTACT_STEPS]), "region_rebuilds": int(st[loc.S_REBUILDS]),
                      "active_set_changes": int(st[loc.S_SET_CHANGES]), "max_free_nodes": int(st[loc.S_MAX_FREE]),
                      "episodes_lost": int(st[loc.S_LOG_LOST])}
