"""`daebench verify INTEGRATOR`: a conformance run — what an integrator declares, measured on
cases with exact solutions, one pass/fail line per property with the numbers.

Properties (each a function ``(cls, settings) -> Check``, in :data:`PROPERTIES`):

* **order** — the slope of log(max position error at the step points) against log(h) over
  :data:`ORDER_STEPS` on the first smooth case with an exact solution the integrator runs
  (:func:`daebench.workflows.verify_cases.smooth_cases`:
  the pendulum, index 3; a harmonic oscillator for ODE-only methods, with a wall out of
  reach for methods that resolve contacts themselves), at fixed steps; it passes when the
  measured order reaches the declared ``capabilities.order`` within :data:`ORDER_SLACK`. An
  adaptive-only method is held to its tolerance instead (the error falls with rtol).
* **drift** — the constraint residuals |C| (position) and |Ċ| (velocity) over the pendulum
  at h = :data:`DRIFT_STEP` against the declared ``capabilities.index``: index 3 holds
  |C| ≤ :data:`HELD`, index 2 holds |Ċ| ≤ :data:`HELD`, index 1 lets both drift up to
  :data:`INDEX1_DRIFT` (a method that drifts more, or one that declares more than it holds,
  fails).
* **energy** — the smooth case over :data:`ENERGY_T_END` (undamped): the largest relative
  energy error and the final one (growth), both ≤ :data:`ENERGY_TOL` of the energy scale.
* **contract** — the steps themselves, taken directly (no driver) on the smooth case's
  problem: each advances t and lands exactly on ``t_stop``, q, v, a of shape (n,) and λ of
  shape (m,), finite values, the step counter kept, the same steps repeated bit for bit.
* **contact** — through the driver: the ball's impact times against the exact ones
  (event-driven: within :data:`IMPACT_TOL` s; resolved by the integrator: impact k within
  (k + 1) steps — only the first one for an integrator with no restitution of its own),
  and, when it declares ``friction``, Housner's ratio ω⁺/ω⁻ = 1 − 1.5 sin²α at the rocking
  block's first four impacts.

A property the integrator cannot be measured on (no case it runs) is ``n/a`` with the
reason, never a failure; a run that fails is a failure with its message. Each property has
a wall-time cap (``run_cap``, :data:`PROPERTY_CAP` by default): a plugin's properties are
measured in a forked child process that is killed beyond it (code blocked where no
cooperative stop reaches), and whatever the integrator's code raises — an exit or an
interrupt of its own included — is that property's failure. The result type and the smooth
cases, and how one run on them is made and fitted: :mod:`daebench.workflows.verify_cases`.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from typing import Any, Callable, Sequence

import numpy as np

from daebench.core.energyscale import energy_scale
from daebench.core.params import ParamError, did_you_mean
from daebench.core.problem import Problem
from daebench.core.scene import Scene, tagged
from daebench.core.system import State
from daebench.core import interrupt
from daebench.harness.running import isolated
from daebench.harness.running.deadline import check_run_cap, deadline
from daebench.harness.running.runner import make_integrator
from daebench.integrators import base
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import IntegratorError
from daebench.models import build_system
from daebench.models.ball import exact_motion
from daebench.models.rigid2d_exact import housner_ratio
from daebench.workflows.verify_cases import (Check, applies, fixed_settings, fmt_numbers, run_exact, scene_of, slope,
                                             smooth_case, smooth_cases)

ORDER_STEPS = (8e-3, 4e-3, 2e-3, 1e-3)   # s: the fixed steps of the order fit (8× larger above order 2)
ORDER_SLACK = 0.3        # the measured order may fall this far below the declared one
ORDER_FLOOR = 1e-11      # errors below this (relative to the case's size) are round-off: not fitted
ORDER_TOLS = (1e-4, 1e-5, 1e-6, 1e-7)    # rtol of an adaptive-only method's tolerance check
TOL_SLOPE = 0.5          # its error must fall at least like rtol^0.5
DRIFT_STEP = 1e-3        # s
HELD = 1e-8              # |C| [m] or |Ċ| [m/s] a level the integrator enforces may reach (pendulum, l = 1 m)
INDEX1_DRIFT = 1e-3      # what an acceleration-level method may drift to over 1 s at h = 1e-3 s
ENERGY_T_END = 10.0      # s
ENERGY_STEP = 1e-3       # s
ENERGY_TOL = 1e-3        # of the energy scale
CONTRACT_STEPS = 10.5    # t_stop = 10.5 h: ten steps, then a half step that must land on it
IMPACT_STEP = 1e-3       # s
IMPACT_TOL = 1e-6        # s: event-driven impact times (the driver locates the event)
HOUSNER_STEPS = {False: 1e-3, True: 2.5e-4}   # event-driven, resolved by the integrator (first order)
HOUSNER_TOL = {False: 1e-6, True: 3e-3}
PROPERTY_CAP = 600.0     # s: the default wall-time cap of one property (verify --run-cap)


@dataclass
class VerifyResult:
    """The conformance report of one integrator at its settings."""

    integrator: str
    settings: dict[str, Any]
    declared: dict[str, Any]
    checks: list[Check]

    @property
    def ok(self) -> bool:
        """No property failed (n/a is not a failure)."""
        return all(c.status != "fail" for c in self.checks)

    @property
    def failed(self) -> list[Check]:
        return [c for c in self.checks if c.status == "fail"]

    def lines(self) -> list[str]:
        return [c.line for c in self.checks]

    def as_json(self) -> str:
        return json.dumps({"integrator": self.integrator, "settings": self.settings, "declared": self.declared,
                           "ok": self.ok, "checks": [asdict(c) for c in self.checks]}, default=str)


def order_steps(order: int) -> tuple[float, ...]:
    """The fixed steps of the order fit: larger for a high order (its errors reach round-off sooner)."""
    return ORDER_STEPS if order <= 2 else tuple(8 * h for h in ORDER_STEPS[::-1])[::-1]


# ---- the properties -----------------------------------------------------------------------------------
def check_order(cls: type, settings: dict[str, Any]) -> Check:
    """The measured order against the declared one (module docstring)."""
    declared = cls.capabilities.order
    case, sc = smooth_case(cls)
    if case is None:
        return Check("order", "n/a", sc)
    label, _, _, col, unit = case
    # output times on the step points of every step of the fit: the interpolant between steps (cubic
    # Hermite by default) must not cap the measured order at 4
    steps = order_steps(declared)
    sc = sc.with_overrides({"output.dt": steps[0]})
    if not cls.capabilities.fixed_step:
        return _tolerance_check(cls, settings, sc, label, col, unit)
    errs, hs = [], []
    for h in steps:
        res, found = run_exact(sc, cls.name, fixed_settings(cls, settings, h))
        if res.refused:
            return Check("order", "n/a", f"{label}: refused at its start: {res.message}")
        if res.status != "completed":
            return Check("order", "fail", f"{label} at h = {h:g} s did not complete: {res.status} — {res.message}",
                         {"h": h})
        hs.append(h)
        errs.append(float(found.get(col, math.nan)))
    use = [(h, e) for h, e in zip(hs, errs) if math.isfinite(e) and e > ORDER_FLOOR]
    nums = {"h": hs, "errors": errs, "declared": declared}
    if len(use) < 2:
        return Check("order", "n/a", f"{label}: errors {fmt_numbers(errs)} {unit} are at round-off over "
                                     f"h = {fmt_numbers(hs)} s "
                                     f"(exact for this case); declared {declared}", nums)
    p = slope(*zip(*use))
    nums["measured"] = p
    ok = p >= declared - ORDER_SLACK
    above = " (above the declared order)" if p > declared + 0.5 else ""
    return Check("order", "pass" if ok else "fail",
                 f"measured {p:.2f}{above}, declared {declared}: slope of log max error against log h on {label} "
                 f"(h = {fmt_numbers(hs)} s: errors {fmt_numbers(errs)} {unit})", nums)


def _tolerance_check(cls: type, settings: dict[str, Any], sc: Scene, label: str, col: str, unit: str) -> Check:
    names = {s.name for s in cls.settings_spec}
    if "rtol" not in names:
        return Check("order", "n/a", f"adaptive only, without an rtol setting: its order cannot be measured at fixed "
                                     f"steps; declared {cls.capabilities.order}")
    errs = []
    for r in ORDER_TOLS:
        res, found = run_exact(sc, cls.name, {**settings, "rtol": r, **({"atol": r / 100} if "atol" in names else {})})
        if res.status != "completed":
            return Check("order", "fail", f"{label} at rtol = {r:g} did not complete: {res.status} — {res.message}")
        errs.append(float(found.get(col, math.nan)))
    use = [(r, e) for r, e in zip(ORDER_TOLS, errs) if math.isfinite(e) and e > ORDER_FLOOR]
    nums = {"rtol": list(ORDER_TOLS), "errors": errs, "declared": cls.capabilities.order}
    fitted = slope(*zip(*use)) if len(use) >= 2 else math.nan
    nums["tolerance_slope"] = fitted
    ok = math.isfinite(fitted) and fitted >= TOL_SLOPE
    return Check("order", "pass" if ok else "fail",
                 f"adaptive only: error falls like rtol^{fitted:.2f} (≥ {TOL_SLOPE} needed) on {label} (rtol = "
                 f"{fmt_numbers(ORDER_TOLS)}: errors {fmt_numbers(errs)} {unit}); the declared order "
                 f"{cls.capabilities.order} is "
                 f"not measurable at fixed steps", nums)


def _step_settings(cls: type, settings: dict[str, Any], h: float) -> dict[str, Any]:
    return fixed_settings(cls, settings, h) if cls.capabilities.fixed_step else dict(settings)


def check_drift(cls: type, settings: dict[str, Any]) -> Check:
    """Constraint residuals against the declared index (module docstring)."""
    cap = cls.capabilities
    if not cap.constraints:
        return Check("drift", "n/a", "ODE only (declares no constraints): nothing to hold")
    sc = scene_of("pendulum")
    refusal = applies(sc, cls)
    if refusal:
        return Check("drift", "n/a", f"pendulum: {refusal}")
    res, found = run_exact(sc, cls.name, _step_settings(cls, settings, DRIFT_STEP))
    if res.status != "completed":
        return Check("drift", "fail", f"pendulum did not complete: {res.status} — {res.message}")
    C, Cd = float(res.constraint_max["C"]), float(res.constraint_max["Cdot"])
    nums = {"C": C, "Cdot": Cd, "declared_index": cap.index}
    at = f"pendulum, 1 s at h = {DRIFT_STEP:g} s" if cap.fixed_step else "pendulum, 1 s at its tolerances"
    measured = f"max |C| = {C:.2e} m, |Ċ| = {Cd:.2e} m/s ({at})"
    if cap.index == 3:
        ok, rule = C <= HELD, f"index 3 holds |C| ≤ {HELD:g} m"
    elif cap.index == 2:
        ok, rule = Cd <= HELD, f"index 2 holds |Ċ| ≤ {HELD:g} m/s"
    else:
        ok, rule = max(C, Cd) <= INDEX1_DRIFT, f"index {cap.index} may drift up to {INDEX1_DRIFT:g}"
    return Check("drift", "pass" if ok else "fail", f"{measured}; declared index {cap.index}: {rule}", nums)


def _undamped_case(cls: type) -> tuple[str, Scene] | tuple[None, str]:
    """The first smooth case (:func:`daebench.workflows.verify_cases.smooth_cases`) ``cls`` runs, over ENERGY_T_END."""
    for label, name, over, _, _ in smooth_cases(cls):
        sc = scene_of(name, {**over, "t_end": ENERGY_T_END})
        if not applies(sc, cls):
            return label, sc
    return None, "no undamped case it runs"


def check_energy(cls: type, settings: dict[str, Any]) -> Check:
    """Energy on an undamped case (module docstring)."""
    label, sc = _undamped_case(cls)
    if label is None:
        return Check("energy", "n/a", sc)
    res, found = run_exact(sc, cls.name, _step_settings(cls, settings, ENERGY_STEP))
    if res.refused:
        return Check("energy", "n/a", f"{label}: refused at its start: {res.message}")
    if res.status != "completed":
        return Check("energy", "fail", f"{label} did not complete: {res.status} — {res.message}")
    system = build_system(sc)
    scale = energy_scale(system, *system.initial_state())
    E = res.history["E"].to_numpy(float)
    dev = (E - E[0]) / scale
    worst, final = float(np.max(np.abs(dev))), float(dev[-1])
    ok = worst <= ENERGY_TOL and np.isfinite(worst)
    at = f"h = {ENERGY_STEP:g} s" if cls.capabilities.fixed_step else "its tolerances"
    return Check("energy", "pass" if ok else "fail",
                 f"max |E − E0| = {worst:.2e}, E(end) − E0 = {final:+.2e} of the energy scale ({scale:.3g} J) over "
                 f"{sc.t_end:g} s of the {label} at {at} (≤ {ENERGY_TOL:g} needed)",
                 {"max_rel": worst, "final_rel": final, "scale_J": scale})


def check_contract(cls: type, settings: dict[str, Any]) -> Check:
    """The steps themselves, taken directly on the smooth case's problem (module docstring)."""
    case, sc = smooth_case(cls)
    if case is None:
        return Check("contract", "n/a", sc)
    h = ORDER_STEPS[-1]
    try:
        first = _direct_steps(cls, settings, sc, h)
    except base.ContractViolation as exc:
        return Check("contract", "fail", str(exc))
    except IntegratorError as exc:
        return Check("contract", "n/a", f"{case[1]}: refused at its start: {exc}")
    except Exception as exc:  # noqa: BLE001 - the integrator's own error is the finding
        return Check("contract", "fail", f"a step raised {type(exc).__name__}: {exc}")
    if isinstance(first, str):
        return Check("contract", "fail", first)
    again = _direct_steps(cls, settings, sc, h)
    calls, states, counted = first
    same = not isinstance(again, str) and len(again[1]) == len(states) and all(
        a.t == b.t and all(np.array_equal(getattr(a, k), getattr(b, k)) for k in ("q", "v", "a", "lam"))
        for a, b in zip(states, again[1]))
    if not same:
        return Check("contract", "fail", f"the same {calls} steps from the same state, repeated with a new instance, "
                                         f"gave different states (not deterministic)")
    s = states[-1]
    return Check("contract", "pass",
                 f"{calls} steps on {case[1]} (h = {h:g} s, t_stop = {CONTRACT_STEPS:g} h): each advanced t, the "
                 f"last landed on t_stop exactly; q, v, a {np.shape(s.q)}, λ {np.shape(s.lam)}, finite; {counted} "
                 f"steps counted; repeated bit for bit", {"calls": calls, "counted": counted})


