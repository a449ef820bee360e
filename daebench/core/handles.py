"""Model kernels as compiled values: every integrator loop compiles once for all models.

A model registers its kernels on its own data class (:mod:`daebench.core.kernels`), and
numba's static dispatch would specialise every caller — each integrator loop, each phase
function — on that class: the loops would compile once per (integrator, model) pair.
Instead, a phase carries a :class:`ModelHandle` of one type for every model:

* ``fns`` — the entry addresses of the model's six kernels, each compiled once per model
  with the one signature of :data:`SIGNATURES` (a kernel the model leaves to the defaults of
  :mod:`daebench.core.kernels` — finite-difference Jacobians, no constraints … — is one
  entry compiled once for every model, which reaches the model's own kernels through
  ``i[0]``: a new model compiles only what it wrote); a caller turns an address into a
  first-class function value (:func:`_function_at`) and calls it with numba's own calling
  convention, so a kernel's exception (a division by zero, the default ``gap``'s guard)
  reaches the caller as from any compiled call;
* ``f`` — the model data's float scalars;
* ``i`` — the address of ``fns`` (``i[0]``), the model data's int and bool scalars and,
  for every array, its address and shape.

Each compiled kernel rebuilds the model's own data tuple from ``f`` and ``i`` (arrays as
views of the model's memory, numba.carray's intrinsic: no copy, no reference counting) and calls
the kernel the model registered; model code does not change, and a plugin model still
registers kernels only. The rebuilding code is generated once per data layout (field
kinds, dtypes, array ranks — not sizes, so every mesh of a model shares it) into a small
module under the numba cache directory (``NUMBA_CACHE_DIR``, else ``~/.cache/daebench``),
named by daebench's source stamp and the code of the kernels the model registered (and of what
they reach: :func:`daebench.core.code_digest.functions_digest`), so it caches on disk like the rest (:func:`_generated_module`). A handle
holds only numbers: passing it from Python costs what passing three arrays costs; it
cannot be pickled (its addresses mean nothing in another process).

The handle keeps the model data alive and reads its arrays in place: a later in-place
change (the interactive-mode method's held contact force) is seen by the kernels.

Python models (:class:`daebench.core.kernels.PyModel`) and ``DAEBENCH_COMPILED=0`` keep
their data as it is: :func:`handle` returns it unchanged.
"""

from __future__ import annotations

import importlib.util
import os
import stat
import sys
import tempfile
import threading
import weakref
from pathlib import Path
from typing import Any, NamedTuple

import numba
import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.core.extending import intrinsic
from numba.np.arrayobj import get_cfarray_intrinsic

from daebench.core import code_digest, kernels
from daebench.core.borrow import uncounted
from daebench.core.kernels import KernelError

_F = types.float64[::1]
_I = types.int64[::1]
_V = types.float64[:]
_R = types.Array(types.float64, 1, "A", readonly=True)  # inputs: IDA hands in read-only views
_M = types.float64[:, :]
#: the one signature of each kernel over (f, i, …): every model's compiled kernels have these types
SIGNATURES = {
    "mass_force": types.void(_F, _I, types.float64, _R, _R, _M, _V),
    "force_jacobian": types.void(_F, _I, types.float64, _R, _R, _M, _M),
    "mass_jacobian_product": types.void(_F, _I, _R, _R, _M),
    "constraints": types.void(_F, _I, types.float64, _R, _R, _V, _M, _V, _V),
    "gap": types.UniTuple(types.float64, 2)(_F, _I, types.int64, _R, _R, _V),
    "tangent": types.float64(_F, _I, types.int64, _R, _R, _V),
}
_ARGS = {"mass_force": "t, q, v, M, Q", "force_jacobian": "t, q, v, Kq, Kv",
         "mass_jacobian_product": "q, a, K", "constraints": "t, q, v, C, Cq, Ct, gam",
         "gap": "idx, q, v, gq", "tangent": "idx, q, v, tq"}
_DTYPES = {np.dtype(np.float64): "_f64_at", np.dtype(np.int64): "_i64_at", np.dtype(np.bool_): "_b1_at"}
_LAYOUT_VERSION = "5"


class ModelHandle(NamedTuple):
    """A model's kernels and data in the one layout every compiled loop is typed for."""

    fns: np.ndarray     # int64: the six compiled kernels' entry addresses, in kernels.KERNELS order
    f: np.ndarray       # float64: the data's float scalars
    i: np.ndarray       # int64: the data's int and bool scalars, every array's address and shape

    def __reduce__(self):
        raise TypeError("a ModelHandle holds memory addresses of this process and cannot be pickled; "
                        "send the scene or the system and make the handle where it runs")


