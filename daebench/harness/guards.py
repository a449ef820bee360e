"""Checks made before a run takes its first step, and the wall-time cap while it runs.

Everything a run would only discover late — an output folder it cannot write, an
observable the model does not have, ~1e10 steps, an integrator that cannot handle the
scene's contacts — is refused here, before any step, with a message that says what to
change (:class:`GuardError`, a :class:`~daebench.core.params.ParamError`: exit code 2 on the
command line).

The wall-time cap (:func:`deadline`) raises :class:`RunTimeout` in the thread that runs
the simulation, from a watchdog thread. It works in any thread (a Dask worker runs tasks
in threads, where SIGALRM cannot reach) and takes effect at the next Python bytecode of
the run; the driver returns to Python at least every compiled batch of steps. It waits
while numba compiles in that thread: an exception raised inside numba's compiler (LLVM
calls back into Python) killed the worker process or left an error on a cold cache, so
a cap that falls inside a compilation takes effect when the compilation ends.
"""

from __future__ import annotations

import ctypes
import errno
import math
import os
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterator

from daebench.integrators import base
from daebench.integrators.base import Integrator, IntegratorError
from daebench.core.params import ParamError, did_you_mean

MAX_STEPS = 1e8          # fixed steps a run may plan without force (≈ 3 min compiled, hours in Python)
MAX_OUTPUT_ROWS = 1e7    # history rows (each ~30 floats: ~2.4 GB at this size)


class GuardError(ParamError):
    """A run refused before its first step; the message says what to change."""


class OutputWriteError(GuardError):
    """A result that was computed but could not be written (full disk, a folder removed
    or made read-only meanwhile); the message says what was kept and what to do. The
    command line exits 1 (the work ran; its input was fine)."""


class RunTimeout(BaseException):
    """A run exceeded its wall-time cap (a BaseException so that a plugin's broad
    ``except Exception`` cannot swallow it)."""


# ---- the wall-time cap ------------------------------------------------------------------
def _raise_in(thread_id: int, exc: type[BaseException] | None) -> None:
    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread_id),
                                               ctypes.py_object(exc) if exc is not None else None)


class _CompileDepth:
    """Per thread, how deep it is inside numba's compiler lock (numba's event API; the
    callbacks run in the compiling thread)."""

    def __init__(self) -> None:
        self.depth: dict[int, int] = {}

    def on_start(self, event: Any) -> None:
        tid = threading.get_ident()
        self.depth[tid] = self.depth.get(tid, 0) + 1

    def on_end(self, event: Any) -> None:
        tid = threading.get_ident()
        self.depth[tid] = self.depth.get(tid, 1) - 1

    def compiling(self, thread_id: int) -> bool:
        return self.depth.get(thread_id, 0) > 0


def _install_compile_depth() -> _CompileDepth:
    from numba.core import event

    class Listener(_CompileDepth, event.Listener):
        pass

    listener = Listener()
    event.register("numba:compiler_lock", listener)
    return listener


COMPILE_DEPTH = _install_compile_depth()
RECHECK_S = 0.05    # while the capped thread compiles, the watchdog looks again this often


@contextmanager
def deadline(seconds: float | None) -> Iterator[None]:
    """Raise :class:`RunTimeout` in the calling thread once ``seconds`` of wall time have
    passed inside the ``with`` block (None or 0: no cap).

    Raises
    ------
    GuardError
        If ``seconds`` is negative or not finite.
    """
    if seconds is None or seconds == 0:
        yield
        return
    check_run_cap(seconds)
    target = threading.get_ident()
    lock = threading.Lock()
    state = {"active": True, "fired": False}

    timers: list[threading.Timer] = []

    def arm(delay: float) -> None:
        timer = threading.Timer(delay, fire)
        timer.daemon = True
        timers.append(timer)
        timer.start()

    def fire() -> None:
        with lock:
            if not state["active"]:
                return
            if COMPILE_DEPTH.compiling(target):
                arm(RECHECK_S)          # never inside numba's compiler: once it is done
                return
            state["fired"] = True
            _raise_in(target, RunTimeout)

    arm(float(seconds))
    try:
        yield
    except RunTimeout:
        raise RunTimeout(f"run exceeded the wall-time cap of {seconds:g} s") from None
    except Exception as exc:
        if not state["fired"]:
            raise
        # the asynchronous RunTimeout landed in a Python model's call from compiled code
        # (numba.objmode): numba's own exception handling then fails with it pending
        # ("SystemError: … returned a result with an exception set", or a garbled
        # TypeError). The run is over its cap either way: a timeout, the error its cause
        raise RunTimeout(f"run exceeded the wall-time cap of {seconds:g} s") from exc
    finally:
        with lock:
            for timer in timers:
                timer.cancel()
            state["active"] = False
            pending = state["fired"]
        if pending:
            _raise_in(target, None)  # the block ended just as the timer fired: drop the pending one
    if pending:
        raise RunTimeout(f"run exceeded the wall-time cap of {seconds:g} s")


