"""Calling the SUNDIALS libraries that scikit-sundae's wheel ships, from Python (ctypes)
and from compiled code (numba intrinsics), for :mod:`daebench.stepping.ida_native`.

Compiled code reaches a C function through its address, passed as an integer and called
with :func:`ccall` (int64 stands for any pointer): the compiled functions hold no ctypes
objects, so they cache on disk. The libraries are found from the installed package
(``scikit_sundae.libs`` next to ``sksundae``), never from a fixed path.
"""

from __future__ import annotations

import ctypes
import glob
import os

import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


# -- calling C through an address -------------------------------------------------------------


@intrinsic
def ccall(typingctx, ret, addr, args):
    """Call the C function at ``addr`` with the tuple ``args`` (int64 stands for any
    pointer, float64 for double, int32 for int); ``ret`` is a number class: int32 or int64."""
    rtype = ret.instance_type

    def codegen(context, builder, sig, llargs):
        _, fn_addr, tup = llargs
        tys = sig.args[2]
        vals = [builder.extract_value(tup, i) for i in range(len(tys))]
        fnty = ir.FunctionType(context.get_value_type(rtype), [context.get_value_type(t) for t in tys])
        fptr = builder.inttoptr(fn_addr, fnty.as_pointer())
        return builder.call(fptr, vals)

    return rtype(ret, addr, args), codegen


@intrinsic
def address_of(typingctx, val):
    """Address of a stack copy of ``val`` (valid while the calling function runs)."""

    def codegen(context, builder, sig, args):
        slot = cgutils.alloca_once(builder, args[0].type)
        builder.store(args[0], slot)
        return builder.ptrtoint(slot, ir.IntType(64))

    return types.int64(val), codegen


@intrinsic
def double_ptr(typingctx, addr):
    """An int64 address as a float64 pointer (for :func:`numba.carray`)."""

    def codegen(context, builder, sig, args):
        return builder.inttoptr(args[0], ir.DoubleType().as_pointer())

    return types.CPointer(types.float64)(addr), codegen


#: numba types that :func:`deref_key` reads, by their :func:`type_key`
_KEYED_TYPES: dict[str, types.Type] = {}


def type_key(ty: types.Type) -> str:
    """A text naming the numba type ``ty`` (its full structure), registered for
    :func:`deref_key`. A compiled C callback that closes over this text instead of the
    type caches on disk: numba keys a cached closure by the pickle of its closure
    variables, and the pickle of a numba type differs from one process to the next (a
    callback closing over the type was compiled — 1.9 s — and saved again by every
    process, its cache file growing by one entry each time)."""
    key = f"{type(ty).__module__}.{type(ty).__qualname__}:{ty}"
    known = _KEYED_TYPES.setdefault(key, ty)
    if known != ty:
        raise RuntimeError(f"two numba types share the key {key!r}")
    return key


@intrinsic
def deref_key(typingctx, ptr, key):
    """The value of the numba type registered under the literal text ``key``
    (:func:`type_key`) at ``**ptr`` (``ptr`` a ``void*`` to the int64 address of the
    value); increfs what it returns."""
    if not isinstance(key, types.StringLiteral):
        return None
    ty = _KEYED_TYPES[key.literal_value]

    def codegen(context, builder, sig, args):
        llty = context.get_value_type(ty)
        addr = builder.load(builder.bitcast(args[0], ir.IntType(64).as_pointer()))
        val = builder.load(builder.inttoptr(addr, llty.as_pointer()))
        context.nrt.incref(builder, ty, val)
        return val

    return ty(types.voidptr, key), codegen


# -- the libraries --------------------------------------------------------------------------------
class NativeUnavailable(RuntimeError):
    """The SUNDIALS libraries of scikit-sundae were not found."""