def _pointer_at(dtype):
    @intrinsic
    def at(typingctx, addr):
        sig = types.CPointer(dtype)(types.int64)

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(types.CPointer(dtype)))

        return sig, codegen

    return at


#: numba.carray's own intrinsic: inlined where it is used, so no function returns the view (numba
#: refuses that in a function compiled without reference counting)
_carray = get_cfarray_intrinsic("C", None)
_f64_at = _pointer_at(types.float64)
_i64_at = _pointer_at(types.int64)
_b1_at = _pointer_at(types.boolean)


def function_value(fntype):
    """The codegen of an intrinsic whose first argument is a compiled function's address: a
    first-class function value of ``fntype``, called with numba's own calling convention
    (its ``jit_addr``), so that its exception reaches the caller as from any compiled call."""

    def codegen(context, builder, signature, args):
        fn = cgutils.create_struct_proxy(fntype)(context, builder)
        null = context.get_constant_null(types.voidptr)
        fn.c_addr = null
        fn.py_addr = null
        fn.jit_addr = builder.inttoptr(args[0], context.get_value_type(types.voidptr))
        return fn._getvalue()

    return codegen


def _function_at(sig):
    """An intrinsic turning a kernel's address into a first-class function value of
    signature ``sig`` (:func:`function_value`)."""
    fntype = types.FunctionType(sig)

    @intrinsic
    def at(typingctx, addr):
        return fntype(types.int64), function_value(fntype)

    return at


_mass_force_at, _force_jacobian_at, _mass_jacobian_product_at, _constraints_at, _gap_at, _tangent_at = (
    _function_at(SIGNATURES[name]) for name in kernels.KERNELS)


# -- the layout of one data value ----------------------------------------------------------------
class _Layout:
    """Walks a data value once: the expression that rebuilds it from (f, i), the classes it
    names, and the scalars and array descriptors that fill f and i."""

    def __init__(self) -> None:
        self.f: list[float] = [0.0]   # never empty (numba types an empty list's array alike)
        self.i: list[int] = [0]
        self.classes: list[type] = []
        self.key: list[str] = []

    def expr(self, value: Any, where: str) -> str:
        if isinstance(value, tuple) and hasattr(type(value), "_fields"):
            cls = type(value)
            if cls not in self.classes:
                self.classes.append(cls)
            self.key.append(f"{cls.__module__}.{cls.__qualname__}(")
            parts = [self.expr(getattr(value, n), f"{where}.{n}") for n in cls._fields]
            self.key.append(")")
            return f"_C{self.classes.index(cls)}({', '.join(parts)})"
        if isinstance(value, tuple):
            self.key.append("(")
            parts = [self.expr(x, f"{where}[{k}]") for k, x in enumerate(value)]
            self.key.append(")")
            return "(" + "".join(p + ", " for p in parts) + ")"
        if isinstance(value, (bool, np.bool_)):
            self.key.append("b")
            self.i.append(int(value))
            return f"bool(i[{len(self.i) - 1}])"
        if isinstance(value, (int, np.integer)):
            self.key.append("i")
            self.i.append(int(value))
            return f"i[{len(self.i) - 1}]"
        if isinstance(value, (float, np.floating)):
            self.key.append("f")
            self.f.append(float(value))
            return f"f[{len(self.f) - 1}]"
        if isinstance(value, np.ndarray):
            at = _DTYPES.get(value.dtype)
            if at is None or value.ndim == 0:
                raise KernelError(f"model data field {where}: arrays must be float64, int64 or bool with "
                                  f"at least one dimension (got {value.dtype}, ndim {value.ndim})")
            if not value.flags.c_contiguous:
                raise KernelError(f"model data field {where}: the array must be C-contiguous "
                                  "(np.ascontiguousarray when the data is built)")
            self.key.append(f"{at}{value.ndim}")
            k = len(self.i)
            self.i.extend([value.ctypes.data, *value.shape])
            shape = ", ".join(f"i[{k + 1 + d}]" for d in range(value.ndim))
            return f"_carray({at}(i[{k}]), ({shape},))"
        raise KernelError(f"model data field {where}: {type(value).__name__} is not a kernel value "
                          "(use float, int, bool, float64/int64/bool arrays, or tuples of them)")