def check_run_cap(seconds: Any) -> float | None:
    """A run cap in seconds: None, or a finite number > 0."""
    if seconds is None:
        return None
    try:
        s = float(seconds)
    except (TypeError, ValueError):
        raise GuardError(f"the run cap must be a number of seconds, got {seconds!r}") from None
    if not math.isfinite(s) or s <= 0:
        raise GuardError(f"the run cap must be a finite number of seconds > 0, got {seconds!r} "
                         f"(e.g. --run-cap 600; leave it out for no cap)")
    return s


# ---- before the first step -------------------------------------------------------------------
def resolve_integrator(name: str) -> str:
    """The registered name of an integrator, matched case-insensitively.

    Raises
    ------
    IntegratorError
        For an unknown name, with the closest registered one.
    """
    reg = base.registry()  # looked up on the module: tests and plugins may replace it
    if not isinstance(name, str) or not name.strip():
        raise IntegratorError(f"an integrator name is needed, e.g. hht; available: {', '.join(reg)}")
    if name in reg:
        return name
    lower = {n.lower(): n for n in reg}
    if name.strip().lower() in lower:
        return lower[name.strip().lower()]
    raise IntegratorError(f"unknown integrator '{name}'{did_you_mean(name.lower(), reg)} "
                          f"Available: {', '.join(reg)} (see `daebench list`).")


def estimated_steps(scene: Any, integ: Integrator) -> float:
    """Steps a fixed-step run plans over the scene (t_end / h); 0 when the integrator
    chooses its own steps (adaptive, or no ``h`` setting)."""
    h = integ.settings.get("h")
    if integ.adaptive or not h:
        return 0.0
    return scene.t_end / float(h)


def check_size(scene: Any, integ: Integrator) -> None:
    """Refuse a run whose step count or history size is beyond reason (pass ``force``
    to the caller to run it anyway)."""
    n = estimated_steps(scene, integ)
    if n > MAX_STEPS:
        raise GuardError(
            f"h = {integ.settings['h']:g} s over t_end = {scene.t_end:g} s is ≈ {n:.2g} steps, beyond the limit of "
            f"{MAX_STEPS:.0e}; use a larger h (e.g. --opt h=1e-4) or a shorter t_end, or pass --force to run it anyway")
    rows = scene.t_end / float(scene["output.dt"])
    if rows > MAX_OUTPUT_ROWS:
        raise GuardError(
            f"output.dt = {scene['output.dt']:g} s over t_end = {scene.t_end:g} s is ≈ {rows:.2g} history rows, beyond "
            f"the limit of {MAX_OUTPUT_ROWS:.0e}; use a larger output.dt (e.g. --set output.dt=1e-3), or pass --force")


def check_observables(scene: Any, system: Any) -> list[str]:
    """The scored observables (``output.observables``) this configuration produces.

    A name the model never computes, whatever its effects, is refused (a typo); a name it
    computes only with an effect this scene turns off (``gap`` without contact) is left
    out of scoring and returned out of the list — callers report it, never silently."""
    check_start(scene, system)
    wanted = list(scene.get("output.observables") or [])
    if not wanted:
        return []
    q, v = system.initial_state()
    have = list(system.observables(0.0, q, v))
    unknown = [o for o in wanted if o not in have]
    if unknown:
        vocabulary = set(have) | _all_effects_observables(scene)
        typos = [o for o in unknown if o not in vocabulary]
        if typos:
            raise GuardError(
                f"scene key 'output.observables': '{typos[0]}' is not an observable of model '{scene.model}'"
                f"{did_you_mean(typos[0], vocabulary)} Observables: {', '.join(sorted(vocabulary))}.")
    return [o for o in wanted if o in have]


