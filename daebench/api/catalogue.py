"""What there is: the named scenes, the registered integrators, and one of either
described (`daebench list`, `daebench show`); a class or model of this process registered
(:func:`register`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

import pandas as pd

from daebench.core.params import Param, ParamError, did_you_mean
from daebench.core.scene import Scene, SceneError, UnknownScene, list_scenes, scene_names
from daebench.harness.scoring import pipeline
from daebench.integrators import base
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import Capabilities, IntegratorError
from daebench.models import REFUSED as MODEL_REFUSALS, build_system, register_model
from daebench.models.scenes import load_scene as _load_scene

SceneLike = str | Path | Scene


def load_scene(scene: SceneLike, overrides: Iterable[str] | dict[str, Any] | None = None) -> Scene:
    """A validated scene: a case name (``"beam-impact"``), a path to a TOML file, or a
    :class:`~daebench.core.scene.Scene`, with ``overrides`` ({key: value} or ["key=value"])."""
    if isinstance(scene, Scene):
        return scene.with_overrides(overrides) if overrides else scene
    return _load_scene(scene, overrides or ())


@dataclass(frozen=True)
class IntegratorInfo:
    """What an integrator declares: settings (type, default, range, meaning) and capabilities."""

    name: str
    description: str
    distribution: str
    capabilities: Capabilities | None
    settings: tuple[Param, ...] = ()
    error: str = ""          # why a plugin could not be loaded (then capabilities is None)

    def settings_table(self) -> pd.DataFrame:
        """One row per setting: name, type/range, default, unit-bearing meaning."""
        return pd.DataFrame([{"setting": p.name, "type / range": p.describe(), "default": p.default,
                              "meaning": p.doc} for p in self.settings])


def integrator_infos() -> dict[str, IntegratorInfo]:
    """Every registered integrator (built-in and plugins), by name."""
    out = {}
    for name, reg in integrator_registry.registry().items():
        cls = reg.cls
        out[name] = IntegratorInfo(name, cls.description if cls else "", reg.distribution,
                                   cls.capabilities if cls else None, tuple(cls.settings_spec) if cls else (),
                                   reg.error)
    return out


def register(obj: Any, name: str | None = None) -> Any:
    """Register an integrator class (a subclass of
    :class:`daebench.integrators.base.Integrator`, under its ``name``) or a model (a module
    or namespace with ``DESCRIPTION``, ``SCHEMA`` and ``build``, under ``name``) defined in
    this process — a notebook's, a script's — so that it runs like an installed plugin:
    ``daebench.run(scene, "myint")``, ``bench``, ``compare``, ``survey``, ``verify``. One call;
    usable as a class decorator (``@daebench.register``). Registering the same class again (a
    notebook cell run again) replaces it.

    Raises
    ------
    ParamError
        The class breaks the contract's declarations (the message lists what), or the name
        is taken by a built-in, an installed plugin or another registered class (both
        providers named).
    """
    if isinstance(obj, type) and issubclass(obj, base.Integrator):
        if name is not None and name != obj.name:
            raise IntegratorError(f"an integrator registers under its class attribute name ('{obj.name}'), not "
                                  f"'{name}'; set name = '{name}' in the class")
        return integrator_registry.register(obj)
    if hasattr(obj, "build") and hasattr(obj, "SCHEMA"):
        return register_model(name if name is not None else getattr(obj, "NAME", None), obj)
    raise ParamError(f"register() takes an Integrator subclass or a model (a module with DESCRIPTION, SCHEMA and "
                     f"build); got {obj!r}")


def integrator_refusals() -> list[str]:
    """Installed integrator plugins refused because a built-in or another plugin provides
    their name (:mod:`daebench.core.entry_names`, the rule models follow too)."""
    return integrator_registry.refusals()


def model_refusals() -> list[str]:
    """Installed model plugins refused because a built-in or another plugin provides their name."""
    return list(MODEL_REFUSALS)


def integrator_info(name: str) -> IntegratorInfo:
    """One integrator's declaration; ``name`` is case-insensitive (did-you-mean on a typo)."""
    return integrator_infos()[integrator_registry.resolve_name(name)]


def cases() -> pd.DataFrame:
    """The named scenes (``cases/``): name, model and description."""
    rows = []
    for name, desc in list_scenes():
        try:
            model = _load_scene(name).model
        except ParamError as exc:  # one broken scene file is listed as such; the others are unaffected
            model, desc = "?", desc if desc.startswith("cannot be read") else f"cannot be loaded: {exc}"
        rows.append({"case": name, "model": model, "description": desc})
    return pd.DataFrame(rows)


@dataclass(frozen=True)
class SceneInfo:
    """A scene as `daebench show` describes it: the scene, its size once built (``n``
    coordinates, bilateral constraints, contact points, contact law), or why it cannot be
    built (``error``)."""

    scene: Scene
    n: int = 0
    n_bilateral: int = 0
    n_contacts: int = 0
    contact_law: str = ""
    error: str = ""
    #: the history's observable columns: (name, unit, meaning), as another code's file names them
    observables: tuple[tuple[str, str, str], ...] = ()


def show(name: str, overrides: Iterable[str] | dict[str, Any] | None = None,
         keys: bool = False) -> IntegratorInfo | SceneInfo:
    """``name`` described: an integrator's declaration, or a scene with its size (a name
    that is both, or given with ``overrides`` or ``keys``, is the scene).

    Raises
    ------
    ParamError
        Neither an integrator nor a scene (with the closest names), or a bad override.
    """
    try:
        integrator_registry.resolve_name(name)
        is_integrator = not overrides and not keys and name.lower() not in {n.lower() for n in scene_names()}
    except IntegratorError:
        is_integrator = False
    if is_integrator:
        return integrator_info(name)      # a plugin that cannot be loaded: capabilities None, its error
    try:
        sc = load_scene(name, overrides)
    except UnknownScene:  # not 'unknown scene key' of an override
        known = list(integrator_infos()) + scene_names()
        raise SceneError(f"'{name}' is neither an integrator nor a scene{did_you_mean(name.lower(), known)} "
                         f"Integrators and cases: `daebench list`.") from None
    try:
        system = build_system(sc)
    except ParamError as exc:
        return SceneInfo(sc, error=str(exc))
    q0, v0 = system.initial_state()
    declared = pipeline.declared(sc.model)
    obs = tuple((c, declared.get(c).unit, declared.get(c).label or c) for c in system.observables(0.0, q0, v0))
    return SceneInfo(sc, system.n, system.n_bilateral, system.n_contacts,
                     system.contact_law.name if system.contact_law else "", observables=obs)
