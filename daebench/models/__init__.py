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

from daebench.core.params import did_you_mean

ENTRY_POINT_GROUP = "daebench.models"


def _scan() -> dict[str, str]:
    """name → module of every registered model; a plugin may not shadow a built-in."""
    found: dict[str, tuple[str, str]] = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        dist = ep.dist.name if ep.dist is not None else "?"
        if ep.name in found and found[ep.name][1] == "daebench":
            continue
        found[ep.name] = (ep.value, dist)
    return {name: value for name, (value, _) in sorted(found.items())}


MODELS: dict[str, str] = _scan()


def get_model(name: str) -> ModuleType:
    if name not in MODELS:
        raise KeyError(f"unknown model '{name}'{did_you_mean(name, MODELS)} Models: {', '.join(MODELS)}")
    return importlib.import_module(MODELS[name])


def build_system(scene):
    """The MechanicalSystem a scene describes."""
    return get_model(scene.model).build(scene)
