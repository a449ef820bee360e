"""daebench: benchmark time integrators for constrained mechanical systems with impact.

The Python API (:mod:`daebench.api`), available at the package top::

    import daebench
    r = daebench.run("pendulum", integrator="hht", h=1e-3)   # arrays r.t, r.q, r.v, r.lam
    df = daebench.bench("pendulum", ["hht", "newmark"], steps=[1e-2, 5e-3])
    daebench.cases(), daebench.integrators(), daebench.load_scene("beam-impact")
    daebench.reference("pendulum")

Two names are both a module and a function: ``daebench.bench`` is the sweep module
and, called, runs :func:`daebench.api.bench`; ``daebench.integrators`` is the subpackage
of the built-in integrators and, called, lists every registered one
(:func:`daebench.api.integrators`). Their module objects are made callable
(:class:`CallableModule`), so that ``from daebench import bench`` and
``daebench.bench(...)`` both keep working.
"""
import os as _os
import types as _types

__version__ = "0.1.0"

# Before any kernel module is decorated: DAEBENCH_COMPILED=0 runs every numba function as
# plain Python (the same source, interpreted), and daebench's compiled functions share one
# cache stamp (daebench._numba_cache).
if _os.environ.get("DAEBENCH_COMPILED", "1").strip().lower() in ("0", "false", "no", "off"):
    import numba as _numba

    _numba.config.DISABLE_JIT = True

from daebench import _numba_cache as _nc  # noqa: E402

_nc.install()

_API = ("run", "reference", "load_scene", "cases", "integrator_info", "RunOutput", "IntegratorInfo")
__all__ = [*_API, "bench", "integrators"]


def __getattr__(name: str):
    # the API is imported on first use: `import daebench` stays cheap for the CLI's --help
    if name in _API:
        from daebench import api

        return getattr(api, name)
    if name == "bench":  # the module, callable (see the module docstring)
        import importlib

        return importlib.import_module("daebench.bench")
    raise AttributeError(f"module 'daebench' has no attribute '{name}'")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class CallableModule(_types.ModuleType):
    """A module that, called, runs the :mod:`daebench.api` function of its name."""

    def __call__(self, *args, **kwargs):
        from daebench import api

        return getattr(api, self.__name__.rsplit(".", 1)[-1])(*args, **kwargs)


from daebench import integrators as _integrators  # noqa: E402

_integrators.__class__ = CallableModule
