"""A sweep's plan: the Cartesian product of integrators × grid × steps or tolerances
(:func:`plan_sweep`), one :class:`RunSpec` per run, every run checked (settings, grid
keys, observables, contacts, size) before anything runs."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any, Sequence

from daebench.core.params import ParamError, did_you_mean
from daebench.core.scene import Scene
from daebench.harness.running import checks
from daebench.harness.sweeps.options import SweepError
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import IntegratorError
from daebench.models import build_system

TOL_ATOL_RATIO = 1e-2   # --tols t sets rtol = t, atol = t · this


@dataclass
class RunSpec:
    """One run of a sweep: which integrator with which settings on which scene variant."""

    index: int
    integrator: str
    options: dict[str, Any]
    scene_overrides: dict[str, Any]
    varied: dict[str, Any]                     # the keys this sweep varies, for labels/columns
    skip: str = ""                             # non-empty: do not run, this is the reason

    @property
    def label(self) -> str:
        parts = [f"{k}={_fmt(v)}" for k, v in self.varied.items() if k not in ("h", "rtol", "atol", "tol")]
        mode = " adaptive" if self.options.get("adaptive") else ""  # never one line with fixed steps
        return self.integrator + mode + (f" ({', '.join(parts)})" if parts else "")


def _fmt(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _integrator_classes(names: Sequence[str]) -> dict[str, type]:
    out = {}
    for n in names:
        try:
            name = integrator_registry.resolve_name(n)
            out[name] = integrator_registry.get_integrator(name)
        except IntegratorError as exc:
            raise SweepError(f"{exc} (in --integrators)") from None
    if len(out) != len(names):
        raise SweepError(f"an integrator is named twice in --integrators: {', '.join(names)}")
    return out


def classify_grid(scene: Scene, classes: dict[str, type], grid: dict[str, Sequence[Any]]
                  ) -> tuple[dict[str, list], dict[str, list]]:
    """Split grid keys into integrator settings (checked first) and scene keys.

    Raises
    ------
    SweepError
        For a key that is neither, with the closest valid name.
    """
    settings = {s.name for c in classes.values() for s in c.settings_spec}
    integ_keys, scene_keys = {}, {}
    for k, vals in grid.items():
        vals = list(vals)
        if not vals:
            raise SweepError(f"grid key '{k}' has no values")
        if k in settings:
            integ_keys[k] = vals
        elif k in scene.schema:
            scene_keys[k] = vals
        else:
            raise SweepError(
                f"unknown grid key '{k}': not a setting of {', '.join(classes)} nor a key of scene "
                f"'{scene.name}'{did_you_mean(k, list(settings) + list(scene.schema))} "
                f"(settings: `daebench list`; scene keys: `daebench show {scene.name} --keys`)")
    return integ_keys, scene_keys


def plan_sweep(scene: Scene, integrators: Sequence[str], grid: dict[str, Sequence[Any]] | None = None,
               steps: Sequence[float] | None = None, tols: Sequence[float] | None = None,
               options: dict[str, Any] | None = None, force: bool = False) -> list[RunSpec]:
    """Every run of the sweep, validated before anything runs.

    Integrator settings in ``grid`` vary only for integrators that have them; scene
    keys vary for all. ``steps`` sets ``h``; ``tols`` sets rtol = tol, atol =
    TOL_ATOL_RATIO·tol and adaptive = true (a non-adaptive integrator gets a row that
    says it was skipped). ``options`` are fixed settings for every integrator that
    has them. Every run is checked as :func:`daebench.harness.running.runner.run_scene` would check it
    (settings, observables, contacts, and — unless ``force`` — its size).
    """
    if steps and tols:
        raise SweepError("give --steps or --tols, not both")
    if not integrators:
        raise SweepError("no integrators given (e.g. --integrators hht,baumgarte)")
    classes = _integrator_classes(integrators)
    integ_keys, scene_keys = classify_grid(scene, classes, dict(grid or {}))
    options = dict(options or {})
    for k in options:
        if not any(k in {s.name for s in c.settings_spec} for c in classes.values()):
            raise SweepError(f"--opt '{k}' is not a setting of any of {', '.join(classes)}")
    # validate every scene variant now (bad values fail before running)
    scene_combos = [dict(zip(scene_keys, combo)) for combo in itertools.product(*scene_keys.values())]
    variants, systems = {}, {}
    for i, sc in enumerate(scene_combos):
        variants[i] = scene.with_overrides(sc)
        systems[i] = build_system(variants[i])
        checks.check_memory(variants[i], systems[i])
        checks.check_observables(variants[i], systems[i])
    specs: list[RunSpec] = []
    for name, cls in classes.items():
        spec_names = {s.name for s in cls.settings_spec}
        mine = {k: v for k, v in integ_keys.items() if k in spec_names}
        fixed = {k: v for k, v in options.items() if k in spec_names}
        if tols:
            modes = [{"tol": t} for t in tols]
        elif steps:
            modes = [{"h": float(h)} for h in steps]
        else:
            modes = [{}]
        for i, sc in enumerate(scene_combos):
            for combo in itertools.product(*mine.values()):
                for mode in modes:
                    opts = {**fixed, **dict(zip(mine, combo))}
                    skip = ""
                    if "tol" in mode:
                        if not cls.capabilities.adaptive:
                            skip = f"'{name}' has no adaptive step-size control; --tols does not apply"
                        else:
                            opts.update(adaptive=True, rtol=mode["tol"], atol=mode["tol"] * TOL_ATOL_RATIO)
                    elif "h" in mode:
                        if not cls.capabilities.fixed_step:
                            skip = f"'{name}' chooses its own steps; --steps does not apply"
                        else:
                            opts["h"] = mode["h"]
                    varied = {**sc, **dict(zip(mine, combo)), **mode}
                    if not skip:
                        try:
                            integ = cls(**opts)  # validate settings now
                            checks.check_applicable(variants[i], cls, systems[i])
                            if not force:
                                checks.check_size(variants[i], integ)
                        except ParamError as exc:
                            raise SweepError(str(exc)) from None
                        except Exception as exc:  # a plugin's constructor bug
                            raise SweepError(f"integrator '{name}' raised while being configured with {opts}: "
                                             f"{type(exc).__name__}: {exc}") from None
                    specs.append(RunSpec(len(specs), name, opts, dict(sc), varied, skip))
    return specs
