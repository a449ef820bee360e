"""Checks made before a run takes its first step.

Everything a run would only discover late — an observable the model does not have,
~1e10 steps, an integrator that cannot handle the scene's contacts, a start through a
rigid surface, an explicit method's step beyond its stability limit — is refused here, before any step, with a message that says what to
change (:class:`GuardError`, a :class:`~daebench.core.params.ParamError`: exit code 2 on
the command line).
"""

from __future__ import annotations

import math
import os
from typing import Any

from daebench.core.params import ParamError, did_you_mean
from daebench.core.scene import scene_names
from daebench.integrators import applicability
from daebench.integrators.base import Integrator, IntegratorError
from daebench.driver.history import DIVERGENCE_ENERGY
from daebench.models import build_system
from daebench.models.scenes import load_scene
from daebench.stepping import stability

MAX_STEPS = 1e8          # fixed steps a run may plan without force (≈ 3 min compiled, hours in Python)
MAX_OUTPUT_ROWS = 1e7    # history rows (each ~30 floats: ~2.4 GB at this size)
#: dense (n + m) × (n + m) float64 matrices a run may hold at once (the driver's augmented system and its
#: factor, an implicit step's mass, stiffness, damping and iteration matrices and their factor)
DENSE_MATRICES = 8
#: the share of the machine's memory a run's estimate may take
MEMORY_FRACTION = 0.5


class GuardError(ParamError):
    """A run refused before its first step; the message says what to change."""


def estimated_steps(scene: Any, integ: Integrator) -> float:
    """Steps a fixed-step run plans over the scene (t_end / h); 0 when the integrator
    chooses its own steps (adaptive, or no ``h`` setting)."""
    h = integ.settings.get("h")
    if integ.adaptive or not h:
        return 0.0
    return scene.t_end / float(h)


def check_size(scene: Any, integ: Integrator) -> None:
    """Refuse a run whose step count or history size is beyond reason (pass ``force``
    to the caller to run it anyway)."""
    n = estimated_steps(scene, integ)
    if n > MAX_STEPS:
        raise GuardError(
            f"h = {integ.settings['h']:g} s over t_end = {scene.t_end:g} s is ≈ {n:.2g} steps, beyond the limit of "
            f"{MAX_STEPS:.0e}; use a larger h (e.g. --opt h=1e-4) or a shorter t_end, or pass --force to run it anyway")
    rows = scene.t_end / float(scene["output.dt"])
    if rows > MAX_OUTPUT_ROWS:
        raise GuardError(
            f"output.dt = {scene['output.dt']:g} s over t_end = {scene.t_end:g} s is ≈ {rows:.2g} history rows, beyond "
            f"the limit of {MAX_OUTPUT_ROWS:.0e}; use a larger output.dt (e.g. --set output.dt=1e-3), or pass --force")


def machine_memory() -> int:
    """The machine's physical memory in bytes (0 when the system does not say)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 0


def memory_estimate(scene: Any, system: Any) -> int:
    """Bytes a run of ``scene`` needs at most, from its size: :data:`DENSE_MATRICES` dense
    (n + m)² float64 matrices (n coordinates, m constraints and contacts) plus the history
    (rows × columns × 8 bytes, twice: the rows and the table)."""
    n = int(system.n)
    m = int(system.n_bilateral) + int(system.n_contacts)
    rows = scene.t_end / float(scene["output.dt"]) + 1
    cols = 30 + 2 * m + len(scene.get("output.observables") or [])
    return int(DENSE_MATRICES * 8 * (n + m) ** 2 + 2 * 8 * rows * cols)


def check_memory(scene: Any, system: Any) -> None:
    """Refuse, before any step, a run whose memory estimate (:func:`memory_estimate`) is over
    :data:`MEMORY_FRACTION` of the machine's memory, with both numbers and the fix."""
    need, have = memory_estimate(scene, system), machine_memory()
    if have and need > MEMORY_FRACTION * have:
        raise GuardError(
            f"scene '{scene.name}' has {system.n} coordinates: a run needs ≈ {need / 2 ** 30:.3g} GiB (dense "
            f"{system.n}² matrices and the history), more than {MEMORY_FRACTION:.0%} of this machine's "
            f"{have / 2 ** 30:.3g} GiB; use a coarser mesh or fewer modes (fewer elements, see `daebench show "
            f"{scene.name} --keys`) or a larger output.dt")


def check_observables(scene: Any, system: Any) -> list[str]:
    """The scored observables (``output.observables``) this configuration produces.

    A name the model never computes, whatever its effects, is refused (a typo); a name it
    computes only with an effect this scene turns off (``gap`` without contact) is left
    out of scoring and returned out of the list — callers report it, never silently."""
    check_start(scene, system)
    wanted = list(scene.get("output.observables") or [])
    if not wanted:
        return []
    q, v = system.initial_state()
    have = list(system.observables(0.0, q, v))
    unknown = [o for o in wanted if o not in have]
    if unknown:
        vocabulary = set(have) | _all_effects_observables(scene)
        typos = [o for o in unknown if o not in vocabulary]
        if typos:
            raise GuardError(
                f"scene key 'output.observables': '{typos[0]}' is not an observable of model '{scene.model}'"
                f"{did_you_mean(typos[0], vocabulary)} Observables: {', '.join(sorted(vocabulary))}.")
    return [o for o in wanted if o in have]


