"""numba's on-disk cache: daebench's compiled functions keyed on daebench's compiled
sources at once, a plugin's on its own code.

numba stamps a cached function with its own file only. A compiled integrator loop here
contains the model kernels and phase functions it calls, which live in other files, so
after an edit of a kernel numba would keep loading the old loop. This locator gives
every daebench function one stamp: a hash of all daebench modules that define numba
functions, plus numba's version. Any change to any of them recompiles; nothing else does.

A plugin's code is never part of that stamp (installing, removing or editing a plugin must
not throw away the built-ins' cache). It keys what is compiled of it
(:mod:`daebench.core.code_digest`):

* a plugin's own cached functions (outside daebench, building on it) are stamped with
  numba's stamp of their file, daebench's stamp (daebench code is compiled into them) and
  the digest of their package's source files (:class:`PluginInTreeLocator` and its kin):
  an edit of any file of the package recompiles them;
* a daebench function compiled for a plugin's types (a loop specialised on a plugin's
  method or model data) has the digest of the code registered for those types — walked
  through its globals as loaded — in its index key (:func:`_keyed_index_key`); compiled
  plugin steppers normally reach daebench's loops as compiled values instead
  (:mod:`daebench.stepping.method_handles`), so that an edit recompiles only the plugin's
  entries.

A damaged cache heals itself: every data file carries a SHA-256 of its payload
(:func:`_checked_save_data`); a data file that fails the check or cannot be rebuilt, and an
index that cannot be read, is reported once on stderr, removed, and its kernel compiled
again (:func:`_checked_load`, :func:`_tolerant_load_index`). Before, flipped bytes made
runs fail with ``UnicodeDecodeError`` or ``UnpicklingError`` charged to the integrator,
in every later process.

Installed by ``daebench/__init__.py`` before any kernel module is imported. Locations
are numba's own (``NUMBA_CACHE_DIR`` if set, else ``__pycache__`` beside the source).
"""

from __future__ import annotations

import hashlib
import io
import os
import pickle
import re
import sys
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

from numba.core import caching, config

from daebench.core import code_digest

PACKAGE_DIR = Path(__file__).resolve().parents[1]  # the daebench package
GROUPS = ("daebench.integrators", "daebench.models")
_STAMP: str | None = None
_PLUGINS: dict[str, str] | None = None
DATA_MAGIC = b"daebench-nbc1"   # data files: magic, SHA-256 of the payload, payload
_REPORTED: set[str] = set()
_COMPILED = re.compile(rb"\bnjit\b")


def plugin_packages() -> dict[str, str]:
    """{top-level package of a plugin: "distribution==version"} (computed once per process)."""
    global _PLUGINS
    if _PLUGINS is None:
        _PLUGINS = {}
        for group in GROUPS:
            for ep in entry_points(group=group):
                if ep.dist is not None and ep.dist.name != "daebench":
                    top = ep.value.split(":")[0].split(".")[0].strip()
                    _PLUGINS[top] = f"{ep.dist.name}=={ep.dist.version}"
    return _PLUGINS


def source_stamp() -> str:
    """The stamp of every cached daebench function (computed once per process)."""
    global _STAMP
    if _STAMP is None:
        import numba

        h = hashlib.sha256(numba.__version__.encode())
        for path in sorted(PACKAGE_DIR.rglob("*.py")):
            if "__pycache__" in path.parts:  # generated kernel modules (core.handles) live there
                continue
            text = path.read_bytes()
            if _COMPILED.search(text):
                h.update(str(path.relative_to(PACKAGE_DIR)).encode())
                h.update(text)
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


class _PluginStampMixin:
    """A plugin's cached function (:func:`daebench.core.code_digest.is_plugin_function`):
    numba's stamp of its own file (or notebook cell), daebench's stamp (the daebench
    functions it calls are compiled into it) and the digest of its package's source files
    (the plugin's other files: helpers, constants)."""

    _plugin_module = ""

    def get_source_stamp(self):
        return (super().get_source_stamp(), source_stamp(), code_digest.package_digest(self._plugin_module))

    @classmethod
    def from_function(cls, py_func, py_file):
        if _ours(py_file) or not code_digest.is_plugin_function(py_func, plugin_packages()):
            return None
        self = super().from_function(py_func, py_file)
        if self is not None:
            self._plugin_module = py_func.__module__
        return self


class PluginUserDirLocator(_PluginStampMixin, caching.UserProvidedCacheLocator):
    """A plugin's function, ``NUMBA_CACHE_DIR`` set."""


class PluginInTreeLocator(_PluginStampMixin, caching.InTreeCacheLocator):
    """A plugin's function, ``__pycache__`` beside its source."""


class PluginUserWideLocator(_PluginStampMixin, caching.UserWideCacheLocator):
    """A plugin's function whose source folder cannot be written (an installed package)."""


class PluginNotebookLocator(_PluginStampMixin, caching.IPythonCacheLocator):
    """A plugin's function defined in a notebook cell."""


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


def report_damaged(path: str, why: str) -> None:
    """Remove a damaged cache file and say so on stderr, once per file and process."""
    try:
        os.unlink(path)
    except OSError:
        pass
    if path not in _REPORTED:
        _REPORTED.add(path)
        sys.stderr.write(f"daebench: the compiled-kernel cache file {path} was damaged ({why}); it was removed "
                         f"and its kernel is compiled again (once)\n")


_original_index_key = caching.Cache._index_key


