"""Suite-wide set-up: the xdist workers share the compile work of a cold kernel cache.

With an empty kernel cache every xdist worker starts by compiling the same integrator
loops and model kernels at the same time (``--dist loadfile`` gives them different files,
not different code), paying twice for each. When the session spans the suite (at least
:data:`WARMUP_MIN_FILES` test files) and runs in xdist workers, each worker first works
through the :data:`WARMUP` list — a tiny run of a common case with each integrator — taking
a job only if no other worker holds it (an ``flock`` per job, non-blocking), so the workers
compile disjoint parts side by side and the cache is written once; a job another worker is
running is then waited for (its result is loaded from the cache by the tests). A finished
job leaves a marker keyed by daebench's source stamp, so a warm cache costs nothing here.
Beyond the warm-up, in any xdist run, a function cached on disk is compiled under a lock
per (function, signature) shared by the workers (:func:`_one_compile_at_a_time`): the
second worker to need it waits and loads it instead of compiling it again.

``DAEBENCH_TEST_SHARE_COMPILE=0`` turns both off (to measure what they save).

``DAEBENCH_TEST_COMPILE_LOG=<folder>``: every worker appends each numba compile (test,
function, signature, own seconds) to ``<folder>/<worker>.jsonl`` — where a cold suite's
time goes (:mod:`daebench.studies.perf.compile_census` records them).
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import time
import warnings
from contextlib import ExitStack
from pathlib import Path

import pytest

#: (case, integrators) run for 0.01 s each at session start: the loops most tests compile
WARMUP = [("pendulum", ("hht", "genalpha", "newmark", "baumgarte", "ida", "moreau", "nsgenalpha")),
          ("ball", ("hht", "genalpha", "newmark", "moreau", "nsgenalpha")),
          ("beam-impact", ("hht", "newmark"))]
WARMUP_MIN_FILES = 30


def _jobs() -> list[tuple[str, str]]:
    return [(case, name) for case, names in WARMUP for name in names]


def _run_job(case: str, name: str) -> None:
    from daebench import api
    from daebench.core.params import ParamError

    step = {} if name == "ida" else {"h": 1e-3}
    try:
        api.run(case, name, overrides=["t_end=0.01"], **step)
    except ParamError:  # the integrator does not take this case: nothing to share
        pass


def _folder() -> Path:
    from daebench.core import handles, numba_cache

    d = handles._directory().parent / "daebench-warmup" / numba_cache.source_stamp()[:16]
    d.mkdir(parents=True, exist_ok=True)
    return d


def _shared_warmup() -> None:
    """Each job once across the workers: take a free one, skip a held one, then wait for those."""
    folder = _folder()
    waiting = []
    with ExitStack() as stack:
        for case, name in _jobs():
            done = folder / f"{case}.{name}.done"
            if done.exists():
                continue
            fd = os.open(folder / f"{case}.{name}.lock", os.O_CREAT | os.O_RDWR)
            stack.callback(os.close, fd)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:  # another worker compiles it now
                waiting.append(fd)
                continue
            if not done.exists():
                try:
                    _run_job(case, name)
                    done.touch()
                except Exception as exc:  # noqa: BLE001 - the tests that use it will fail and say why
                    warnings.warn(f"warm-up {name} on {case} failed: {type(exc).__name__}: {exc}", stacklevel=1)
            fcntl.flock(fd, fcntl.LOCK_UN)
        for fd in waiting:
            fcntl.flock(fd, fcntl.LOCK_EX)  # until the other worker has cached it
            fcntl.flock(fd, fcntl.LOCK_UN)


_HELD: set[str] = set()


def _one_compile_at_a_time(folder: Path) -> None:
    """numba's ``Dispatcher.compile`` under a lock per (function, signature) shared by the
    workers, for functions cached on disk: a worker that needs what another is compiling
    waits and loads it from the cache instead of compiling it a second time."""
    from numba.core.caching import NullCache
    from numba.core.dispatcher import Dispatcher

    original = Dispatcher.compile

    def compile(self, sig):
        if isinstance(self._cache, NullCache):
            return original(self, sig)
        py = self.py_func
        key = hashlib.sha1(f"{py.__module__}.{py.__qualname__}|{py.__code__.co_filename}|{sig}".encode()).hexdigest()
        if key in _HELD:  # re-entered (recursion) or another thread of this worker: numba's own lock serialises
            return original(self, sig)
        fd = os.open(folder / f"{key}.lock", os.O_CREAT | os.O_RDWR)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            _HELD.add(key)
            return original(self, sig)  # a hit in the cache if another worker compiled it meanwhile
        finally:
            _HELD.discard(key)
            os.close(fd)  # releases the lock

    Dispatcher.compile = compile


def _in_a_worker() -> bool:
    import numba

    return ("PYTEST_XDIST_WORKER" in os.environ and not numba.config.DISABLE_JIT
            and os.environ.get("DAEBENCH_TEST_SHARE_COMPILE", "1") != "0")


def pytest_configure(config: pytest.Config) -> None:
    if _in_a_worker():  # before collection: test modules compile at import too
        locks = _folder() / "compile-locks"
        locks.mkdir(exist_ok=True)
        _one_compile_at_a_time(locks)


@pytest.fixture(scope="session", autouse=True)
def _workers_share_the_cold_compile(request: pytest.FixtureRequest) -> None:
    if not _in_a_worker():
        return
    if len({item.path for item in request.session.items}) < WARMUP_MIN_FILES:
        return  # a few files: compile only what they use
    _shared_warmup()


# -- the opt-in compile log ---------------------------------------------------------------------
_LOG = os.environ.get("DAEBENCH_TEST_COMPILE_LOG")
_CURRENT = ["(session start)"]


if _LOG:
    def pytest_sessionstart(session: pytest.Session) -> None:
        from numba.core import event as ev

        path = Path(_LOG) / f"{os.environ.get('PYTEST_XDIST_WORKER', 'main')}.jsonl"
        path.parent.mkdir(parents=True, exist_ok=True)
        stack: list[list] = []

        class Compiles(ev.Listener):
            def on_start(self, event):
                py = getattr(event.data["dispatcher"], "py_func", None)
                stack.append([f"{getattr(py, '__module__', '?')}.{getattr(py, '__qualname__', '?')}",
                              ", ".join(str(a) for a in event.data["args"])[:200], time.perf_counter(), 0.0])

            def on_end(self, event):
                name, sig, t0, nested = stack.pop()
                span = time.perf_counter() - t0
                if stack:
                    stack[-1][3] += span
                with open(path, "a") as f:
                    f.write(json.dumps({"test": _CURRENT[0], "name": name, "signature": sig,
                                        "own_s": span - nested, "end": time.time()}) + "\n")

        ev.register("numba:compile", Compiles())

    @pytest.hookimpl(tryfirst=True)
    def pytest_runtest_setup(item: pytest.Item) -> None:
        _CURRENT[0] = item.nodeid
