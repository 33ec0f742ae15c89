"""Sums formed in the order numpy's BLAS forms them, for the compiled embedded Runge-Kutta driver
(``integrators.embedded_driver``), whose steps then match scipy's bit for bit.

* ``fused_multiply_add``: x·y + z rounded once (LLVM's ``llvm.fma.f64``), as OpenBLAS's kernels use it;
* ``combine``: a stage combination Σⱼ aᵢⱼkⱼ as OpenBLAS's ``dgemv_n`` forms it on its Haswell and Zen kernels
  (blocks of four terms as two fused multiply-add chains, then a pair, then a single term);
* ``larger``: ``np.maximum`` of two numbers (NaN if either is NaN).

(integrators/README.md "Compiled embedded Runge-Kutta pairs" gives the measurement behind this order.)
"""

from __future__ import annotations

import math

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from foucault_bench.models.jit import jit


@intrinsic
def fused_multiply_add(typingctx, x, y, z):
    """x·y + z rounded once (LLVM's ``llvm.fma.f64``: the hardware instruction, or libm's ``fma``)."""
    signature = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, sig, args):
        double = ir.DoubleType()
        function = builder.module.declare_intrinsic("llvm.fma", [double], ir.FunctionType(double, [double] * 3))
        return builder.call(function, args)

    return signature, codegen


@jit(inline="always")
def combine(k, weights, n_terms, component):
    """Σⱼ<n weightsⱼ·k[j, component] in the order of OpenBLAS's dgemv_n (see the module docstring)."""
    total = 0.0
    j = 0
    for _ in range(n_terms // 4):
        even = k[j, component] * weights[j]
        odd = k[j + 1, component] * weights[j + 1]
        even = fused_multiply_add(k[j + 2, component], weights[j + 2], even)
        odd = fused_multiply_add(k[j + 3, component], weights[j + 3], odd)
        total = total + (even + odd)
        j += 4
    if n_terms % 4 >= 2:
        total = total + (k[j, component] * weights[j] + k[j + 1, component] * weights[j + 1])
        j += 2
    if n_terms % 2 == 1:
        total = total + k[j, component] * weights[j]
    return total


@jit(inline="always")
def larger(a, b):
    """np.maximum: the larger value, NaN if either is NaN."""
    if a != a or b != b:
        return math.nan
    return a if a >= b else b