def _source(layout: _Layout, expr: str, names: tuple[str, ...]) -> str:
    lines = ["# generated by daebench.core.handles: a model's kernels over (f, i) (do not edit)",
             "import numba", "from numba import njit",
             "from daebench.core import kernels as _kernels",
             "from daebench.core.handles import SIGNATURES as _S, _carray, _f64_at, _i64_at, _b1_at"]
    for k, cls in enumerate(layout.classes):
        lines.append(f"from {cls.__module__} import {cls.__qualname__} as _C{k}")
    lines += ["", "", "@njit(inline='always')", "def _unpack(f, i):", f"    return {expr}", ""]
    for name in names:
        args = _ARGS[name]
        impl = getattr(kernels, name).implementation(layout.classes[0])
        # the registered kernel's code is inlined into the entry (one compile instead of two, no
        # second optimisation of linked code); a fastmath kernel keeps its own compile and flags
        inline = not getattr(impl, "targetoptions", {}).get("fastmath")
        lines += [f"_{name} = getattr(_kernels, {name!r}).implementation(_C0)"
                  + (f"\n_{name} = njit(inline='always')(_{name}.py_func)" if inline else ""), "", "",
                  f"@njit(_S[{name!r}], cache=True)", f"def {name}(f, i, {args}):",
                  f"    return _{name}(_unpack(f, i), {args})", "", ""]
    return "\n".join(lines).rstrip() + "\n"


def _directory() -> Path:
    """A folder for the generated modules that only this user can write: owned by this user,
    not writable by group or others (a shared temporary folder planted by someone else is
    passed over), created 0700 when missing."""
    # outside the package: source scanners (layers test, packaging) must not see generated code
    roots = [Path(numba.config.CACHE_DIR)] if numba.config.CACHE_DIR else []
    roots += [Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "daebench",
              Path(tempfile.gettempdir()) / f"daebench-numba-{os.getuid()}"]
    for root in roots:
        d = root / "daebench-handles"
        try:
            d.mkdir(mode=0o700, parents=True, exist_ok=True)
            if _private(d):
                return d
        except OSError:
            continue
    raise OSError(f"no private writable directory for daebench's generated kernel modules (tried {roots}: each "
                  f"must be owned by you and not writable by others); set NUMBA_CACHE_DIR to such a directory")


def _private(d: Path) -> bool:
    """``d`` is a real folder owned by this user, writable by it and by nobody else."""
    st = os.lstat(d)
    return (stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid() and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)
            and os.access(d, os.W_OK))


_MODULES: dict[tuple, Any] = {}


def load_generated(name: str, path: Path, text: str, namespace: dict[str, Any] | None = None) -> Any:
    """The module ``name`` of the generated source ``text`` (its globals first filled from
    ``namespace``), kept at ``path`` because numba's on-disk cache keys compiled code on a
    file. What runs is ``text``, never what the file holds: a line planted in it does not
    run, and a file that differs (planted, truncated, older) is written anew before its code
    is cached. Every generated module of daebench loads through here."""
    try:
        same = path.read_bytes() == text.encode()
    except OSError:
        same = False
    if not same:
        tmp = path.with_suffix(f".{os.getpid()}.{threading.get_ident()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)  # concurrent workers write the same text: either copy is right
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    module.__dict__.update(namespace or {})
    sys.modules[name] = module
    exec(compile(text, str(path), "exec"), module.__dict__)
    return module


def _generated_module(layout: _Layout, expr: str) -> Any:
    from daebench.core import numba_cache

    cls = layout.classes[0]
    impls = tuple(getattr(kernels, k).implementation(cls) for k in kernels.KERNELS)
    made = (cls, impls, *layout.key)  # a kernel registered anew in this process makes a new module
    if made in _MODULES:
        return _MODULES[made]
    # the registered kernels' code, and what they reach, is part of the name: a plugin (or a
    # notebook's model) edited without a version bump must not load another kernel's machine code
    digest = code_digest.functions_digest(impls, [_LAYOUT_VERSION, numba_cache.source_stamp(), *layout.key])
    name = f"_daebench_handle_{cls.__name__.lower()}_{digest[:16]}"
    path = _directory() / f"{name}.py"
    own = tuple(k for k, f in zip(kernels.KERNELS, impls) if _shared(k, f) is None)
    text = _source(layout, expr, own)
    module = load_generated(name, path, text)
    module.__daebench_fns__ = np.array([_jit_address(getattr(module, k) if k in own else _shared(k, f), SIGNATURES[k])
                                        for k, f in zip(kernels.KERNELS, impls)], dtype=np.int64)
    module.__daebench_fns__.flags.writeable = False
    _MODULES[made] = module
    return module


_KEEP: dict[int, Any] = {}


def handle(md: Any) -> Any:
    """The :class:`ModelHandle` of a model's kernel data ``md`` (``md`` itself for a Python
    model and under ``DAEBENCH_COMPILED=0``). The handle keeps ``md`` alive: its arrays are
    read in place, so a kernel sees every later in-place change of them."""
    if numba.config.DISABLE_JIT or isinstance(md, (kernels.PyModel, ModelHandle)):
        return md
    if not kernels.registered(type(md)):
        raise KernelError(f"{type(md).__name__}: no kernels registered for this data class "
                          "(daebench.core.kernels.register)")
    layout = _Layout()
    expr = layout.expr(md, type(md).__name__)
    module = _generated_module(layout, expr)
    i = np.array(layout.i, dtype=np.int64)
    i[0] = module.__daebench_fns__.ctypes.data  # the shared default kernels find the model's own here (_self)
    _KEEP[id(i)] = md
    weakref.finalize(i, _KEEP.pop, id(i), None)
    return ModelHandle(module.__daebench_fns__, np.array(layout.f, dtype=np.float64), i)


def _jit_address(dispatcher: Any, sig: Any) -> int:
    cres = dispatcher.get_compile_result(sig)
    return int(cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name))


