"""Fused multiply-add in compiled code, for kernels that must give numpy's products bit for bit.

numpy hands small products to BLAS (OpenBLAS in its wheels), whose kernels accumulate with fused
multiply-adds (``a * b + c`` rounded once).  A compiled loop written as ``a * b + c`` rounds twice, so it
differs from numpy in the last bit about one time in ten; ``fma`` below rounds once (LLVM's ``llvm.fma``),
so a kernel can take numpy's order of operations exactly.  The orders measured on the wheels' OpenBLAS
(tests/test_fused.py checks each against numpy on random inputs):

* ``numpy.dot`` of two vectors (``ddot``), so ``numpy.linalg.norm`` of a vector: ``fma(x2, y2, fma(x1, y1,
  x0 * y0))``, in index order;
* a matrix times a column (``dgemv``, (2, 2) @ (2, 1) and (R, 3) @ (3,)): per row ``fma(a0, b0, a1 * b1)``
  and ``fma(a2, b2, fma(a0, b0, a1 * b1))``, element 1 first;
* a matrix times a matrix (2 x 2, stacked or not): ``fma(a_i1, b_1j, a_i0 * b_0j)``;
* a product over an inner dimension of 1: the plain product.

Another BLAS, or the same OpenBLAS on another machine, may sum them otherwise (on an AMD EPYC, issue 11's ninth
round, a 3-vector's ``dot`` is the plain sum, each product rounded; ``tests/_blas.py``'s ``FUSES`` tells); the
results then differ from numpy's in the last bit, which changes nothing but bit-for-bit comparisons with the numpy
code these kernels replaced, and the trials, whose closed loops carry a last-bit difference on.
"""

from __future__ import annotations

import math

import numba
from numba.extending import intrinsic

__all__ = ["fma", "norm3"]


@intrinsic
def _fma(typingctx, a, b, c):  # pragma: no cover - compiled
    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return numba.types.float64(numba.types.float64, numba.types.float64, numba.types.float64), codegen


@numba.njit(cache=True, inline="always")
def fma(a: float, b: float, c: float) -> float:  # pragma: no cover - jitted
    """``a * b + c`` rounded once (float64)."""
    return _fma(a, b, c)


@numba.njit(cache=True)
def norm3(x: float, y: float, z: float) -> float:  # pragma: no cover - jitted
    """``numpy.linalg.norm`` of the vector (x, y, z): the square root of ``ddot``'s fused sum, in index order."""
    return math.sqrt(fma(z, z, fma(y, y, x * x)))
