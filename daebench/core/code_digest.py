"""The code a plugin's compiled functions are made of, as one digest: what keys their cache.

daebench's own compiled functions share one stamp (:func:`daebench.core.numba_cache.source_stamp`:
every daebench module that defines numba functions). A plugin's are keyed on their own code
instead, so that an author's edit recompiles the plugin's functions and nothing of daebench:

* :func:`package_digest` — the source files of the package a plugin function lives in
  (every ``.py`` file of its top-level package, or its one file), read when the function
  is decorated: numba stamps a cached function then (the loaded code is what was read);
* :func:`functions_digest` — the code objects of given functions as loaded in this
  process and of everything they reach (functions and numba functions of the same
  package or of a notebook, the constants they read from their globals), walked through
  their globals: what keys a daebench loop or a generated entry compiled around a plugin's
  functions (a notebook's cells have no file; a file edited after import is not what runs);
* :func:`is_plugin_function` — whether a compiled function outside daebench builds on
  daebench (its module imports daebench, or belongs to a registered plugin package).

A function's line numbers and file name are not part of its code here: moving it, or
running a notebook cell again unchanged, does not recompile.
"""

from __future__ import annotations

import hashlib
import os
import sys
import types as _pytypes
from pathlib import Path
from typing import Any, Iterable

import numpy as np

_FILES: dict[tuple[str, int, int], bytes] = {}
_SIMPLE = (bool, int, float, complex, str, bytes, type(None))
#: top-level packages whose code is never walked (their versions key numba's own cache)
_LIBRARIES = frozenset({"numpy", "numba", "llvmlite", "scipy", "math", "cmath", "builtins", "typing",
                        "collections", "functools", "operator", "itertools"})


def is_daebench(module: str | None) -> bool:
    return bool(module) and (module == "daebench" or module.startswith("daebench."))


def generated(module: str | None) -> bool:
    """A module daebench generates itself (handles of models and methods), named by its digest."""
    return bool(module) and module.startswith("_daebench_")


def _top(module: str) -> str:
    return module.split(".")[0]


def _file_bytes(path: str) -> bytes:
    """SHA-256 of one file's bytes, read again only when its size or time changes."""
    try:
        st = os.stat(path)
    except OSError:
        return b"missing:" + path.encode()
    key = (path, st.st_mtime_ns, st.st_size)
    got = _FILES.get(key)
    if got is None:
        with open(path, "rb") as f:
            got = hashlib.sha256(f.read()).digest()
        _FILES[key] = got
    return got


def package_files(module: str) -> list[str]:
    """The source files of ``module``'s top-level package (every ``.py`` under it), or the
    module's own file when it is not in a package; [] for a module without a file (a
    notebook's ``__main__``)."""
    top = sys.modules.get(_top(module))
    roots = list(getattr(top, "__path__", None) or [])
    if roots:
        return sorted({str(p) for r in roots for p in Path(r).rglob("*.py") if "__pycache__" not in p.parts})
    mod = sys.modules.get(module)
    f = getattr(mod, "__file__", None)
    return [f] if f and f.endswith(".py") and os.path.exists(f) else []


def package_digest(module: str) -> str:
    """SHA-256 over the source files of ``module``'s package (:func:`package_files`)."""
    h = hashlib.sha256()
    for f in package_files(module):
        h.update(f.encode())
        h.update(_file_bytes(f))
    return h.hexdigest()


def _code_bytes(code: _pytypes.CodeType, h: Any) -> list[str]:
    """Feed ``code`` (nested code objects included) to ``h`` without file name and line
    numbers; return the global names it reads."""
    h.update(code.co_code)
    h.update(repr((code.co_names, code.co_varnames, code.co_freevars, code.co_cellvars, code.co_argcount,
                   code.co_kwonlyargcount, code.co_flags)).encode())
    names = list(code.co_names)
    for c in code.co_consts:
        if isinstance(c, _pytypes.CodeType):
            names += _code_bytes(c, h)
        else:
            h.update(repr(c).encode())
    return names


def _function_of(obj: Any) -> _pytypes.FunctionType | None:
    py = getattr(obj, "py_func", obj)
    return py if isinstance(py, _pytypes.FunctionType) else None


def _walked(module: str | None, own: set[str]) -> bool:
    """Whether code of ``module`` is part of the digest: not daebench's (its stamp covers
    it), not a library's, and of one of the packages being walked or without a file."""
    if not module or is_daebench(module) or _top(module) in _LIBRARIES:
        return False
    return _top(module) in own or not package_files(module)


def functions_digest(functions: Iterable[Any], extra: Iterable[str] = ()) -> str:
    """SHA-256 of the code of ``functions`` (Python or numba functions) and of what they
    reach through their globals (module docstring); ``extra`` strings are mixed in."""
    h = hashlib.sha256()
    for x in extra:
        h.update(x.encode())
    todo = [f for f in (_function_of(f) for f in functions) if f is not None]
    own = {_top(f.__module__) for f in todo if f.__module__ and not is_daebench(f.__module__)}
    seen: set[int] = set()
    modules: set[int] = set()
    while todo:
        fn = todo.pop()
        if id(fn) in seen:
            continue
        seen.add(id(fn))
        h.update(f"{fn.__module__}.{fn.__qualname__}".encode())
        for name in _code_bytes(fn.__code__, h):
            value = fn.__globals__.get(name)
            _mix_global(name, value, h, todo, own, modules)
        for cell in fn.__closure__ or ():
            try:
                _mix_global("<cell>", cell.cell_contents, h, todo, own, modules)
            except ValueError:  # an empty cell
                pass
    return h.hexdigest()


def _mix_global(name: str, value: Any, h: Any, todo: list, own: set[str], own_modules: set[int]) -> None:
    if isinstance(value, _SIMPLE):
        h.update(f"{name}={value!r}".encode())
    elif isinstance(value, tuple) and all(isinstance(v, _SIMPLE) for v in value):
        h.update(f"{name}={value!r}".encode())
    elif isinstance(value, (np.ndarray, np.generic)):
        h.update(name.encode() + np.ascontiguousarray(value).tobytes())
    elif isinstance(value, _pytypes.ModuleType):  # `helpers.f(x)`, `helpers.K`: all it defines
        mod = value.__name__
        if _walked(mod, own) and id(value) not in own_modules:
            own_modules.add(id(value))
            h.update(f"{name}:{mod}".encode())
            for k, v in sorted(vars(value).items()):
                if not k.startswith("__") and (getattr(v, "__module__", mod) == mod or isinstance(v, _SIMPLE)):
                    _mix_global(f"{mod}.{k}", v, h, todo, own, own_modules)
    else:
        fn = _function_of(value)
        if fn is not None and _walked(fn.__module__, own):
            todo.append(fn)
        elif isinstance(value, type) and _walked(value.__module__, own):
            h.update(f"{name}:{value.__module__}.{value.__qualname__}{getattr(value, '_fields', '')}".encode())


def is_plugin_function(py_func: Any, plugin_tops: Iterable[str] = ()) -> bool:
    """A compiled function outside daebench that builds on it: its module imports daebench
    (a module, class or function of it among its globals), or belongs to a package that
    registers under daebench's entry points (``plugin_tops``); daebench's own generated
    modules are not."""
    module = getattr(py_func, "__module__", None) or ""
    if is_daebench(module) or generated(module):
        return False
    if _top(module) in plugin_tops:
        return True
    for value in list(getattr(py_func, "__globals__", {}).values()):
        owner = value.__name__ if isinstance(value, _pytypes.ModuleType) else getattr(value, "__module__", None)
        if isinstance(owner, str) and is_daebench(owner):
            return True
    return False
