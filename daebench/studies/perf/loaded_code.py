"""What one process holds compiled: every specialization of daebench's compiled functions
that this process compiled or loaded from the kernel cache, with its machine-code bytes.

A census taken inside a process (:func:`loaded`), without compiling anything: each
dispatcher of daebench's modules (and of the kernel modules generated for models and
steppers, ``_daebench_*``) lists the signatures it holds (``dispatcher.overloads``); the
machine code of a specialization loaded from the cache is read from its cache entry (the
object file numba saved beside its bitcode: :func:`object_text_bytes`), of one compiled in
this process from the object numba emitted. Run in a fresh process after a command, it
counts what that command needs (on a warm cache the functions it called from Python, whose
machine code holds every callee linked into them; on a cold one every function compiled) — deterministic counts for one numba, LLVM and CPU, which a
test can bound (tests/stepping/test_compile_budget.py) where a compile time could not be.
"""

from __future__ import annotations

import re
import struct
import sys
from collections import defaultdict
from dataclasses import dataclass

from numba.core.registry import CPUDispatcher

from daebench.harness.running.compile_events import code_bytes, text_bytes
from daebench.harness.running.runner import run_scene
from daebench.models.scenes import load_scene

PREFIXES = ("daebench", "_daebench_")
_ELF = b"\x7fELF"
_GENERATED = re.compile(r"^(_daebench_\w+?)_[0-9a-f]{16}$")   # a generated kernel module: its digest


@dataclass(frozen=True)
class Loaded:
    """One specialization held by this process."""

    name: str           # module.qualname
    signature: str
    code_bytes: int     # machine code of its library (callees linked into it included); 0: unknown


def object_text_bytes(blob: bytes) -> int:
    """:func:`text_bytes` of the ELF object inside a cache entry's bytes (numba pickles the
    object code as one bytes value; an ELF64 file ends with its section headers); 0 when the
    entry holds none (another object format)."""
    at = blob.find(_ELF)
    if at < 0 or blob[at + 4] != 2 or blob[at + 5] != 1:     # ELF64, little-endian
        return 0
    shoff, = struct.unpack_from("<Q", blob, at + 0x28)
    shentsize, shnum = struct.unpack_from("<HH", blob, at + 0x3A)
    return text_bytes(blob[at:at + shoff + shentsize * shnum])


def _cached_code(disp: CPUDispatcher, sig: tuple) -> int:
    cache = getattr(disp, "_cache", None)
    files = getattr(cache, "_cache_file", None)
    if files is None:
        return 0
    index = files._load_index()
    key = cache._index_key(sig, disp.targetctx.codegen())
    name = index.get(key)
    if name is None:   # compiled for a full signature (return type given): numba keys the entry by it
        name = next((v for k, v in index.items() if getattr(k[0], "args", None) == sig and k[1:] == key[1:]), None)
    if name is None:
        return 0
    with open(files._data_path(name), "rb") as f:
        return object_text_bytes(f.read())


def dispatchers(prefixes: tuple[str, ...] = PREFIXES) -> dict[str, CPUDispatcher]:
    """Every compiled function defined at the top of a loaded module whose name starts with
    one of ``prefixes``, by module.qualname (a generated module's name without its code
    digest: ``_daebench_handle_hubbeamdata.mass_force``, the same name after an edit)."""
    out: dict[str, CPUDispatcher] = {}
    for modname, mod in list(sys.modules.items()):
        if not modname.startswith(prefixes):
            continue
        for value in list(vars(mod).values()):
            if isinstance(value, CPUDispatcher) and value.py_func.__module__ == modname:
                out[_GENERATED.sub(r"\1", modname) + "." + value.py_func.__qualname__] = value
    return out


def loaded(prefixes: tuple[str, ...] = PREFIXES) -> list[Loaded]:
    """Every specialization this process holds of the functions :func:`dispatchers` finds."""
    rows = []
    for name, disp in sorted(dispatchers(prefixes).items()):
        for sig, cres in list(disp.overloads.items()):
            size = code_bytes(cres.library) or _cached_code(disp, sig)
            rows.append(Loaded(name, ", ".join(str(a) for a in sig)[:200], size))
    return rows


def by_function(rows: list[Loaded]) -> dict[str, tuple[int, int]]:
    """function → (specializations, machine-code bytes)."""
    acc: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    for r in rows:
        acc[r.name][0] += 1
        acc[r.name][1] += r.code_bytes
    return {k: (n, b) for k, (n, b) in acc.items()}


#: the main job (`daebench compare beam-impact`) in small: each of its integrators at its
#: protocol's coarsest setting, started 2° above the plane so that an impact, the contact
#: phase and the rebound are reached within 0.1 s
MAIN_JOB_CASE = "beam-impact"
MAIN_JOB_OVERRIDES = ("t_end=0.1", "start.theta_deg=2")
MAIN_JOB = (("hht", {"h": 1e-4, "h_contact": 1e-6}), ("newmark", {"h": 1e-4, "h_contact": 1e-6}),
            ("genalpha", {"h": 1e-4, "h_contact": 1e-6}), ("baumgarte", {"h": 2.5e-5, "h_contact": 1e-6}),
            ("moreau", {"h": 1e-4}), ("nsgenalpha", {"h": 1e-4}), ("ida", {"rtol": 1e-4, "atol": 1e-6}))


def main_job() -> list[Loaded]:
    """Run :data:`MAIN_JOB` in this process (nothing written) and return :func:`loaded`:
    what the main job holds compiled, when this process ran nothing before."""
    scene = load_scene(MAIN_JOB_CASE, list(MAIN_JOB_OVERRIDES))
    for name, settings in MAIN_JOB:
        rec, _ = run_scene(scene, name, settings, write=False)
        if rec.status != "completed":
            raise RuntimeError(f"the main job's {name} run on {MAIN_JOB_CASE} ended {rec.status}: {rec.message}")
    return loaded()


if __name__ == "__main__":   # `python -m daebench.studies.perf.loaded_code`: the main job's census as JSON
    import json

    print(json.dumps([r.__dict__ for r in main_job()]))
