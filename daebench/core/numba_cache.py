"""numba's on-disk cache, keyed on every compiled source of daebench at once.

numba stamps a cached function with its own file only. A compiled integrator loop here
contains the model kernels and phase functions it calls, which live in other files, so
after an edit of a kernel numba would keep loading the old loop. This locator gives
every daebench function one stamp: a hash of all daebench modules that define numba functions,
plus the versions of numba and of the plugin distributions registered under daebench's
entry points. Any change to any of them recompiles; nothing else does.

Installed by ``daebench/__init__.py`` before any kernel module is imported. Locations
are numba's own (``NUMBA_CACHE_DIR`` if set, else ``__pycache__`` beside the source).
"""

from __future__ import annotations

import hashlib
import io
import os
import pickle
import re
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

from numba.core import caching, config

PACKAGE_DIR = Path(__file__).resolve().parents[1]  # the daebench package
GROUPS = ("daebench.integrators", "daebench.models")
_STAMP: str | None = None
_COMPILED = re.compile(rb"\bnjit\b")


def _plugin_versions() -> list[str]:
    out = set()
    for group in GROUPS:
        for ep in entry_points(group=group):
            if ep.dist is not None and ep.dist.name != "daebench":
                out.add(f"{ep.dist.name}=={ep.dist.version}")
    return sorted(out)


def source_stamp() -> str:
    """The stamp of every cached daebench function (computed once per process)."""
    global _STAMP
    if _STAMP is None:
        import numba

        h = hashlib.sha256(numba.__version__.encode())
        for path in sorted(PACKAGE_DIR.rglob("*.py")):
            text = path.read_bytes()
            if _COMPILED.search(text):
                h.update(str(path.relative_to(PACKAGE_DIR)).encode())
                h.update(text)
        for item in _plugin_versions():
            h.update(item.encode())
        _STAMP = h.hexdigest()
    return _STAMP


def _ours(py_file: str) -> bool:
    try:
        return Path(py_file).resolve().is_relative_to(PACKAGE_DIR)
    except OSError:
        return False


class _PackageStampMixin:
    def get_source_stamp(self):
        return source_stamp()

    @classmethod
    def from_function(cls, py_func, py_file):
        if not _ours(py_file):
            return None
        return super().from_function(py_func, py_file)


class UserDirLocator(_PackageStampMixin, caching.UserProvidedCacheLocator):
    """``NUMBA_CACHE_DIR`` set: cache there, with the package stamp."""


class InTreeLocator(_PackageStampMixin, caching.InTreeCacheLocator):
    """``__pycache__`` beside the source, with the package stamp."""


class Unavailable:
    """Stands in, in a loaded cache index, for a class this process cannot import (a
    plugin's model or method type): the entries that name it can never match a lookup
    here, and every other entry of the index stays usable."""


class _IndexUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> Any:
        try:
            return super().find_class(module, name)
        except (ImportError, AttributeError):
            return Unavailable


def _tolerant_load_index(self: Any) -> dict:
    """numba's index loader (``IndexDataCacheFile._load_index``), but a class the index
    names and this process cannot import costs only the entries that name it.

    A loop compiled for a plugin's model or method keeps that plugin's type in the index
    of the loop's file (daebench's). numba would fail on every compiled call of that loop
    in a process without the plugin; treating the whole index as unreadable instead made
    every such process recompile and then save an index of its own entry only, so the
    cache of the built-ins was thrown away each time a process with the plugin had run."""
    try:
        with open(self._index_path, "rb") as f:
            version = pickle.load(f)
            data = f.read()
    except FileNotFoundError:
        return {}
    if version != self._version:
        return {}
    try:
        stamp, overloads = _IndexUnpickler(io.BytesIO(data)).load()
    except Exception:  # noqa: BLE001 - an index this process cannot read at all is a miss
        return {}
    return overloads if stamp == self._source_stamp else {}


def install() -> None:
    """Put the package-stamped locators first and make index loading tolerant (idempotent)."""
    classes = caching.CacheImpl._locator_classes
    for cls in (InTreeLocator, UserDirLocator):  # UserDirLocator ends up first
        if cls not in classes:
            classes.insert(0, cls)
    caching.IndexDataCacheFile._load_index = _tolerant_load_index


def cache_dir_note() -> str:
    """Where compiled kernels are cached, for messages."""
    return config.CACHE_DIR or os.path.join(str(PACKAGE_DIR), "**", "__pycache__")
