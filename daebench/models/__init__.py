"""Model registry. Each model module defines

* ``DESCRIPTION`` — one line for `daebench list`;
* ``SCHEMA`` — ``dict[str, Param]`` of the scene keys it understands (dotted names);
* ``build(scene) -> MechanicalSystem`` — assemble only the effects the scene turns on;
* optionally ``check_scene(scene)`` — cross-key validation raising ``SceneError``.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from daebench.params import did_you_mean

MODELS: dict[str, str] = {
    "hub-beam": "daebench.models.hubbeam",
    "pendulum": "daebench.models.pendulum",
    "andrews": "daebench.models.andrews",
    "chain": "daebench.models.chain",
}


def get_model(name: str) -> ModuleType:
    if name not in MODELS:
        raise KeyError(f"unknown model '{name}'{did_you_mean(name, MODELS)} Models: {', '.join(MODELS)}")
    return importlib.import_module(MODELS[name])


def build_system(scene):
    """The MechanicalSystem a scene describes."""
    return get_model(scene.model).build(scene)