def _direct_steps(cls: type, settings: dict[str, Any], sc: Scene, h: float) -> tuple[int, list[State], int] | str:
    """Step ``cls`` from the scene's consistent start to t_stop = CONTRACT_STEPS·h by direct
    calls; a violation the base raises (:func:`daebench.integrators.base.check_step`)
    propagates; what it does not check comes back as the failure's text."""
    system = build_system(sc)
    problem = Problem(system)
    q, v = (np.asarray(x, float) for x in system.initial_state())
    a, lam = problem.acceleration(0.0, q, v)
    integ = make_integrator(cls.name, _step_settings(cls, settings, h))
    integ.start(problem, State(0.0, q, v, a, lam), h)
    t_stop = CONTRACT_STEPS * h
    states: list[State] = []
    limit = 4 * math.ceil(CONTRACT_STEPS) + 10
    while (not states or states[-1].t < t_stop) and len(states) < limit:
        s = integ.step(t_stop)
        k = len(states) + 1
        for key in ("q", "v", "a", "lam"):
            x = np.asarray(getattr(s, key), float)
            if not np.all(np.isfinite(x)):
                return f"step {k} (to t = {s.t:.9g} s) returned a non-finite {key}"
        counted = integ.counters_snapshot()["steps"]
        if counted != k:
            return f"after {k} steps the integrator's counters say {counted} steps (the base counts them: rule 4)"
        states.append(s.copy())
    if states[-1].t != t_stop:
        return (f"{len(states)} steps toward t_stop = {t_stop:.9g} s ended at t = {states[-1].t:.17g} s, not on "
                f"t_stop exactly (daebench.stepping.control.land)")
    return len(states), states, integ.counters_snapshot()["steps"]