START_GAP_TOL = 1e-9   # m: a start this far inside a rigid (impact-law) contact is refused


def check_start(scene: Any, system: Any) -> None:
    """Refuse a start with a body through a surface whose contact is an impact law
    (constraint, complementarity): such a run would begin with the contact violated and
    blow up (beam-impact at θ = -30°: gap -0.5 m, 9e5 J). Continuous laws (Hertz,
    penalty) accept a penetrating start: their force is defined there.

    Raises
    ------
    GuardError
        Naming the contact, its gap and the fix.
    """
    if not getattr(system, "n_contacts", 0) or not scene.get("effects.contact", True):
        return
    law = getattr(system, "contact_law", None)
    if law is not None and law.continuous:
        return
    q, _ = system.initial_state()
    gap = [float(g) for g in system.gap(q)]
    inside = [(i, g) for i, g in enumerate(gap) if g < -START_GAP_TOL]
    if inside:
        i, g = min(inside, key=lambda x: x[1])
        raise GuardError(
            f"scene '{scene.name}' starts with contact {i} {-g:.3g} m through its surface (gap {g:.3g} m at t = 0); "
            f"a rigid contact cannot start violated. Start outside it (gap ≥ 0: change the start.* keys, "
            f"`daebench show {scene.name} --keys`), or use a continuous law (--set contact.law=hertz)")


def _all_effects_observables(scene: Any) -> set[str]:
    """What the model computes with every effect of the scene switched on."""

    effects = {k: True for k in scene.values if k.startswith("effects.")}
    try:
        system = build_system(scene.with_overrides(effects))
        q, v = system.initial_state()
        return set(system.observables(0.0, q, v))
    except Exception:  # a combination the model refuses: only what this scene produces counts
        return set()


def check_contacts_fit(scene: Any, cls: type[Integrator]) -> None:
    """An integrator that resolves contacts itself needs a scene with contacts that are left
    to it ('complementarity') or closed by the ``constraint`` law (whose restitution it
    applies); name a scene key value the scene accepts, or the scenes that offer one. Whether
    the system asks for constraints or friction is the driver's rule, applied to the built
    system (:func:`check_fits_system`)."""
    if not cls.capabilities.contacts:
        return
    law = scene.schema.get("contact.law")
    current = scene.get("contact.law")
    if current in cls.contact_laws and scene.get("effects.contact", True):
        return
    if law is not None and law.choices:
        fits = [c for c in cls.contact_laws if c in law.choices]
        if fits:
            raise IntegratorError(f"integrator '{cls.name}' resolves contacts itself; run it with "
                                  + " or ".join(f"`--set contact.law={c}`" for c in fits)
                                  + (" and `--set effects.contact=true`" if scene.get("effects.contact") is False else "")
                                  + f" (scene '{scene.name}' uses '{current}')")

    offer = []
    for name in scene_names():
        try:
            p = load_scene(name).schema.get("contact.law")
        except ParamError:  # a broken scene file offers nothing
            continue
        if p is not None and p.choices and any(c in p.choices for c in cls.contact_laws):
            offer.append(name)
    laws = " or ".join(f"'{c}'" for c in cls.contact_laws)
    hint = f"scenes that offer it: {', '.join(offer)}" if offer else "no installed scene offers it"
    raise IntegratorError(f"integrator '{cls.name}' resolves contacts itself (contact law {laws}), which "
                          f"scene '{scene.name}' (model {scene.model}) does not offer; {hint}")


def check_applicable(scene: Any, cls: type[Integrator], system: Any = None) -> None:
    """Refuse, before anything runs, an integrator that cannot run this scene: the contact
    fit (:func:`check_contacts_fit`) and the capability check the driver makes at its
    start (:func:`daebench.integrators.applicability.check_fits`: constraints are needed
    for bilateral joints, and for impact-law contacts the integrator does not resolve
    itself). Refusals an integrator makes only in its own start (e.g. a model type it
    does not support) still come at run time.

    Raises
    ------
    IntegratorError
    """
    check_contacts_fit(scene, cls)
    check_fits_system(scene, cls, system if system is not None else build_system(scene))


def check_fits_system(scene: Any, cls: type[Integrator], system: Any) -> None:
    """The capability check the driver makes at its start
    (:func:`daebench.integrators.applicability.check_fits`, the same function), made before any
    compile, its messages naming only contact laws the scene offers.

    Raises
    ------
    IntegratorError
    """
    choices = getattr(scene.schema.get("contact.law"), "choices", None)
    applicability.check_fits(cls, system, what=f"scene '{scene.name}'", laws=tuple(choices) if choices else None)