START_GAP_TOL = 1e-9   # m: a start this far inside a rigid (impact-law) contact is refused


def check_start(scene: Any, system: Any) -> None:
    """Refuse a start with a body through a surface whose contact is an impact law
    (constraint, complementarity): such a run would begin with the contact violated and
    blow up (beam-impact at θ = -30°: gap -0.5 m, 9e5 J). Continuous laws (Hertz,
    penalty) accept a penetrating start: their force is defined there.

    Raises
    ------
    GuardError
        Naming the contact, its gap and the fix.
    """
    if not getattr(system, "n_contacts", 0) or not scene.get("effects.contact", True):
        return
    law = getattr(system, "contact_law", None)
    if law is not None and law.continuous:
        return
    q, _ = system.initial_state()
    gap = [float(g) for g in system.gap(q)]
    inside = [(i, g) for i, g in enumerate(gap) if g < -START_GAP_TOL]
    if inside:
        i, g = min(inside, key=lambda x: x[1])
        raise GuardError(
            f"scene '{scene.name}' starts with contact {i} {-g:.3g} m through its surface (gap {g:.3g} m at t = 0); "
            f"a rigid contact cannot start violated. Start outside it (gap ≥ 0: change the start.* keys, "
            f"`daebench show {scene.name} --keys`), or use a continuous law (--set contact.law=hertz)")


def _all_effects_observables(scene: Any) -> set[str]:
    """What the model computes with every effect of the scene switched on."""
    from daebench.models import build_system

    effects = {k: True for k in scene.values if k.startswith("effects.")}
    try:
        system = build_system(scene.with_overrides(effects))
        q, v = system.initial_state()
        return set(system.observables(0.0, q, v))
    except Exception:  # a combination the model refuses: only what this scene produces counts
        return set()


def check_contacts_fit(scene: Any, cls: type[Integrator]) -> None:
    """An integrator that resolves contacts itself needs a scene with contacts that are left
    to it ('complementarity') or closed by the ``constraint`` law (whose restitution it
    applies; :func:`daebench.integrators.base.check_capabilities` is the driver's rule);
    name a scene key value the scene accepts, or the scenes that offer one. A scene with
    Coulomb friction (``contact.friction`` > 0, contacts on) needs an integrator that applies
    it under the scene's law (:func:`daebench.integrators.base.applies_friction`)."""
    if (scene.get("contact.friction", 0.0) or 0.0) > 0.0 and scene.get("effects.contact", True) \
            and not base.applies_friction(cls, scene.get("contact.law")):
        raise IntegratorError(base.friction_refusal(cls.name, f"scene '{scene.name}'"))
    if not cls.capabilities.contacts:
        return
    law = scene.schema.get("contact.law")
    current = scene.get("contact.law")
    if current in cls.contact_laws and scene.get("effects.contact", True):
        return
    if law is not None and law.choices:
        fits = [c for c in cls.contact_laws if c in law.choices]
        if fits:
            raise IntegratorError(f"integrator '{cls.name}' resolves contacts itself; run it with "
                                  + " or ".join(f"`--set contact.law={c}`" for c in fits)
                                  + (" and `--set effects.contact=true`" if scene.get("effects.contact") is False else "")
                                  + f" (scene '{scene.name}' uses '{current}')")
    from daebench.core.scene import list_scenes
    from daebench.models.scenes import load_scene

    offer = []
    for name, _ in list_scenes():
        p = load_scene(name).schema.get("contact.law")
        if p is not None and p.choices and any(c in p.choices for c in cls.contact_laws):
            offer.append(name)
    laws = " or ".join(f"'{c}'" for c in cls.contact_laws)
    hint = f"scenes that offer it: {', '.join(offer)}" if offer else "no installed scene offers it"
    raise IntegratorError(f"integrator '{cls.name}' resolves contacts itself (contact law {laws}), which "
                          f"scene '{scene.name}' (model {scene.model}) does not offer; {hint}")


