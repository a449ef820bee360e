"""daebench: benchmark time integrators for constrained mechanical systems with impact."""
import os as _os

__version__ = "0.1.0"

# Before any kernel module is decorated: DAEBENCH_COMPILED=0 runs every numba function as
# plain Python (the same source, interpreted), and daebench's compiled functions share one
# cache stamp (daebench._numba_cache).
if _os.environ.get("DAEBENCH_COMPILED", "1").strip().lower() in ("0", "false", "no", "off"):
    import numba as _numba

    _numba.config.DISABLE_JIT = True

from daebench import _numba_cache as _nc  # noqa: E402

_nc.install()
