"""Static dispatch on the type of a data tuple: the one mechanism behind model kernels
(:mod:`daebench.core.kernels`) and integrator step kernels (:mod:`daebench.stepping`).

A *generic* is a function whose first argument is a ``typing.NamedTuple`` instance (a
model's or a method's data). Each data class registers its own implementation. In
compiled code numba picks the implementation from the argument's type when it compiles
the caller (``numba.extending.overload``): no branch, no table of kinds, and every
caller is specialized — and cached on disk — per data class. From Python (and with
``DAEBENCH_COMPILED=0``) the generic dispatches on ``type(data)``.
"""

from __future__ import annotations

import functools
import inspect
from typing import Any, Callable

import numba
from numba import njit, types
from numba.extending import overload


class DispatchError(TypeError):
    """No implementation is registered for this data class."""


#: data class → every implementation registered for it, by any generic (what the code
#: digest of a plugin's data class covers: :func:`daebench.core.numba_cache.class_digest`)
IMPLEMENTATIONS: dict[type, dict[str, Callable]] = {}


def _data_class(tp: Any) -> type | None:
    if isinstance(tp, (types.NamedTuple, types.NamedUniTuple)):
        return tp.instance_class
    return None


def _adapter(name: str, params: str, fn: Callable) -> Callable:
    """A plain function with the generic's exact parameter names calling ``fn`` (numba
    compiles what an overload returns, and wants the generic's names)."""
    scope: dict[str, Any] = {"fn": fn}
    exec(f"def {name}_impl({params}):\n    return fn({params})\n", scope)
    return scope[f"{name}_impl"]


def _is_named_tuple_class(cls: Any) -> bool:
    return isinstance(cls, type) and issubclass(cls, tuple) and hasattr(cls, "_fields")


def generic(template: Callable) -> Callable:
    """Turn ``template`` (signature and docstring only) into a generic function with a
    ``register(data_class, implementation)`` method."""
    sig = inspect.signature(template)
    params = ", ".join(sig.parameters)
    name = template.__name__
    impls: dict[type, Callable] = {}
    adapters: dict[type, Callable] = {}
    uncounted: set[type] = set()  # implementations compiled without reference counting (core.borrow)

    @functools.wraps(template)
    def function(*args):
        fn = impls.get(type(args[0]))
        if fn is None:
            raise DispatchError(f"{name}: nothing registered for {type(args[0]).__name__}")
        return fn(*args)

    def typer_for(counted: bool) -> Callable:
        def typer(*args):
            cls = _data_class(args[0])
            if (cls in uncounted) == counted:
                return None
            return adapters.get(cls)  # None: numba reports the typing error

        typer.__signature__ = sig
        return typer

    def register(data_class: type, implementation: Callable) -> None:
        if not _is_named_tuple_class(data_class):
            raise DispatchError(f"{data_class!r} must be a typing.NamedTuple class")
        if not hasattr(implementation, "py_func") and not numba.config.DISABLE_JIT:
            implementation = njit(cache=True)(implementation)
        impls[data_class] = implementation
        IMPLEMENTATIONS.setdefault(data_class, {})[name] = implementation
        py = getattr(implementation, "py_func", implementation)
        same = list(inspect.signature(py).parameters) == list(sig.parameters)
        # numba compiles what the overload returns: the implementation's own Python
        # function when its parameters carry the generic's names (one compile), else an
        # adapter that calls it
        adapters[data_class] = py if same else _adapter(name, params, implementation)
        if getattr(implementation, "targetoptions", {}).get("_nrt", True) is False:
            uncounted.add(data_class)
        else:
            uncounted.discard(data_class)

    function.register = register
    function.registered = lambda data_class: data_class in impls
    function.implementation = lambda data_class: impls[data_class]
    # numba compiles an overload's implementation with the overload's options: one overload
    # for implementations with reference counting, one for those without — both explicit, or
    # numba would inherit the caller's (an object-mode Python kernel needs counting even when
    # an uncounted phase function calls it)
    overload(function, jit_options={"_nrt": True})(typer_for(True))
    overload(function, jit_options={"_nrt": False})(typer_for(False))
    return function