def check_applicable(scene: Any, cls: type[Integrator], system: Any = None) -> None:
    """Refuse, before anything runs, an integrator that cannot run this scene: the contact
    fit (:func:`check_contacts_fit`) and the capability check the driver makes at its
    start (:func:`daebench.integrators.base.check_capabilities`, with the driver's
    arguments: constraints are needed for bilateral joints, and for impact-law contacts
    the integrator does not resolve itself). Refusals an integrator makes only in its own
    start (e.g. a model type it does not support) still come at run time.

    Raises
    ------
    IntegratorError
    """
    from daebench.integrators.base import check_capabilities
    from daebench.models import build_system

    check_contacts_fit(scene, cls)
    system = system if system is not None else build_system(scene)
    law = system.contact_law
    needs_constraints = system.n_bilateral > 0 or (law is not None and not law.continuous and system.n_contacts > 0
                                                   and not cls.capabilities.contacts)
    check_capabilities(cls, needs_constraints, contacts_by_integrator=system.contacts_by_integrator,
                       contact_law=None if law is None else law.name, n_contacts=system.n_contacts,
                       what=f"scene '{scene.name}'")


def ensure_writable_dir(path: str | Path, what: str = "output folder", longest_name: str = "") -> Path:
    """Create ``path`` if needed and prove it writable (a file is made and removed), so
    that a run never finishes only to fail when it writes. ``longest_name``: the longest
    file name that will be written there, checked against the file system's limit."""
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise GuardError(f"{what} must be a folder path (a string), e.g. results/runs; got {path!r}")
    p = Path(path)
    try:
        if p.exists() and not p.is_dir():
            raise GuardError(f"{what} '{p}' is a file, not a folder; give a folder (it is created if missing)")
        p.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=p, prefix=".write-test-"):
            pass
    except OSError as exc:
        raise GuardError(f"cannot write to {what} '{str(p)[:120]}{'…' if len(str(p)) > 120 else ''}': "
                         f"{describe_os_error(exc)}; choose a writable folder (--out, or the DAEBENCH_RESULTS "
                         f"environment variable)") from None
    if longest_name:
        check_name_fits(p, longest_name, what)
    return p


def check_name_fits(folder: Path, name: str, what: str = "output folder") -> None:
    """Refuse, before any work, a file name longer than ``folder``'s file system takes."""
    try:
        limit = os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    n = len(os.fsencode(name))
    if n > limit:
        raise GuardError(f"the file name {name[:40]!r}… would be {n} bytes, more than the {limit} the file system "
                         f"of {what} '{folder}' takes; use a shorter scene name (--set name=short) or --name")


def describe_os_error(exc: BaseException) -> str:
    """'the disk is full (No space left on device)' and the like, for messages."""
    code = getattr(exc, "errno", None)
    text = getattr(exc, "strerror", None) or str(exc)
    if code in (errno.ENOSPC, errno.EDQUOT) or "disk is full" in str(exc) or "No space left" in str(exc):
        return f"the disk is full ({text})"
    if code in (errno.EACCES, errno.EPERM, errno.EROFS):
        return f"it is not writable ({text})"
    if code == errno.ENAMETOOLONG:
        return f"the name is too long for the file system ({text})"
    return f"{type(exc).__name__}: {text}"


def atomic_write(path: Path, write: Callable[[Path], Any], what: str, kept: str = "") -> None:
    """Write ``path`` through a temporary file beside it (``write(tmp)``, then ``os.replace``).
    A failure removes the temporary file and raises :class:`OutputWriteError` naming the
    file, the cause and ``kept`` (what is safe)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        raise write_error(exc, what, path, kept, tmp) from None


def write_error(exc: BaseException, what: str, path: Path | str, kept: str = "",
                tmp: Path | None = None) -> OutputWriteError:
    """The :class:`OutputWriteError` of a failed write (the temporary file ``tmp`` removed)."""
    if tmp is not None:
        try:
            os.unlink(tmp)
        except OSError:
            pass
    return OutputWriteError(f"could not write {what} {path}: {describe_os_error(exc)}. "
                            + (f"{kept[0].upper()}{kept[1:]}. " if kept else "")
                            + "Free space there or choose another folder (--out, or DAEBENCH_RESULTS), "
                              "then run again; this is not a fault of the integrator")
