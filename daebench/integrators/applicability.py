"""Whether an integrator can run a system, decided once: what the system asks of it
(constraints for joints and for impact-law contacts it does not resolve itself, Coulomb
friction from its contacts' kernels, a contact law) against what the integrator declares
(:class:`~daebench.integrators.base.Capabilities`, ``contact_laws``, ``applies_friction``).
The driver's start and the harness's pre-run check both call :func:`check_fits`; every
refusal is an :class:`~daebench.integrators.base.IntegratorError` saying what to do."""

from __future__ import annotations

from typing import Any

from daebench.core.kernels import friction_coefficients
from daebench.integrators.base import Integrator, IntegratorError
from daebench.integrators.registry import registry


def applies_friction(cls: type[Integrator], contact_law: str | None) -> bool:
    """Whether ``cls`` applies Coulomb friction under ``contact_law``: it declares ``capabilities.friction``, or
    the law is compliant (hertz, penalty: the phase's regularised Coulomb force) and the driver hands it over."""
    return cls.capabilities.friction or (contact_law in ("hertz", "penalty") and not cls.capabilities.contacts)


def friction_refusal(name: str, what: str) -> str:
    """The message refusing integrator ``name`` on a case with friction (names those that can)."""
    can = [r.name for r in registry().values() if r.cls is not None and r.cls.capabilities.friction]
    return (f"{what} has Coulomb friction (contact.friction > 0), which integrator '{name}' does not apply; "
            f"use one that does ({', '.join(can) or 'none is installed'}), a compliant law with regularised "
            f"friction where the case offers one (`--set contact.law=penalty` or `hertz`), or `--set contact.friction=0`.")


def _laws_hint(laws: tuple[str, ...] | None, wanted: tuple[str, ...]) -> str:
    """`` (`--set contact.law=a` or `b`)`` for the laws of ``wanted`` the case offers (all of
    them when its laws are not known); '' when it offers none of them."""
    fit = [w for w in wanted if laws is None or w in laws]
    if not fit:
        return ""
    return f" (`--set contact.law={fit[0]}`" + "".join(f" or `{w}`" for w in fit[1:]) + ")"


def check_fits(cls: type[Integrator], system: Any, adaptive: bool = False, what: str = "this case",
               laws: tuple[str, ...] | None = None) -> None:
    """:func:`check_capabilities` with what ``system`` asks of an integrator: constraints
    for bilateral joints, and for contacts under an impact law (not a continuous one) that
    the integrator does not resolve itself; Coulomb friction where a contact's μ (its
    ``tangent`` kernel at the start) is positive. The driver's start and the harness's
    pre-run check both call this, so they cannot disagree."""
    law = system.contact_law
    needs_constraints = system.n_bilateral > 0 or (law is not None and not law.continuous and system.n_contacts > 0
                                                   and not cls.capabilities.contacts)
    friction = bool(system.n_contacts) and bool((friction_coefficients(
        system.kernel_handle(), system.n_contacts, *system.initial_state()) > 0.0).any())
    check_capabilities(cls, needs_constraints, adaptive, what, contacts_by_integrator=system.contacts_by_integrator,
                       contact_law=None if law is None else law.name, n_contacts=system.n_contacts,
                       friction=friction, laws=laws)


def check_capabilities(cls: type[Integrator], problem_needs_constraints: bool,
                       adaptive: bool = False, what: str = "this case",
                       contacts_by_integrator: bool = False, contact_law: str | None = None,
                       n_contacts: int = 0, friction: bool = False, laws: tuple[str, ...] | None = None) -> None:
    """Refuse a mismatch before the first step, with a message that says what to do.

    ``contacts_by_integrator``: the system leaves its contacts to the integrator (no
    law); ``contact_law``: the name of its law otherwise. An integrator that resolves
    contacts itself takes over contacts with no law or the ``constraint`` law (whose
    restitution it applies); a continuous law would count the contact twice.
    ``friction``: the system's contacts have Coulomb coefficients μ > 0 (:func:`applies_friction`);
    ``laws``: the contact laws the case offers (its ``contact.law`` choices; None: not known),
    so that a message suggests only laws the case accepts."""
    cap = cls.capabilities
    if friction and not applies_friction(cls, contact_law):
        raise IntegratorError(friction_refusal(cls.name, what))
    if contacts_by_integrator and not cap.contacts:
        raise IntegratorError(
            f"{what} leaves its contacts to the integrator (contact law 'complementarity'), but "
            f"'{cls.name}' does not resolve contacts; use an integrator that does (`daebench list`: "
            f"'resolves contacts'), or pick a contact law the driver handles"
            + _laws_hint(laws, ("hertz", "penalty", "constraint")) + "."
        )
    if cap.contacts and not contacts_by_integrator and (n_contacts == 0 or contact_law is None):
        raise IntegratorError(
            f"integrator '{cls.name}' resolves contacts itself and needs a case with contacts "
            f"(`--set effects.contact=true`); {what} has none."
        )
    if cap.contacts and (contact_law or "complementarity") not in cls.contact_laws:
        raise IntegratorError(
            f"integrator '{cls.name}' resolves contacts itself and takes over contacts with the law "
            + " or ".join(f"'{c}'" for c in cls.contact_laws) + f"; {what} has '{contact_law}'"
            + (" (a continuous law would count the contact twice)" if contact_law not in ("constraint", None) else "")
            + ". Choose one with `--set contact.law=...`."
        )
    if problem_needs_constraints and not cap.constraints:
        raise IntegratorError(
            f"integrator '{cls.name}' integrates ODEs only, but {what} has constraints "
            f"(bilateral joints or contact law 'constraint'). Use an integrator that "
            f"handles constraints (hht, baumgarte, newmark, ida)"
            + (f", or for contact choose a continuous law{_laws_hint(laws, ('hertz', 'penalty'))}"
               if laws is None or {"hertz", "penalty"} & set(laws) else
               f"; {what} offers no continuous contact law (its laws: {', '.join(laws)})") + "."
        )
    if adaptive and not cap.adaptive:
        raise IntegratorError(
            f"integrator '{cls.name}' has no adaptive step-size control; "
            f"drop `--opt adaptive=true` and give a fixed step with `--opt h=...`."
        )