def check_contact(cls: type, settings: dict[str, Any]) -> Check:
    """Impact times on the ball; Housner's ratio when friction is declared (module docstring)."""
    own = cls.capabilities.contacts
    law = "constraint" if not own or "constraint" in cls.contact_laws else "complementarity"
    sc = scene_of("ball", {"contact.law": law})
    refusal = applies(sc, cls)
    if refusal:
        return Check("contact", "n/a", f"ball: {refusal}")
    res, found = run_exact(sc, cls.name, _step_settings(cls, settings, IMPACT_STEP))
    if res.refused:
        return Check("contact", "n/a", f"ball: refused at its start: {res.message}")
    if res.status != "completed":
        return Check("contact", "fail", f"ball did not complete: {res.status} — {res.message}")
    exact = [t for t, _, _ in exact_motion(build_system(sc), sc.t_end)[0]]
    got = [float(i.t) for i in res.impacts]
    how = "resolved by the integrator" if own else "located by the driver"
    if law == "complementarity":   # its own law, no restitution: only the first impact's time is known
        exact, got = exact[:1], got[:1]
        how += ", its own contact law (no restitution): the first impact"
    # event-driven: the driver's event location; resolved in the steps: impact k within (k + 1) h
    # (each impact within its step, and the flight times after it off by O(h))
    tols = [IMPACT_TOL if not own else (k + 2) * IMPACT_STEP for k in range(len(exact))]
    errs = [abs(a - b) for a, b in zip(got, exact)]
    err = max(errs, default=math.nan)
    nums = {"impacts": len(got), "exact": len(exact), "time_errors_s": errs}
    ok = len(got) == len(exact) and len(errs) > 0 and all(e <= t for e, t in zip(errs, tols))
    need = f"≤ {IMPACT_TOL:g} s needed" if not own else "impact k within (k + 1)·h needed"
    text = (f"ball ({how}, h = {IMPACT_STEP:g} s): {len(got)} impacts of {len(exact)} exact, impact times within "
            f"{err:.2e} s ({need})")
    if not cls.capabilities.friction:
        return Check("contact", "pass" if ok else "fail", text + "; no friction declared", nums)
    hc = _housner(cls, settings)
    nums.update(hc.numbers)
    return Check("contact", "pass" if ok and hc.status == "pass" else "fail", f"{text}; {hc.text}", nums)


