"""The integrator registry: the ``daebench.integrators`` entry points (daebench's own in its
pyproject.toml, a plugin package's in its own) and the classes registered in this process
(:func:`register`), one per name by the registries' one rule
(:mod:`daebench.core.entry_names`); a plugin that fails to load or breaks the contract's
declarations (:func:`daebench.integrators.base.declaration_problems`) is listed with its
error instead of breaking the others."""

from __future__ import annotations

import sys
from dataclasses import dataclass, replace
from importlib.metadata import entry_points
from typing import Any

from daebench.core import entry_names
from daebench.core.params import did_you_mean
from daebench.integrators.base import Integrator, IntegratorError, declaration_problems

ENTRY_POINT_GROUP = "daebench.integrators"


@dataclass(frozen=True)
class Registered:
    name: str
    cls: type[Integrator] | None
    distribution: str
    error: str = ""  # why the entry point could not be loaded (cls is None then)
    source: str = ""  # where it comes from: the entry point's value, or module.Class of a registered class

    @property
    def provider(self) -> str:
        """Who provides it, for messages naming two providers of one name."""
        if self.distribution == entry_names.BUILTIN:
            return f"daebench's built-in ({self.source})" if self.source else "daebench's built-in"
        if self.distribution.startswith(REGISTERED):
            return f"the class {self.source} registered in this process"
        return f"the installed distribution {self.distribution} ({self.source})"


REGISTERED = "registered"   # the distribution of a class registered with :func:`register`
_REGISTRY_CACHE: tuple[tuple[str, ...], dict[str, Registered], tuple[str, ...]] | None = None
_IN_PROCESS: dict[str, Registered] = {}   # classes registered with register(), by name


def _scan_entry_points() -> tuple[dict[str, Registered], list[str]]:
    """The entry points' integrators, and the refusals of those that shadow another."""
    found: dict[str, Registered] = {}

    def listed(ep: Any) -> Registered:
        return Registered(ep.name, None, entry_names.distribution(ep), source=ep.value)

    kept, refused = entry_names.one_per_name(entry_points(group=ENTRY_POINT_GROUP), "integrator",
                                             lambda ep: listed(ep).provider,
                                             "rename its entry point and its class's name")
    for ep in kept.values():
        new = listed(ep)
        try:
            cls = ep.load()
        except Exception as exc:  # a broken plugin must not take the others down
            found[ep.name] = replace(new, error=f"{type(exc).__name__}: {exc}")
            continue
        problems = declaration_problems(cls, ep.name)
        found[ep.name] = replace(new, error=f"{ep.value}: {'; '.join(problems)}") if problems \
            else replace(new, cls=cls)
    return found, refused


def registry(refresh: bool = False) -> dict[str, Registered]:
    """All integrators: the ``daebench.integrators`` entry points and the classes
    registered in this process (:func:`register`). A plugin may not shadow a built-in (one
    provided by daebench) nor another plugin (:func:`refusals` says which were refused). A
    plugin that fails to import, or whose class breaks the contract's declarations
    (:func:`declaration_problems`), is listed with its error instead of breaking the registry.

    Scanning the installed distributions' entry points took ~12 ms — most of a short
    run's fixed cost in a sweep — so the result is kept for the process while
    ``sys.path`` is unchanged; ``refresh=True`` rescans (a plugin installed into an
    already-listed directory while the process runs)."""
    global _REGISTRY_CACHE
    key = tuple(sys.path)
    if refresh or _REGISTRY_CACHE is None or _REGISTRY_CACHE[0] != key:
        found, refused = _scan_entry_points()
        _REGISTRY_CACHE = (key, found, tuple(refused))
    return dict(sorted({**_REGISTRY_CACHE[1], **_IN_PROCESS}.items()))


def refusals() -> list[str]:
    """Why installed plugins were refused (a name a built-in or another plugin provides)."""
    registry()
    return list(_REGISTRY_CACHE[2])


def register(cls: type[Integrator]) -> type[Integrator]:
    """Register integrator class ``cls`` in this process under ``cls.name`` (a notebook's or a
    script's class; ``daebench.register``): it then runs like an installed plugin in `run`,
    `bench`, `compare`, `survey`, `verify` and the report (sweeps' worker processes are forked
    from this one and know it; a Dask cluster's do not). Usable as a class decorator.

    Registering a class again under its name (the same module and class name: a notebook
    cell run again) replaces it.

    Raises
    ------
    IntegratorError
        A class that breaks the contract's declarations (:func:`declaration_problems`), or a
        name that a built-in, an installed plugin or another registered class provides
        (both providers named).
    """
    problems = declaration_problems(cls)
    if problems:
        raise IntegratorError(f"cannot register {getattr(cls, '__qualname__', cls)!r}: " + "; ".join(problems))
    new = Registered(cls.name, cls, f"{REGISTERED} ({cls.__module__})", source=f"{cls.__module__}.{cls.__qualname__}")
    taken = next((r for n, r in registry().items() if n.lower() == cls.name.lower()), None)
    if taken is not None and taken.source != new.source:
        raise IntegratorError(f"integrator name '{cls.name}' is taken: {taken.provider} provides it, so {new.provider} "
                              f"cannot take it; give the class another name (class attribute `name`)")
    _IN_PROCESS[cls.name] = new
    return cls


def unregister(name: str) -> None:
    """Forget the class registered under ``name`` in this process (entry points stay)."""
    _IN_PROCESS.pop(name, None)


def resolve_name(name: str) -> str:
    """The registered name of an integrator, matched case-insensitively (the one lookup).

    Raises
    ------
    IntegratorError
        For an unknown name, with the closest registered one.
    """
    reg = registry()
    if not isinstance(name, str) or not name.strip():
        raise IntegratorError(f"an integrator name is needed, e.g. hht; available: {', '.join(reg)}")
    if name in reg:
        return name
    lower = {n.lower(): n for n in reg}
    if name.strip().lower() in lower:
        return lower[name.strip().lower()]
    raise IntegratorError(f"unknown integrator '{name}'{did_you_mean(name.lower(), reg)} "
                          f"Available: {', '.join(reg)} (see `daebench list`).")


def get_integrator(name: str) -> type[Integrator]:
    """The class registered under ``name`` (:func:`resolve_name`); refused when it cannot be loaded."""
    name = resolve_name(name)
    reg = registry()
    if reg[name].cls is None:
        raise IntegratorError(f"integrator '{name}' (from {reg[name].distribution}) cannot be loaded: "
                              f"{reg[name].error}")
    return reg[name].cls
