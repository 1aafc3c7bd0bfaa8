"""Small dense linear algebra that rounds the same on every machine: elementwise products summed by numpy's own
reduction loops (in an order fixed by numpy, not by the CPU), a Cholesky solve in Python floats - never BLAS or
LAPACK.

numpy hands ``@``, ``np.dot`` and ``np.linalg`` to its BLAS (OpenBLAS in the numpy wheels), which picks a kernel
by the CPU it runs on (Prescott, Sandybridge, Haswell, SkylakeX, Zen, ...; ``OPENBLAS_CORETYPE`` overrides it),
and each kernel sums in its own order.  Where a simulation's inputs pass through such a product - the inverse
kinematics of a motion's targets, the sensors' discretised filters - the last bits of the inputs moved with the
machine, the quantised sensor readings flipped a step apart a few seconds in, and a campaign's features and the
figures read off them differed between two hosts (docs/diagnostics.md, "The same campaign on another machine").
Elementwise IEEE-754 arithmetic rounds the same everywhere.  For matrices of a few rows only: the setup code's.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray


def sq_norm(v: NDArray) -> float:
    """``v @ v``, without BLAS."""
    return float((v * v).sum())


def matmul(a: NDArray, b: NDArray) -> NDArray:
    """``a @ b`` of two small matrices, without BLAS (each entry's products summed along an axis by numpy)."""
    return (np.asarray(a, float)[:, :, None] * np.asarray(b, float)[None, :, :]).sum(axis=1)


def solve_spd(a: NDArray, b: NDArray) -> NDArray:
    """``x`` with ``a x = b`` for a small symmetric positive definite ``a`` (Cholesky in Python floats)."""
    n = len(b)
    a = [[float(v) for v in row] for row in np.asarray(a, float)]
    low = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            acc = a[i][j]
            for k in range(j):
                acc -= low[i][k] * low[j][k]
            if i == j:
                if acc <= 0.0:
                    raise np.linalg.LinAlgError("solve_spd: matrix not positive definite")
                low[i][i] = math.sqrt(acc)
            else:
                low[i][j] = acc / low[j][j]
    y = [0.0] * n
    for i in range(n):  # L y = b
        acc = float(b[i])
        for k in range(i):
            acc -= low[i][k] * y[k]
        y[i] = acc / low[i][i]
    x = [0.0] * n
    for i in reversed(range(n)):  # L^T x = y
        acc = y[i]
        for k in range(i + 1, n):
            acc -= low[k][i] * x[k]
        x[i] = acc / low[i][i]
    return np.array(x)


__all__ = ["matmul", "solve_spd", "sq_norm"]
