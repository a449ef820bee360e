"""daebench: benchmark time integrators for constrained mechanical systems with impact.

The Python API (:mod:`daebench.api`), available at the package top:

>>> import daebench
>>> r = daebench.run("pendulum", integrator="hht", h=1e-3)   # arrays r.t, r.q, r.v, r.lam  # doctest: +SKIP
>>> df = daebench.bench("pendulum", ["hht", "newmark"], steps=[1e-2, 5e-3])                  # doctest: +SKIP
>>> daebench.cases(), daebench.integrator_infos(), daebench.load_scene("beam-impact")         # doctest: +SKIP
>>> daebench.reference("pendulum"), daebench.compare("pendulum")                             # doctest: +SKIP
>>> daebench.score("pendulum", "exudyn.csv").row, daebench.export_case("beam-impact")        # doctest: +SKIP
>>> daebench.ParamError                                                                      # doctest: +SKIP

The package reads top-down, one layer a subpackage, each importing only those before it
(``tests/test_layers.py`` holds the order): :mod:`.core` (data and physics interfaces),
:mod:`.stepping` (compiled steppers), :mod:`.models`, :mod:`.integrators`,
:mod:`.driver` (the event-driven driver), :mod:`.harness` (runs, sweeps, references,
scores), :mod:`.workflows` (what each command does), :mod:`.peers` (other codes run on a
case: Siconos, Exudyn), :mod:`.studies` (the reproduced
papers, the speed figures), :mod:`.api` (the only door the command line uses), :mod:`.cli`.
"""
import os as _os

__version__ = "0.1.0"

# One BLAS thread per process unless the environment says otherwise (read when numpy first
# loads OpenBLAS, so only where daebench is imported before numpy: the command line, sweep
# workers). daebench runs one method per process and prices it in CPU seconds; on the
# paper-size slider (n = 4 738, 2 cores) OpenBLAS's second thread spent 15 s of CPU waiting
# in a 64 s run, with the same wall time (docs/performance.md).
_os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

# Before any kernel module is decorated: DAEBENCH_COMPILED=0 runs every numba function as
# plain Python (the same source, interpreted), and daebench's compiled functions share one
# cache stamp (daebench.core.numba_cache).
from daebench.core.switches import switched_off as _switched_off  # noqa: E402

if _switched_off("DAEBENCH_COMPILED"):
    import numba as _numba

    _numba.config.DISABLE_JIT = True

from daebench.core import numba_cache as _nc  # noqa: E402
from daebench.core import stack_chunks as _sc  # noqa: E402

_nc.install()
_sc.install()   # numba's compiler on CPython 3.11/3.12: no map and unmap per frame-stack chunk crossed

_API = ("run", "bench", "reference", "compare", "survey", "effects", "report", "stability", "load_scene", "cases",
        "integrator_info", "integrator_infos", "RunOutput", "IntegratorInfo", "ParamError", "score", "export_case",
        "register", "verify")
__all__ = list(_API)


def __getattr__(name: str):
    # the API is imported on first use: `import daebench` stays cheap for the CLI's --help
    if name in _API:
        from daebench import api  # lazy: the API loads the harness; `import daebench` stays cheap for --help

        return getattr(api, name)
    raise AttributeError(f"module 'daebench' has no attribute '{name}'")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
