"""Shape checks of the Python API's arguments and of a sweep's plan, before anything runs.

The command line hands the API strings it has already split; a Python caller can hand it
anything. Each check here turns a value of the wrong shape into a
:class:`~daebench.core.params.ParamError` that names the argument, what it must be and an
example — never a ``TypeError`` or ``ValueError`` from deep inside (e.g. ``run(s,
settings="h=1e-3")``, ``bench(s, None)``, ``grid={"alpha": 0.0}``, ``options="alpha=0"``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from daebench.core.params import ParamError

#: the integrator settings a sweep's --steps / --tols set on every run
STEP_KEYS = ("h",)
TOL_KEYS = ("tol", "rtol", "atol", "adaptive")


def mapping(value: Any, what: str, example: str) -> dict[str, Any]:
    """``value`` as a dict with string keys (None: empty).

    Raises
    ------
    ParamError
        For anything else (a string such as "h=1e-3", a list, a number).
    """
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ParamError(f"{what} must be a dict of name → value, e.g. {example}; got {value!r}"
                         + (" (a string: the command line's form; in Python pass a dict)"
                            if isinstance(value, str) else ""))
    bad = [k for k in value if not isinstance(k, str)]
    if bad:
        raise ParamError(f"{what}: names must be strings, e.g. {example}; got {bad[0]!r}")
    return dict(value)


def names(value: Any, what: str = "integrators", example: str = '["hht", "newmark"] or "hht,newmark"') -> list[str]:
    """Integrator names: a list of strings or one comma-separated string."""
    if isinstance(value, str):
        out = [x.strip() for x in value.split(",") if x.strip()]
    elif isinstance(value, Iterable) and not isinstance(value, (bytes, Mapping)):
        out = list(value)
    else:
        out = None
    if out is None or not all(isinstance(x, str) and x.strip() for x in out):  # [] is the planner's to refuse
        raise ParamError(f"{what} must name at least one integrator, e.g. {example}; got {value!r} "
                         f"(`daebench list` shows them)")
    return out


def grid(value: Any) -> dict[str, list[Any]]:
    """A sweep grid: {key: list of values}; a single value is a mistake (grid={"alpha": 0.0}
    meant [0.0] or was meant as a fixed setting: options={"alpha": 0.0})."""
    g = mapping(value, "grid", '{"alpha": [0.0, -0.1]}')
    for k, v in g.items():
        if isinstance(v, (str, bytes, Mapping)) or not isinstance(v, Iterable):
            raise ParamError(f"grid key '{k}' must have a list of values, e.g. {{\"{k}\": [{v!r}]}}; got {v!r} "
                             f"(a single fixed value goes in options={{\"{k}\": {v!r}}})")
        g[k] = list(v)
    return g


def check_grid_against_modes(grid_keys: Iterable[str], steps: Any, tols: Any) -> None:
    """Refuse a grid key that --steps or --tols also sets: `--steps 1e-2 --grid h=1e-3,2e-3`
    made two runs, both at h = 0.01 (the grid's values silently dropped).

    Raises
    ------
    ParamError
    """
    keys = set(grid_keys)
    for flag, given, owned in (("--steps", steps, STEP_KEYS), ("--tols", tols, TOL_KEYS)):
        both = sorted(keys & set(owned)) if given else []
        if both:
            raise ParamError(f"grid key '{both[0]}' is also set by {flag} (every run's {both[0]} comes from "
                             f"{flag}); give the values in one place: {flag} with all of them, or --grid "
                             f"{both[0]}=… without {flag}")