# -- the step of a conditionally stable method -----------------------------------------------------
AUTO_FRACTION = 0.9   # h = auto: this fraction of the largest stable step of linear theory at the start
TOP_MODES = 4         # the fastest modes the check computes (the limit is theirs)
_MODES: dict[str, Any] = {}   # scene hash → its fastest modes (a sweep runs one scene many times)
_PREDICTED: dict[tuple, float] = {}


def _fastest(scene: Any, system: Any) -> Any:
    lin = _MODES.get(scene.hash)
    if lin is None:
        if len(_MODES) > 32:
            _MODES.clear()
        lin = _MODES[scene.hash] = stability.linearize_system(system, top=TOP_MODES)
    return lin


def check_step(scene: Any, system: Any, integ: Integrator) -> tuple[list[str], float | None]:
    """Check the fixed step of a conditionally stable method against the scene before the
    first step (:mod:`daebench.stepping.stability`: ω_max from the assembled mass and tangent
    stiffness at the start, the method's interval); returns the warnings for the run record
    and the step the run must take instead of the integrator's (None: its own), which the
    caller hands to :meth:`~daebench.integrators.base.Integrator.with_step`.

    * A method with a strict interval Ω (central differences: hω ≤ 2; a Newmark member with
      2β < γ) beyond it — h or h_contact above Ω/ω_max — is refused (IntegratorError, with
      the limit and the fix); a default h it did not choose is replaced by h = auto.
    * ABM4-PECE (Baumgarte), which has no strict interval (its growth per step is tiny
      below hω ≈ 0.93), beyond its predicted stable step for the run's length gets a warning:
      it runs and diverges as the stability map shows (``daebench paper`` and ``compare``
      run it there on purpose and expect the diverged row).
    * ``h = auto`` takes :data:`AUTO_FRACTION` × that largest stable step and says so.

    The contact stiffness of a penalty contact is not in the start's K (no contact is
    engaged there): a step in contact may need to be smaller still."""
    model = integ.stability_model()
    if model is None or not integ.capabilities.fixed_step or integ.adaptive:
        if integ.auto_step:
            raise IntegratorError(f"h = auto takes the largest stable step of a conditionally stable method; "
                                  f"'{integ.name}' has no stability limit to take it from here: give h")
        return [], None
    strict = stability.strict_interval(model) if model.strict else 0.0
    if math.isinf(strict):   # unconditionally stable: nothing to check, no step to choose
        if integ.auto_step:
            raise IntegratorError(f"h = auto takes the largest stable step of a conditionally stable method; "
                                  f"'{integ.name}' ({model.name}) is unconditionally stable: give h")
        return [], None
    lin = _fastest(scene, system)
    w = float(lin.omega.max(initial=0.0))
    if w <= 0.0:
        if integ.auto_step:
            raise IntegratorError(f"h = auto: '{scene.name}' has no oscillating mode at its start to bound the "
                                  f"step of {model.name} (ω_max = 0); give h")
        return [], None
    h, hc = float(integ.settings["h"]), float(integ.settings.get("h_contact", 0.0) or 0.0)
    where = f"{scene.name} (ω_max = {w:.4g} rad/s from the assembled mass and stiffness at the start)"
    hard = model.strict
    if hard:
        limit, rule = strict / w, f"h ω_max ≤ {strict:.4g}"
    else:
        key = (scene.hash, model, scene.t_end)
        if key not in _PREDICTED:
            _PREDICTED[key] = stability.predict(model, lin, scene.t_end, DIVERGENCE_ENERGY)["h_pred"]
        limit = _PREDICTED[key]
        rule = f"its interval over this run's {scene.t_end:g} s, h ω_max ≤ {limit * w:.3g} (daebench stability)"
    if integ.auto_step or (hard and integ.default_step and max(h, hc) > limit):
        chosen = AUTO_FRACTION * limit
        how = "h = auto" if integ.auto_step else f"the default h = {h:g} s is beyond it"
        return [f"{how}: took h = {chosen:.4g} s = {AUTO_FRACTION:g} × the largest stable step of {model.name} on "
                f"{where}, {rule}"], chosen
    over = [f"{k} = {x:g} s" for k, x in (("h", h), ("h_contact", hc)) if x > limit]
    if not over:
        return [], None
    text = (f"{' and '.join(over)} beyond the stable step of {model.name} on {where}: {rule} gives "
            f"h ≤ {limit:.4g} s")
    if hard:
        raise IntegratorError(f"{text}; give --opt h={_floor2(limit):g} (or smaller), or --opt h=auto for "
                              f"{AUTO_FRACTION:g} × the limit")
    return [f"{text}: the run is expected to diverge (--opt h=auto takes {AUTO_FRACTION:g} × the limit)"], None


def _floor2(x: float) -> float:
    """x rounded down to two significant digits (a step to suggest that is below the limit)."""
    e = math.floor(math.log10(x)) - 1
    return math.floor(x / 10 ** e) * 10 ** e