_FUNCS = {  # name: (library stem, restype, argtypes); P = pointer
    "SUNContext_Create": ("core", "i", "iP"), "SUNContext_Free": ("core", "i", "P"),
    "SUNContext_ClearErrHandlers": ("core", "i", "P"),
    "N_VNew_Serial": ("nvecserial", "P", "iP"), "N_VDestroy": ("core", "v", "P"),
    "N_VGetArrayPointer": ("core", "P", "P"),
    "SUNDenseMatrix": ("sunmatrixdense", "P", "iiP"), "SUNDenseMatrix_Data": ("sunmatrixdense", "P", "P"),
    "SUNMatDestroy": ("core", "v", "P"),
    "SUNLinSol_Dense": ("sunlinsoldense", "P", "PPP"), "SUNLinSolFree": ("core", "i", "P"),
    "IDACreate": ("ida", "P", "P"), "IDAInit": ("ida", "i", "PPdPP"), "IDAReInit": ("ida", "i", "PdPP"),
    "IDASVtolerances": ("ida", "i", "PdP"), "IDASetUserData": ("ida", "i", "PP"),
    "IDASetLinearSolver": ("ida", "i", "PPP"), "IDASetJacFn": ("ida", "i", "PP"),
    "IDASetMaxNonlinIters": ("ida", "i", "Pi"), "IDASetMaxConvFails": ("ida", "i", "Pi"),
    "IDASetId": ("ida", "i", "PP"), "IDASetInitStep": ("ida", "i", "Pd"), "IDASetMinStep": ("ida", "i", "Pd"),
    "IDASetMaxStep": ("ida", "i", "Pd"), "IDASetMaxOrd": ("ida", "i", "Pi"),
    "IDASetMaxNumSteps": ("ida", "i", "Pl"), "IDASetStopTime": ("ida", "i", "Pd"),
    "IDAClearStopTime": ("ida", "i", "P"), "IDASolve": ("ida", "i", "PdPPPi"),
    "IDAGetNumResEvals": ("ida", "i", "PP"), "IDAGetSolution": ("ida", "i", "PdPP"), "IDAGetNumJacEvals": ("ida", "i", "PP"),
    "IDAFree": ("ida", "v", "P"),
}
_CT = {"i": ctypes.c_int, "P": ctypes.c_void_p, "d": ctypes.c_double, "l": ctypes.c_long, "v": None}
# addresses handed to compiled code, by index
_ADDR_NAMES = ("IDASetStopTime", "IDASolve", "IDAClearStopTime", "N_VGetArrayPointer", "SUNDenseMatrix_Data",
               "IDASetUserData", "IDAGetNumResEvals", "IDAGetNumJacEvals", "IDAGetSolution")
A_STOP, A_SOLVE, A_CLEAR, A_NVDATA, A_MATDATA, A_USERDATA, A_NRES, A_NJAC, A_GETSOL = range(len(_ADDR_NAMES))


def library_dir() -> str:
    """The folder of the SUNDIALS libraries scikit-sundae's wheel ships (found from the
    installed package)."""
    try:
        import sksundae
    except ImportError as exc:  # pragma: no cover - sksundae is a dependency
        raise NativeUnavailable(f"scikit-sundae is not installed ({exc}); install it or use backend=sksundae") from None
    pkg = os.path.dirname(os.path.abspath(sksundae.__file__))
    for cand in (os.path.join(os.path.dirname(pkg), "scikit_sundae.libs"), os.path.join(pkg, ".libs"), pkg):
        if glob.glob(os.path.join(cand, "libsundials_ida*.so*")):
            return cand
    raise NativeUnavailable(f"no libsundials_ida*.so next to {pkg}; use the setting backend=sksundae")


class _Lib:
    """The SUNDIALS functions as ctypes functions (for set-up) and addresses (for compiled code)."""

    def __init__(self) -> None:
        import sksundae.ida  # noqa: F401  (loads the libraries and their dependencies first)

        folder = library_dir()
        libs = {}
        for stem in {v[0] for v in _FUNCS.values()}:
            found = sorted(glob.glob(os.path.join(folder, f"libsundials_{stem}-*.so*")) or
                           glob.glob(os.path.join(folder, f"libsundials_{stem}.so*")))
            if not found:
                raise NativeUnavailable(f"libsundials_{stem} not found in {folder}; use backend=sksundae")
            libs[stem] = ctypes.CDLL(found[0], mode=ctypes.RTLD_GLOBAL)
        for name, (stem, res, args) in _FUNCS.items():
            fn = getattr(libs[stem], name)
            fn.restype = _CT[res]
            fn.argtypes = [_CT[a] for a in args]
            setattr(self, name, fn)
        self.addresses = np.array([ctypes.cast(getattr(self, n), ctypes.c_void_p).value for n in _ADDR_NAMES],
                                  dtype=np.int64)


_LIB: _Lib | None = None


def lib() -> _Lib:
    global _LIB
    if _LIB is None:
        _LIB = _Lib()
    return _LIB


@intrinsic
def as_int(typingctx, ptr):
    """A ``void*`` as int64."""

    def codegen(context, builder, sig, args):
        return builder.ptrtoint(args[0], ir.IntType(64))

    return types.int64(types.voidptr), codegen


def message(flag: int) -> str:
    try:
        from sksundae._cy_ida import IDAMESSAGES
        return str(IDAMESSAGES.get(flag, f"IDA flag {flag}"))
    except ImportError:  # pragma: no cover
        return f"IDA flag {flag}"