# -- the handle's own kernels: call the model's through their addresses ---------------------
def _h_mass_force(md, t, q, v, M, Q):
    _mass_force_at(md.fns[0])(md.f, md.i, t, q, v, M, Q)


def _h_force_jacobian(md, t, q, v, Kq, Kv):
    _force_jacobian_at(md.fns[1])(md.f, md.i, t, q, v, Kq, Kv)


def _h_mass_jacobian_product(md, q, a, K):
    _mass_jacobian_product_at(md.fns[2])(md.f, md.i, q, a, K)


def _h_constraints(md, t, q, v, C, Cq, Ct, gam):
    _constraints_at(md.fns[3])(md.f, md.i, t, q, v, C, Cq, Ct, gam)


def _h_gap(md, i, q, v, gq):
    return _gap_at(md.fns[4])(md.f, md.i, i, q, v, gq)


def _h_tangent(md, i, q, v, tq):
    return _tangent_at(md.fns[5])(md.f, md.i, i, q, v, tq)


kernels.register(ModelHandle, mass_force=uncounted(_h_mass_force), force_jacobian=uncounted(_h_force_jacobian),
                 mass_jacobian_product=uncounted(_h_mass_jacobian_product), constraints=uncounted(_h_constraints),
                 gap=uncounted(_h_gap), tangent=uncounted(_h_tangent))


# -- the default kernels, compiled once for every model ------------------------------------------
@njit(inline="always")
def _self(f, i):
    """The handle of the model whose (f, i) these are: ``i[0]`` holds its kernels' addresses."""
    return ModelHandle(_carray(_i64_at(i[0]), (len(kernels.KERNELS),)), f, i)


# A kernel the model did not register is not compiled with the model: its entry is one of
# these, compiled once (for every model, on disk), the default of core.kernels run over the
# handle — the finite differences call the model's own compiled mass_force through its address.
@njit(cache=True)
def _default_force_jacobian(f, i, t, q, v, Kq, Kv):
    kernels._fd_force_jacobian(_self(f, i), t, q, v, Kq, Kv)


@njit(cache=True)
def _default_mass_jacobian_product(f, i, q, a, K):
    kernels._fd_mass_jacobian_product(_self(f, i), q, a, K)


@njit(cache=True)
def _constant_mass(f, i, q, a, K):
    kernels.constant_mass(_self(f, i), q, a, K)


@uncounted
def _default_constraints(f, i, t, q, v, C, Cq, Ct, gam):
    kernels._no_constraints(_self(f, i), t, q, v, C, Cq, Ct, gam)


@uncounted
def _default_gap(f, i, idx, q, v, gq):
    return kernels._no_gap(_self(f, i), idx, q, v, gq)


@uncounted
def _default_tangent(f, i, idx, q, v, tq):
    return kernels._no_friction(_self(f, i), idx, q, v, tq)


_SHARED = {("force_jacobian", kernels._fd_force_jacobian): _default_force_jacobian,
           ("mass_jacobian_product", kernels._fd_mass_jacobian_product): _default_mass_jacobian_product,
           ("mass_jacobian_product", kernels.constant_mass): _constant_mass,
           ("constraints", kernels._no_constraints): _default_constraints,
           ("gap", kernels._no_gap): _default_gap,
           ("tangent", kernels._no_friction): _default_tangent}


def compile_shared_defaults() -> None:
    """Compile (or load from the cache) every shared default entry: library code, paid once
    per cache by the first model that leaves a kernel to its default (the new-model study
    warms them with the loops, so that a new model's figure is its own code)."""
    for (name, _), entry in _SHARED.items():
        _jit_address(entry, SIGNATURES[name])


def _shared(name: str, implementation: Any) -> Any:
    """The shared compiled entry of kernel ``name`` when ``implementation`` is one of the
    defaults of :mod:`daebench.core.kernels`, else None (the model's own kernel)."""
    return _SHARED.get((name, implementation))
