"""What `daebench verify` measures on (:mod:`daebench.workflows.verify`): its result type,
the smooth cases with exact solutions and how one run on them is made and fitted.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from daebench.core.params import ParamError
from daebench.core.scene import Scene
from daebench.harness.running import checks
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.models.scenes import load_scene
from daebench.workflows.run import errors


@dataclass(frozen=True)
class Check:
    """One property: ``status`` 'pass', 'fail' or 'n/a', the line that says what was
    measured against what was declared, and the numbers."""

    property: str
    status: str
    text: str
    numbers: dict[str, Any] = field(default_factory=dict)

    @property
    def line(self) -> str:
        return f"{self.status.upper():4s}  {self.property:8s}  {self.text}"


def scene_of(name: str, overrides: dict[str, Any] | None = None) -> Scene:
    sc = load_scene(name)
    return sc.with_overrides(overrides) if overrides else sc


def own_law(cls: type) -> str:
    """The contact law a contact-resolving integrator is given: the constraint law (with its
    restitution) when it takes that, else its own ('complementarity'); the driver's otherwise."""
    return "constraint" if not cls.capabilities.contacts or "constraint" in cls.contact_laws else "complementarity"


def smooth_cases(cls: type) -> tuple[tuple[str, str, dict[str, Any], str, str], ...]:
    """Smooth cases with exact solutions, in order of preference: (label, scene, overrides,
    error column, unit) — the pendulum (index 3); a harmonic oscillator (spring-wall without
    its wall) for ODE-only methods; the same with the wall out of reach, for methods that
    resolve contacts themselves (they refuse a system without contacts)."""
    return (("pendulum (index 3, exact θ(t))", "pendulum", {}, "err_pos_max", "m"),
            ("harmonic oscillator (spring-wall without its wall)", "spring-wall",
             {"effects.contact": False, "t_end": 1.0}, "err_x_max", "m"),
            ("harmonic oscillator (spring-wall, its wall out of reach)", "spring-wall",
             {"contact.law": own_law(cls), "contact.wall": -1.0, "t_end": 1.0}, "err_x_max", "m"))


def applies(scene: Scene, cls: type) -> str:
    """'' when ``cls`` may run ``scene``, else the refusal."""
    try:
        checks.check_applicable(scene, cls)
    except ParamError as exc:
        return str(exc)
    return ""


def smooth_case(cls: type) -> tuple[tuple, Scene] | tuple[None, str]:
    """The first of :func:`smooth_cases` that ``cls`` runs, or (None, why none)."""
    why = []
    for case in smooth_cases(cls):
        sc = scene_of(case[1], case[2])
        refusal = applies(sc, cls)
        if not refusal:
            return case, sc
        why.append(f"{case[1]}: {refusal}")
    return None, "no smooth case with an exact solution it runs (" + " | ".join(why) + ")"


def fixed_settings(cls: type, settings: dict[str, Any], h: float) -> dict[str, Any]:
    """``settings`` at the fixed step h (adaptivity off where the integrator has it)."""
    names = {s.name for s in cls.settings_spec}
    out = {**settings, "h": h}
    if "adaptive" in names:
        out["adaptive"] = False
    return out


def run_exact(scene: Scene, name: str, settings: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
    """One driver run: its result and its errors against the exact solution."""
    _, res = run_scene(scene, make_integrator(name, settings), write=False, force=True)
    return res, (errors(scene, res.history, res.impacts) if len(res.history) else {})


def slope(x: Sequence[float], y: Sequence[float]) -> float:
    return float(np.polyfit(np.log(np.asarray(x, float)), np.log(np.asarray(y, float)), 1)[0])


def fmt_numbers(xs: Sequence[float]) -> str:
    return ", ".join(f"{x:.3g}" for x in xs)