def _housner(cls: type, settings: dict[str, Any]) -> Check:
    own = cls.capabilities.contacts
    cases = tagged("housner")
    if not cases:
        return Check("housner", "fail", "no case is tagged 'housner' in its [compare] table: the friction check "
                                        "needs the rocking block of Housner's closed form")
    sc = scene_of(cases[0])
    refusal = applies(sc, cls)
    if refusal:
        return Check("housner", "fail", f"{sc.name} (friction declared): {refusal}")
    h = HOUSNER_STEPS[own]
    res, found = run_exact(sc, cls.name, _step_settings(cls, settings, h))
    imps = [i for i in res.impacts if i.t > 0 and i.v_minus is not None][:4]
    r = housner_ratio(sc["body.width"], sc["body.height"])
    if res.status != "completed" or len(imps) < 4:
        return Check("housner", "fail", f"{sc.name} at h = {h:g} s: {res.status}, {len(imps)} impacts with "
                                        f"velocities (4 needed) — {res.message}")
    ratios = [abs(i.v_plus[2]) / abs(i.v_minus[2]) for i in imps]
    err = max(abs(x - r) for x in ratios)
    ok = err <= HOUSNER_TOL[own]
    return Check("housner", "pass" if ok else "fail",
                 f"Housner's ω⁺/ω⁻ on {sc.name} (h = {h:g} s) {fmt_numbers(ratios)} against 1 − 1.5 sin²α = {r:.6f}, "
                 f"off by {err:.1e} (≤ {HOUSNER_TOL[own]:g} needed)", {"housner_ratios": ratios, "housner_error": err})


