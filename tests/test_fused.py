"""navstack.fused: a fused multiply-add in compiled code, and the orders in which numpy's BLAS sums small products.

``fma`` is checked against exact rational arithmetic (machine independent).  The orders of
:mod:`navstack.fused`'s docstring are checked against numpy itself: bit for bit where numpy's BLAS fuses as the
wheels' OpenBLAS does on this kind of machine, and on any BLAS within a few roundings of the products' magnitudes
(which still catches a wrong index or a missing term).
"""

from __future__ import annotations

import numba
import numpy as np
from _blas import assert_as_numpy_sums as _check
from _blas import exact_fma as _exact_fma

from navstack.fused import fma

RNG = np.random.default_rng(2024)


@numba.njit(cache=True)
def _fma_many(a, b, c):  # pragma: no cover - jitted
    out = np.empty(a.shape[0])
    for i in range(a.shape[0]):
        out[i] = fma(a[i], b[i], c[i])
    return out


def test_fma_rounds_once():
    a, b = RNG.normal(size=3000), RNG.normal(size=3000)
    c = np.where(np.arange(3000) % 2 == 0, -a * b, RNG.normal(size=3000))  # half of them cancel
    got = _fma_many(a, b, c)
    want = np.array([_exact_fma(x, y, z) for x, y, z in zip(a.tolist(), b.tolist(), c.tolist(), strict=True)])
    np.testing.assert_array_equal(got, want)
    assert np.count_nonzero(got != a * b + c) > 300  # so it is not the twice-rounded a * b + c


def test_the_dot_product_order():
    x, y = RNG.normal(size=(500, 3)), RNG.normal(size=(500, 3))
    got = np.array([np.dot(a, b) for a, b in zip(x, y, strict=True)])
    want = np.array([_exact_fma(a[2], b[2], _exact_fma(a[1], b[1], a[0] * b[0])) for a, b in
                     zip(x.tolist(), y.tolist(), strict=True)])
    _check(got, want, (np.abs(x) * np.abs(y)).sum(axis=1))


def test_the_matrix_times_column_order():
    A3, v = RNG.normal(size=(500, 3)), RNG.normal(size=3)
    want3 = np.array([_exact_fma(a[2], v[2], _exact_fma(a[0], v[0], a[1] * v[1])) for a in A3.tolist()])
    _check(A3 @ v, want3, np.abs(A3) @ np.abs(v))
    F, x = RNG.normal(size=(2, 2)), RNG.normal(size=(500, 2, 1))
    want2 = np.array([[[_exact_fma(F[i, 0], c[0, 0], F[i, 1] * c[1, 0])] for i in range(2)] for c in x])
    _check(F @ x, want2, np.abs(F) @ np.abs(x))


def test_the_two_by_two_matrix_product_order():
    A, B = RNG.normal(size=(500, 2, 2)), RNG.normal(size=(500, 2, 2))
    want = np.array([[[_exact_fma(a[i, 1], b[1, j], a[i, 0] * b[0, j]) for j in range(2)] for i in range(2)]
                     for a, b in zip(A, B, strict=True)])
    _check(A @ B, want, np.abs(A) @ np.abs(B))
    _check(A @ B[0], np.array([[[_exact_fma(a[i, 1], B[0][1, j], a[i, 0] * B[0][0, j]) for j in range(2)]
                                for i in range(2)] for a in A]), np.abs(A) @ np.abs(B[0]))
