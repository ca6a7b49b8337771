"""|z|ⁿ for the switched Bouc-Wen kernels: exp(n·log x) in plain arithmetic that numba can vectorise.

Why not ``math.pow``: libm's pow was two thirds of the switched kernels' time (perf, 1,921-sample
specimen), and a libm call runs one lane at a time, so the lockstep kernel's loop over its lanes
stayed scalar. ``power`` is inlined arithmetic (two 128-entry tables, fused multiply-adds), which
LLVM turns into vector code over the lanes (AVX2/AVX-512), while a scalar caller gets the very same
bits: each vector lane does exactly the operations of a scalar call (an FMA is rounded once, there is
no fastmath), so the scalar, lockstep and sensitivity kernels stay bit-identical to one another as
long as they all call this function.

Method (as in the table-driven log and exp of glibc and ARM's optimized-routines, without their
extra-precision tail): x = 2^k·z with z in [0.7, 1.4), log z = log c_i + log1p(z/c_i − 1) with
c_i the centre of one of 128 subintervals (|z/c_i − 1| < 0.0028, log1p by its degree-6 series);
then y = n·log x and exp y = 2^(j/128)·2^e·exp r with |r| < 0.0027 (degree-5 series).
Accuracy: the relative error is below 2·(|n·log x| + 4) units in the last place (1.6· measured;
the rounding of y = n·log x, which libm's pow avoids by carrying log x in double-double): at most 8e-15 for
|n·log x| ≤ 20 (tests/models/test_power.py), against an RK4 step error of ~1e-6 of the range.
Special values for n > 0: x = 0 gives 0, x = inf gives inf, NaN gives NaN; x below the smallest
normal number (2.2e-308) is taken as that number, results below e^−708 (~3e-308) are flushed to 0
and those above e^709.7 (~1.65e308) are inf. None of these matter to the model, where the power is
multiplied by β ± γ and subtracted from A: they keep its blow-ups blow-ups and its zeros zeros.
"""

from __future__ import annotations

import math
import struct

import numba
import numpy as np
from numba.core import types
from numba.extending import intrinsic


@intrinsic
def _bits(typingctx, x):
    """The IEEE bits of a float64 as an int64 (a register move, no memory)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.int64))

    return types.int64(types.float64), codegen


@intrinsic
def _float(typingctx, i):
    """The float64 whose IEEE bits are the int64 ``i``."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.float64))

    return types.float64(types.int64), codegen


@intrinsic
def _fma(typingctx, a, b, c):
    """a·b + c rounded once (llvm.fma: the same result in a scalar and in a vector instruction)."""

    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return types.float64(types.float64, types.float64, types.float64), codegen


def _as_float(i: int) -> float:
    return struct.unpack("<d", struct.pack("<q", i))[0]


_TABLE_BITS = 7
_N = 1 << _TABLE_BITS  # subintervals of the log table, and steps of 2^(j/N) in the exp table
# z = x/2^k is taken in [0.7, 1.4) (so that log z is small where x is near 1): the bits of 0.7,
# rounded to a subinterval edge (glibc's log uses the same offset).
_OFF = 0x3FE6955500000000
_EXPONENT = -(1 << 52)  # 0xFFF0000000000000: the sign and exponent bits, as an int64
_INV_C = np.empty(_N)  # 1/c_i, c_i the centre of subinterval i
_LOG_C = np.empty(_N)  # log c_i = −log(1/c_i) of the rounded 1/c_i, so that the two agree exactly
for _i in range(_N):
    _lo = _as_float(_OFF + (_i << (52 - _TABLE_BITS)))
    _hi = _as_float(_OFF + ((_i + 1) << (52 - _TABLE_BITS)))
    _INV_C[_i] = 1.0 / (0.5 * (_lo + _hi))
    _LOG_C[_i] = -math.log(_INV_C[_i])