#: every property, in report order
PROPERTIES: dict[str, Callable[[type, dict[str, Any]], Check]] = {
    "order": check_order, "drift": check_drift, "energy": check_energy, "contract": check_contract,
    "contact": check_contact}


def _measure(p: str, cls: type, settings: dict[str, Any], run_cap: float) -> Check:
    """Property ``p`` of ``cls`` within ``run_cap`` seconds of wall time: in a forked child for
    a plugin (code that blocks is stopped there, :mod:`daebench.harness.running.isolated`),
    under the cooperative cap for a built-in; whatever its code raises is the finding."""
    signals = interrupt.signal_count()
    try:
        with interrupt.signals_counted():
            if isolated.available() and not cls.__module__.startswith("daebench."):
                return isolated.call(lambda _: PROPERTIES[p](cls, settings), run_cap, None, f"property '{p}'")[0]
            with deadline(run_cap):
                return PROPERTIES[p](cls, settings)
    except ParamError as exc:   # a setting the case refuses (e.g. ~1e10 steps)
        return Check(p, "n/a", str(exc))
    except interrupt.RunTimeout as exc:
        return Check(p, "fail", f"{exc} (verify --run-cap sets the cap of each property)")
    except BaseException as exc:  # noqa: BLE001 - the integrator's own error is the finding
        if interrupt.from_signal(exc, signals):
            raise
        return Check(p, "fail", f"raised {interrupt.describe_raised(exc)}")


