"""Calling the compiled controller functions from Python through ctypes.

:class:`CompiledFunction` binds one generated function of a shared library to
preallocated numpy arrays (inputs, outputs, the ``iw``/``w`` work arrays and
the ``arg``/``res`` pointer arrays), allocated once from the sizes the library
itself reports (``<name>_work``), exactly as the C harness uses static arrays.
A call copies the inputs in, calls the C function, and returns views of the
output arrays: the per-call overhead is a few microseconds.
"""

from __future__ import annotations

import ctypes
import os
from pathlib import Path

import numpy as np

_c_real_p = ctypes.POINTER(ctypes.c_double)
_c_int = ctypes.c_longlong  # casadi_int of the generated code (CODEGEN_OPTIONS)


class CompiledLibrary:
    """A loaded ``libmaglev_controller.so`` (kept alive while any of its functions is)."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.lib = ctypes.CDLL(str(self.path))

    def has(self, name: str) -> bool:
        """Whether the library exports function ``name``."""
        return hasattr(self.lib, name)

    def function(self, name: str) -> CompiledFunction:
        """The compiled function ``name``."""
        return CompiledFunction(self, name)


class CompiledFunction:
    """One generated function, callable like :class:`maglev_ocp.fastcall.BufferedFunction`.

    Parameters
    ----------
    library : CompiledLibrary
        The loaded library.
    name : str
        Function name (C symbol).

    Notes
    -----
    Sizes of the inputs and outputs are read from the generated
    ``<name>_sparsity_in/out`` (dense vectors/matrices: ``nnz = rows * cols``).
    """

    def __init__(self, library: CompiledLibrary, name: str):
        lib = library.lib
        self.library = library
        self.name = name
        if not library.has(name):
            raise KeyError(f"{library.path} has no function {name!r}")
        self._f = getattr(lib, name)
        self._f.restype = ctypes.c_int
        self._f.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int]
        for suffix, res in (("_n_in", _c_int), ("_n_out", _c_int)):
            getattr(lib, name + suffix).restype = res
        n_in, n_out = int(getattr(lib, name + "_n_in")()), int(getattr(lib, name + "_n_out")())
        sp_in, sp_out = getattr(lib, name + "_sparsity_in"), getattr(lib, name + "_sparsity_out")
        for sp in (sp_in, sp_out):
            sp.restype = ctypes.POINTER(_c_int)
            sp.argtypes = [_c_int]
        self.in_sizes = [self._nnz(sp_in(i)) for i in range(n_in)]
        self.out_sizes = [self._nnz(sp_out(i)) for i in range(n_out)]
        work = getattr(lib, name + "_work")
        work.argtypes = [ctypes.POINTER(_c_int)] * 4
        sz = [_c_int() for _ in range(4)]
        work(*[ctypes.byref(s) for s in sz])
        sz_arg, sz_res, sz_iw, sz_w = (max(int(s.value), 0) for s in sz)
        checkout = getattr(lib, name + "_checkout")
        checkout.restype = ctypes.c_int
        self._mem = int(checkout())
        self.args = [np.zeros(n) for n in self.in_sizes]
        self.res = [np.zeros(n) for n in self.out_sizes]
        self._iw = np.zeros(max(sz_iw, 1), dtype=np.int64)
        self._w = np.zeros(max(sz_w, 1))
        self._arg = (ctypes.c_void_p * max(sz_arg, n_in, 1))()
        self._resp = (ctypes.c_void_p * max(sz_res, n_out, 1))()
        for i, a in enumerate(self.args):
            self._arg[i] = a.ctypes.data
        for i, r in enumerate(self.res):
            self._resp[i] = r.ctypes.data
        self._call_args = (self._arg, self._resp, self._iw.ctypes.data, self._w.ctypes.data, self._mem)

    @staticmethod
    def _nnz(sp) -> int:
        # CasADi compressed column storage: nrow, ncol, then either a dense flag (colind[0] == 1) or colind[]
        nrow, ncol = int(sp[0]), int(sp[1])
        if int(sp[2]) == 1:  # dense shorthand
            return nrow * ncol
        return int(sp[2 + ncol])

    def __call__(self, *inputs) -> list[np.ndarray]:
        """Evaluate; returns the output arrays (reused by the next call: copy what you keep)."""
        for dst, src in zip(self.args, inputs, strict=True):
            dst[:] = np.ravel(np.asarray(src, dtype=float), order="F")
        if self._f(*self._call_args):
            raise RuntimeError(f"compiled {self.name} returned an error")
        return self.res

    def call_raw(self) -> None:
        """Evaluate on the current contents of :attr:`args` (for timing the C function alone)."""
        if self._f(*self._call_args):
            raise RuntimeError(f"compiled {self.name} returned an error")


__all__ = ["CompiledFunction", "CompiledLibrary"]
