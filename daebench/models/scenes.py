"""Scenes read against the model registry: a scene file names its model, whose declared
settings (``SCHEMA``) validate every key and whose ``check_scene`` runs the cross-key
checks. The scene value itself (:class:`daebench.core.scene.Scene`) knows no model."""

from __future__ import annotations

import os
from typing import Any, Iterable

from daebench.core import comparison
from daebench.core.params import Param, did_you_mean
from daebench.core.scene import COMMON_SCHEMA, Scene, SceneError, flatten, read_toml, resolve_path, validate_key
from daebench.models import MODELS, get_model


def model_schema(model: str) -> dict[str, Param]:
    return {**COMMON_SCHEMA, **get_model(model).SCHEMA}


def load_scene(name_or_path: str | os.PathLike, overrides: Iterable[str] | dict[str, Any] = ()) -> Scene:
    """Load, validate and apply overrides.

    Parameters
    ----------
    name_or_path : a case name from ``cases/`` (``"beam-impact"``, case-insensitive) or a
        path to a TOML scene file
    overrides : ``["key=value", ...]`` as on the command line, or ``{key: value}``

    Raises
    ------
    SceneError
        On any problem, with a message that names the key and the fix.
    """
    path = resolve_path(name_or_path)
    raw = read_toml(path)  # a regular UTF-8 file of at most 1 MB; refusals name the fix
    return scene_from_dict(raw, name=path.stem, source=str(path)).with_overrides(overrides)


def scene_from_dict(raw: dict[str, Any], name: str = "scene", source: str = "") -> Scene:
    """A validated scene from a scene file's TOML: the physics keys as values, the
    ``[compare]`` table apart (:mod:`daebench.core.comparison`, outside the hash)."""
    raw = dict(raw)
    cmp = comparison.parse(raw.pop("compare", None), source or name)
    flat = flatten(raw)
    model = flat.get("model")
    if model is None:
        raise SceneError(f"{source or name}: the scene must name its model, e.g. model = \"hub-beam\"")
    if not isinstance(model, str):
        raise SceneError(f"{source or name}: 'model' must be one model name (a string), e.g. model = \"hub-beam\"; "
                         f"got {model!r}")
    if model not in MODELS:
        raise SceneError(
            f"{source or name}: unknown model '{model}'{did_you_mean(str(model), MODELS)} "
            f"Models: {', '.join(MODELS)}."
        )
    schema = model_schema(model)
    values = {k: p.default for k, p in schema.items()}
    for key, v in flat.items():
        values[key] = validate_key(key, v, schema, source or name, strict=True)
    values["name"] = values.get("name") or name
    check = getattr(get_model(model), "check_scene", None)
    return Scene(values["name"], model, values, schema, source, check, dict(values) if source else None,
                 cmp).checked()