_EXP_2 = np.array([2.0 ** (j / _N) for j in range(_N)])  # 2^(j/N), correctly rounded by Python's pow
_LN2_HI = 6.93147180369123816490e-01  # ln 2 in two parts: k·_LN2_HI is exact for |k| < 2^20
_LN2_LO = 1.90821492927058770002e-10
_N_OVER_LN2 = _N / math.log(2.0)
_LN2_OVER_N = math.log(2.0) / _N
_SHIFT = 6755399441055744.0  # 1.5·2^52: y + _SHIFT rounds y to an integer held in the low bits
_SHIFT_BITS = 0x4338000000000000  # the bits of _SHIFT
_SMALLEST_NORMAL = 2.2250738585072014e-308
_EXP_MIN, _EXP_MAX = -708.0, 709.7  # e^−708 ≈ 3e-308 (normal), e^709.7 ≈ 1.65e308 (the largest is 1.80e308)


@numba.njit(cache=True, inline="always", error_model="numpy")
def log(x):
    """Natural log of x ≥ 0 (−inf at 0, inf at inf, NaN at NaN), within ~1 unit of |log x|'s last place
    plus 2e-16 absolute; x below the smallest normal number is taken as that number (log ≈ −708.4)."""
    # Written for latency (the scalar kernel waits for each power): no branch, the table index
    # and the float parts side by side, the last multiply and add fused.
    bits = _bits(max(x, _SMALLEST_NORMAL))
    tmp = bits - _OFF
    i = (tmp >> (52 - _TABLE_BITS)) & (_N - 1)
    k = float(tmp >> 52)
    z = _float(bits - (tmp & _EXPONENT))  # x/2^k in [0.7, 1.4)
    r = _fma(z, _INV_C[i], -1.0)  # z/c_i − 1, |r| < 0.0028
    head = _fma(k, _LN2_HI, _LOG_C[i]) + _fma(k, _LN2_LO, r)  # k·ln 2 + log c_i + r
    r2 = r * r
    # log1p(r) − r = r²·(−1/2 + r/3 + r²·(−1/4 + r/5 − r²/6))
    out = _fma(r2, _fma(r2, _fma(r2, -1.0 / 6.0, _fma(r, 0.2, -0.25)), _fma(r, 1.0 / 3.0, -0.5)), head)
    if not x < np.inf:
        out = x  # inf or NaN
    if x == 0.0:
        out = -np.inf
    return out


@numba.njit(cache=True, inline="always", error_model="numpy")
def exp(y):
    """e^y within 2 units in the last place plus |y|·4e-17 (y is reduced by ln 2/128 held in one
    double); 0 below −708, inf above 709.7, NaN at NaN."""
    # No clamp of y on the path: out of range, t, the index and the scale are garbage (the index is
    # masked, so the table read stays inside) and the selects below replace the result.
    t = _fma(y, _N_OVER_LN2, _SHIFT)
    kf = t - _SHIFT  # y·N/ln 2 rounded to an integer
    ki = _bits(t) - _SHIFT_BITS  # the same integer, from the low bits of t
    r = _fma(-kf, _LN2_OVER_N, y)  # |r| ≤ ln 2/(2N) ≈ 0.0027
    r2 = r * r
    # e^r − 1 = r + r²·(1/2 + r/6 + r²·(1/24 + r/120))
    em1 = _fma(r2, _fma(r2, _fma(r, 1.0 / 120.0, 1.0 / 24.0), _fma(r, 1.0 / 6.0, 0.5)), r)
    # 2^(j/N)·2^e: exact (a power of two times a number in [1, 2), no overflow in range)
    scaled = _EXP_2[ki & (_N - 1)] * _float(((ki >> _TABLE_BITS) + 1023) << 52)
    out = _fma(scaled, em1, scaled)
    if y > _EXP_MAX:
        out = np.inf
    if y < _EXP_MIN:
        out = 0.0
    if y != y:
        out = y
    return out


@numba.njit(cache=True, inline="always", error_model="numpy")
def power_inline(x, n):
    """x**n for x ≥ 0 and n > 0, inlined: for a loop over lanes that LLVM should vectorise (see the
    module docstring for accuracy and special values)."""
    return exp(n * log(x))


@numba.njit(cache=True, error_model="numpy")
def power(x, n):
    """``power_inline`` as a call: the same operations, for scalar code. Inlined into the scalar
    kernel's RK4 stages it made that kernel 8 % slower than with libm's pow (a bigger loop body
    holding the tables' addresses and constants), as a call 12 % faster (benchmarks/bench_objective.py)."""
    return exp(n * log(x))
