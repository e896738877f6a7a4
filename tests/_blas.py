"""Whether numpy's BLAS sums small products with fused multiply-adds in the orders of :mod:`navstack.fused`."""

from __future__ import annotations

from fractions import Fraction

import numpy as np


def exact_fma(a: float, b: float, c: float) -> float:
    """``a * b + c`` rounded once, from exact rational arithmetic."""
    return float(Fraction(a) * Fraction(b) + Fraction(c))


def _probe() -> bool:
    """numpy's dot product of (x, y) with itself is fma(y, y, x * x), for a pair where that is not x*x + y*y."""
    rng = np.random.default_rng(5)
    for x, y in rng.normal(size=(1000, 2)).tolist():
        fused, plain = exact_fma(y, y, x * x), x * x + y * y
        if fused != plain:
            return float(np.dot([x, y], [x, y])) == fused
    return False


FUSES = _probe()
"""True where navstack's compiled kernels give numpy's results bit for bit (the wheels' OpenBLAS on x86-64)."""


def assert_as_numpy_sums(got: np.ndarray, want: np.ndarray, scale: np.ndarray | float) -> None:
    """``got`` is ``want`` bit for bit where numpy's BLAS fuses as OpenBLAS does (:data:`FUSES`); on any BLAS
    within four roundings of ``scale`` (the sum of the products' magnitudes: another order of the same sum is
    that close)."""
    assert np.all(np.abs(got - want) <= 4 * np.finfo(float).eps * np.asarray(scale))
    if FUSES:
        np.testing.assert_array_equal(got, want)