def _plugin_classes(ty: Any, out: dict[type, None]) -> None:
    """The Python classes from outside daebench that numba type ``ty`` names (data
    tuples of a plugin's method or model, at any depth)."""
    from numba.core import types

    cls = getattr(ty, "instance_class", None)
    if isinstance(cls, type) and not code_digest.is_daebench(cls.__module__) and cls.__module__ != "builtins":
        out[cls] = None
    if isinstance(ty, types.BaseTuple):
        for t in ty.types:
            _plugin_classes(t, out)


_CLASS_DIGESTS: dict[tuple, str] = {}


def class_digest(cls: type) -> str:
    """The digest of the code registered for data class ``cls`` (its stepper's or kernels'
    implementations, :data:`daebench.core.dispatch.IMPLEMENTATIONS`) and of its fields."""
    from daebench.core.dispatch import IMPLEMENTATIONS

    impls = tuple(IMPLEMENTATIONS.get(cls, {}).values())
    key = (cls, *map(id, impls))
    if key not in _CLASS_DIGESTS:
        _CLASS_DIGESTS[key] = code_digest.functions_digest(
            impls, [f"{cls.__module__}.{cls.__qualname__}{getattr(cls, '_fields', '')}"])
    return _CLASS_DIGESTS[key]


def _keyed_index_key(self: Any, sig: Any, codegen: Any) -> tuple:
    """numba's index key, plus the code digests of the plugin classes the signature names."""
    key = _original_index_key(self, sig, codegen)
    if not _ours(self._py_func.__code__.co_filename):
        return key
    named: dict[type, None] = {}
    for ty in sig if isinstance(sig, tuple) else getattr(sig, "args", ()):
        _plugin_classes(ty, named)
    if named:
        digests = tuple(sorted(f"{c.__module__}.{c.__qualname__}={class_digest(c)}" for c in named))
        key = key[:-1] + (tuple(key[-1]) + digests,)
    return key


_original_save_data = caching.IndexDataCacheFile._save_data
_original_load = caching.IndexDataCacheFile.load


def _checked_save_data(self: Any, name: str, data: Any) -> None:
    """numba's data writer with a checksum (daebench's functions: magic, SHA-256 of the
    payload, payload; other functions' files stay numba's own format)."""
    if self._source_stamp != source_stamp():
        return _original_save_data(self, name, data)
    payload = self._dump(data)
    with self._open_for_write(self._data_path(name)) as f:
        f.write(DATA_MAGIC + hashlib.sha256(payload).digest() + payload)


def _checked_load(self: Any, key: Any) -> Any:
    """numba's entry loader; a data file that fails its checksum or unpickling is
    reported, removed and treated as a miss (the kernel is compiled and saved again)."""
    if self._source_stamp != source_stamp():
        return _original_load(self, key)
    name = self._load_index().get(key)
    if name is None:
        return None
    path = self._data_path(name)
    try:
        with open(path, "rb") as f:
            blob = f.read()
    except OSError:  # removed while the index still names it
        return None
    n = len(DATA_MAGIC)
    if not blob.startswith(DATA_MAGIC) or len(blob) < n + 32:
        report_damaged(path, f"{len(blob)} bytes without the checksum header: empty, truncated or overwritten")
        return None
    payload = blob[n + 32:]
    if hashlib.sha256(payload).digest() != blob[n:n + 32]:
        report_damaged(path, "checksum mismatch: bytes changed after it was written")
        return None
    try:
        return pickle.loads(payload)
    except Exception as exc:  # noqa: BLE001 - the checksum held, yet it cannot be read back
        report_damaged(path, f"{type(exc).__name__} while reading it")
        return None


_original_load_overload = caching.Cache._load_overload


def _guarded_load_overload(self: Any, sig: Any, target_context: Any) -> Any:
    """numba's cache lookup; an entry that cannot be rebuilt is a miss, not an error of the run."""
    try:
        return _original_load_overload(self, sig, target_context)
    except Exception as exc:  # noqa: BLE001 - a cache must never fail a run
        report_damaged(getattr(self._cache_file, "_index_path", "?"), f"{type(exc).__name__} while loading")
        return None


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
    except (FileNotFoundError, IsADirectoryError):
        return {}
    except Exception as exc:  # noqa: BLE001 - random bytes, an empty or truncated index
        report_damaged(self._index_path, f"{type(exc).__name__} while reading its version")
        return {}
    if version != self._version:
        return {}
    try:
        stamp, overloads = _IndexUnpickler(io.BytesIO(data)).load()
    except Exception as exc:  # noqa: BLE001 - an index this process cannot read at all
        report_damaged(self._index_path, f"{type(exc).__name__} while reading it")
        return {}
    if not isinstance(overloads, dict):
        report_damaged(self._index_path, "not an index")
        return {}
    return overloads if stamp == self._source_stamp else {}


def install() -> None:
    """Put the package-stamped and plugin-stamped locators first, make index loading
    tolerant, data files checksummed and plugin code part of the keys that name plugin
    types (idempotent)."""
    classes = caching.CacheImpl._locator_classes
    for cls in (PluginNotebookLocator, PluginUserWideLocator, PluginInTreeLocator, PluginUserDirLocator,
                InTreeLocator, UserDirLocator):  # UserDirLocator ends up first, then daebench's, then plugins'
        if cls not in classes:
            classes.insert(0, cls)
    caching.IndexDataCacheFile._load_index = _tolerant_load_index
    caching.IndexDataCacheFile._save_data = _checked_save_data
    caching.IndexDataCacheFile.load = _checked_load
    caching.Cache._index_key = _keyed_index_key
    caching.Cache._load_overload = _guarded_load_overload


def cache_dir_note() -> str:
    """Where compiled kernels are cached, for messages."""
    return config.CACHE_DIR or os.path.join(str(PACKAGE_DIR), "**", "__pycache__")
