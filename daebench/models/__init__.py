"""Model registry: models are found through the entry-point group ``daebench.models``
(name → module), as integrators are through ``daebench.integrators``; daebench's own
register in its pyproject.toml, a plugin package in its own. Each model module defines

* ``DESCRIPTION`` — one line for `daebench list`;
* ``SCHEMA`` — ``dict[str, Param]`` of the scene keys it understands (dotted names);
* ``build(scene) -> MechanicalSystem`` — assemble only the effects the scene turns on;
* optionally ``OBSERVABLES`` — its history columns' meaning for the scorer (units, short
  names, derivatives, points; :mod:`daebench.core.observables`), and on the system an
  ``exact_observables(t)`` method when the model has an exact solution (runs are then
  scored against it: :mod:`daebench.harness.scoring`);
* optionally ``check_scene(scene)`` — cross-key validation raising ``SceneError``.

Its system gives its physics as compiled kernels (:mod:`daebench.core.kernels`, subclass
:class:`daebench.core.system.KernelSystem`) or as plain Python methods.

May import: :mod:`daebench.core` and :mod:`daebench.stepping` (a model may own a
model-specific stepper part, as the planar bodies' interactive-mode statics).
"""

from __future__ import annotations

import importlib
from importlib.metadata import entry_points
from types import ModuleType
from typing import Any

from daebench.core import entry_names
from daebench.core.kernels import friction_coefficients
from daebench.core.params import did_you_mean
from daebench.core.scene import SceneError

ENTRY_POINT_GROUP = "daebench.models"


#: name → who provides it (a distribution, or "registered (module)")
PROVIDERS: dict[str, str] = {}
_REGISTERED: dict[str, ModuleType] = {}   # models registered in this process (register_model)


#: why installed models were refused (a name a built-in or another plugin provides)
REFUSED: list[str] = []


def _scan() -> dict[str, str]:
    """name → module of every installed model, one per name by the registries' one rule
    (:mod:`daebench.core.entry_names`); the refusals in :data:`REFUSED`."""
    kept, refused = entry_names.one_per_name(
        entry_points(group=ENTRY_POINT_GROUP), "model",
        lambda ep: f"{_provider(entry_names.distribution(ep))} ({ep.value})", "rename its entry point")
    REFUSED[:] = refused
    for name in [n for n, who in PROVIDERS.items() if not who.startswith("registered")]:
        del PROVIDERS[name]      # a rescan replaces what the last one found
    PROVIDERS.update({name: entry_names.distribution(ep) for name, ep in kept.items()})
    return {name: ep.value for name, ep in sorted(kept.items())}


def get_model(name: str) -> ModuleType:
    if name in _REGISTERED:
        return _REGISTERED[name]
    if name not in MODELS:
        raise KeyError(f"unknown model '{name}'{did_you_mean(name, MODELS)} Models: {', '.join(MODELS)}")
    return importlib.import_module(MODELS[name])


def register_model(name: str, module: Any) -> Any:
    """Register a model defined in this process (a notebook's module or namespace with
    ``DESCRIPTION``, ``SCHEMA`` and ``build``, as this package's docstring lists) under
    ``name``: a scene file naming it (``model = "name"``) then loads and runs. Registering
    again from the same module replaces it.

    Raises
    ------
    SceneError
        Something it must define is missing, or the name is provided by a built-in, an
        installed plugin or another registered model (both providers named).
    """
    missing = [k for k in ("DESCRIPTION", "SCHEMA", "build") if not hasattr(module, k)]
    if missing or not callable(getattr(module, "build", None)) or not isinstance(getattr(module, "SCHEMA", None), dict):
        raise SceneError(f"cannot register model '{name}': {module!r} needs DESCRIPTION, SCHEMA (a dict of Param) and "
                         f"build(scene); missing or wrong: {', '.join(missing) or 'SCHEMA or build'}")
    where = f"registered ({getattr(module, '__name__', type(module).__name__)})"
    if not isinstance(name, str) or not name.strip():
        raise SceneError(f"a model is registered under a name, e.g. register_model('mymodel', module); got {name!r}")
    if name in MODELS and PROVIDERS.get(name) != where:
        raise SceneError(f"model name '{name}' is taken: {_provider(PROVIDERS.get(name, '?'))} provides it, so the "
                         f"model {where.removeprefix('registered ')} cannot take it; register it under another name")
    _REGISTERED[name] = module
    MODELS[name] = f"<{where}>"
    PROVIDERS[name] = where
    return module


def unregister_model(name: str) -> None:
    """Forget the model registered under ``name`` in this process (entry points stay)."""
    if _REGISTERED.pop(name, None) is not None:
        MODELS.pop(name, None)
        PROVIDERS.pop(name, None)


def _provider(dist: str) -> str:
    if dist == entry_names.BUILTIN:
        return "daebench's built-in model"
    if dist.startswith("registered"):
        return f"the model {dist.removeprefix('registered ')} registered in this process"
    return f"the installed distribution {dist}"


MODELS: dict[str, str] = _scan()


def build_system(scene):
    """The MechanicalSystem a scene describes (friction asked of it: :func:`check_friction_kernel`)."""
    system = get_model(scene.model).build(scene)
    if scene.get("effects.contact", True):
        check_friction_kernel(system, float(scene.get("contact.friction", 0.0) or 0.0), f"model '{scene.model}'")
    return system


def check_friction_kernel(system, mu: float, what: str = "this model") -> None:
    """Refuse Coulomb friction μ > 0 asked of a system with contacts whose kernels give no
    friction coefficient (no ``tangent`` kernel, :mod:`daebench.core.kernels`): the run
    would be silently frictionless."""
    if mu > 0.0 and system.n_contacts and not (friction_coefficients(
            system.kernel_handle(), system.n_contacts, *system.initial_state()) > 0.0).any():
        raise SceneError(f"contact.friction = {mu:g} is asked of {what}, whose contacts have no friction: it "
                         f"registers no 'tangent' kernel (daebench.core.kernels); use `--set contact.friction=0` "
                         f"or a model with one (rigid2d, cradle)")