def verify(name: str, settings: dict[str, Any] | None = None, properties: Sequence[str] | str | None = None,
           progress: Callable[[str], None] | None = None, run_cap: float = PROPERTY_CAP) -> VerifyResult:
    """Measure what integrator ``name`` declares (module docstring), at ``settings``, each
    property within ``run_cap`` seconds of wall time (:data:`PROPERTY_CAP` by default);
    ``progress`` is called with each property's name before it runs, then with its line.

    Raises
    ------
    IntegratorError
        An unknown integrator, bad settings or an unknown property — before anything runs.
    """
    run_cap = check_run_cap(run_cap)
    cls = integrator_registry.get_integrator(name)
    settings = dict(settings or {})
    cls(**settings)   # the settings are checked before any run
    if isinstance(properties, str):   # "order" or "order,drift": names, not letters
        properties = [p.strip() for p in properties.split(",") if p.strip()]
    wanted = list(properties or PROPERTIES)
    unknown = [p for p in wanted if p not in PROPERTIES]
    if unknown:
        raise IntegratorError(f"unknown property '{unknown[0]}'{did_you_mean(unknown[0], PROPERTIES)} "
                              f"Properties: {', '.join(PROPERTIES)}.")
    out = []
    for p in wanted:
        if progress is not None:
            progress(p)
        out.append(_measure(p, cls, settings, run_cap))
    cap = cls.capabilities
    return VerifyResult(cls.name, settings, asdict(cap), out)
