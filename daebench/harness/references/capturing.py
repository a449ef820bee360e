"""The reference of a nonsmooth or frictional case: a fine event-capturing run, its accuracy
stated as an IDA reference states its own (:mod:`daebench.harness.references.accuracy`).

**When.** :func:`reference_kind` picks the kind of a scene's reference
(:mod:`daebench.harness.references.reference` computes and stores either kind the same way):

* ``capturing`` for a scene with Coulomb friction at its contacts (a ``tangent`` kernel
  with μ > 0), with contacts left to an integrator (``contact.law = 'complementarity'``),
  or whose model declares ``capturing_reference`` (a non-empty reason: e.g. the
  slider-crank's chattering corners, whose accumulating impacts an event-driven run can
  only approximate). IDA resolves none of these: the event-driven driver applies no
  friction cone and no complementarity, and an accumulation of impacts is cut off;
* ``ida`` for every other scene.

**How.** :data:`CAPTURE_INTEGRATOR` (Moreau–Jean, θ = γ = ½) at the fixed step
:func:`reference_step` — :data:`STEP_DIVISOR` steps per output row of the reference, whose
rows are REF_OVERSAMPLE× denser than the scene's, so h = output.dt / (REF_OVERSAMPLE ·
STEP_DIVISOR), and at most 1/:data:`STEP_MARGIN` of the smallest step scored against it.
Fixed-step event capturing is first order through impacts and stick–slip switches
(:data:`ORDER`), so the accuracy record is built from:

* a coarse run at r h, r = :data:`COARSE_FACTOR` = 2.1: the reference's estimated error is
  |y_rh − y_h| / (r^p − 1), p = ORDER (Richardson's estimate; the loose run of an IDA
  reference divided by its tolerance ratio, ``loose_factor`` = r^p − 1 = 1.1 here). Not
  r = 2: the error of a switch (an impact, a stop) depends on where it falls inside its
  step, and a switch time commensurate with both h and 2h gives both runs the same error —
  the block on the incline (stop at 0.4025 s) at h = 5e-5 s: 2h agrees to 12.7 digits of
  vx's range where the reference is right to 5.0; with r = 2.1 the estimate says 4.8
  (tests/harness/test_refcapture.py);
* a run at h from a start perturbed by :data:`PERTURB_REL` relative (the sensitivity:
  where the chattering's bounce sequence changes, the two runs part);

:func:`daebench.harness.references.accuracy.assess` turns them into the digits per window and the
trusted span ``trust_t`` / ``trust_impacts`` exactly as for IDA references; the sidecar
records ``kind = 'capturing'``, why, the step and the integrator's settings.
"""

from __future__ import annotations

from contextlib import nullcontext
from typing import Any, Callable

from daebench.core.kernels import friction_coefficients
from daebench.core.scene import Scene
from daebench.driver.simulate import simulate
from daebench.harness.references import accuracy
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.models import build_system

CAPTURE_INTEGRATOR = "moreau"
STEP_DIVISOR = 10       # capturing steps per output row of the (REF_OVERSAMPLE× denser) reference history
STEP_MARGIN = 10.0      # the reference step is at most this fraction of the smallest scored step
COARSE_FACTOR = 2.1     # the coarse run's step / the reference's (not 2: see the module docstring)
ORDER = 1               # the order of fixed-step event capturing through impacts and switches
PERTURB_REL = 1e-10     # relative perturbation of the perturbed run's start (as rtol for IDA references)


def reference_kind(scene: Scene, system: Any = None) -> tuple[str, str]:
    """('capturing', why) for a scene only an event-capturing run resolves (module
    docstring), else ('ida', '')."""
    system = system if system is not None else build_system(scene)
    nc = int(getattr(system, "n_contacts", 0))
    if nc:
        q, v = system.initial_state()
        mu = friction_coefficients(system.kernel_handle(), nc, q, v)
        if (mu > 0.0).any():
            return "capturing", (f"Coulomb friction at its contacts (μ = {float(mu.max()):g}): the event-driven "
                                 f"IDA applies no friction cone")
        if system.contacts_by_integrator:
            return "capturing", ("contacts left to an integrator (contact.law = 'complementarity'): IDA resolves "
                                 "no complementarity")
        why = getattr(system, "capturing_reference", "")
        if why:
            return "capturing", str(why)
    return "ida", ""


def reference_step(scene: Scene, oversample: float, tightest_h: float | None = None) -> float:
    """The capturing reference's step: output.dt / (oversample · STEP_DIVISOR), at most the
    smallest scored step / STEP_MARGIN."""
    h = float(scene["output.dt"]) / (oversample * STEP_DIVISOR)
    if tightest_h is not None and tightest_h > 0:
        h = min(h, float(tightest_h) / STEP_MARGIN)
    return h


def capture_runs(scene: Scene, dense_scene: Scene, h: float, check: bool = True,
                 progress: Callable[[str, float], Any] | None = None) -> tuple[Any, Any, dict[str, Any]]:
    """(integrator, result, accuracy record) of the capturing reference of ``scene`` at step
    ``h``, its rows at ``dense_scene``'s output times; with ``check`` the coarse and the
    perturbed runs and :func:`daebench.harness.references.accuracy.assess` (module docstring).

    Raises
    ------
    RuntimeError
        If the reference run does not complete (a frictional LCP without solution, …).
    """
    def run(step: float, label: str, start: Any = None) -> tuple[Any, Any]:
        integ = make_integrator(CAPTURE_INTEGRATOR, {"h": step})
        with progress(label, scene.t_end) if progress is not None else nullcontext() as cb:
            if start is None:
                return integ, run_scene(dense_scene, integ, write=False, force=True, progress=cb)[1]
            system = accuracy.with_start(build_system(dense_scene), *start)
            return integ, simulate(system, integ, scene.t_end, dense_scene["output.dt"], progress=cb)

    integ, res = run(h, f"reference of {scene.name}: {CAPTURE_INTEGRATOR} h {h:g}")
    if res.status != "completed":
        raise RuntimeError(f"reference run of '{scene.name}' ({CAPTURE_INTEGRATOR} h = {h:g}) {res.status}: "
                           f"{res.message}")
    if not check:
        return integ, res, {}
    impacts = [float(i.t) for i in res.impacts]
    _, coarse = run(COARSE_FACTOR * h, f"accuracy of the reference: {CAPTURE_INTEGRATOR} h {COARSE_FACTOR * h:g}")
    start = accuracy.perturbed_start(build_system(scene), PERTURB_REL, factor=1.0)
    _, pert = run(h, f"accuracy of the reference: {CAPTURE_INTEGRATOR} h {h:g}, perturbed start", start=start)
    cols = list(scene["output.observables"]) or [c for c in res.history.columns if c != "t"]
    loose_factor = COARSE_FACTOR ** ORDER - 1.0
    acc = accuracy.assess(res.history, impacts, coarse.history, pert.history, cols, scene.t_end,
                          loose_factor=loose_factor)
    acc.update({"loose": coarse.status, "perturbed": pert.status, "perturbed_impacts": len(pert.impacts),
                "loose_impacts": len(coarse.impacts), "estimate": f"|y({COARSE_FACTOR:g}h) − y(h)| / "
                f"({COARSE_FACTOR:g}^{ORDER} − 1), {CAPTURE_INTEGRATOR} of order {ORDER} through impacts",
                "coarse_h": COARSE_FACTOR * h, "perturb_rel": PERTURB_REL})
    acc["perturb_factor"] = PERTURB_REL
    return integ, res, acc
