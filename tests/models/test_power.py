"""The kernels' |z|ⁿ (``bwbench.models.power``) against libm's pow, its special values, and the same bits
whether it runs one call at a time or in a vectorised loop."""

import math

import numba
import numpy as np
import pytest

from bwbench.models.power import exp, log, power, power_inline


@numba.njit
def _vector_loop(x, n, out):
    for i in range(x.shape[0]):  # no condition: LLVM vectorises this loop
        out[i] = power_inline(x[i], n[i])


@numba.njit
def _one_by_one(x, n, out):
    for i in range(x.shape[0]):
        out[i] = power(x[i], n[i])


@pytest.fixture(scope="module")
def points():
    rng = np.random.default_rng(7)
    x = np.exp(rng.uniform(-40.0, 10.0, 200_000))  # |z| from 4e-18 to 2e4
    n = rng.uniform(0.1, 11.0, x.size)  # Table 5's n and the identifiable box's, with margin
    return x, n


def test_relative_error_is_that_of_rounding_n_log_x(points):
    x, n = points
    ours = np.empty_like(x)
    _one_by_one(x, n, ours)
    exact = x**n  # libm: < 1 unit in the last place
    inside = (exact > 1e-300) & (exact < 1e300)
    relative = np.abs(ours - exact)[inside] / exact[inside]
    y = np.abs(n * np.log(x))[inside]
    # 2·(|n·log x| + 4) units in the last place: the rounding of y = n·log x, carried by exp
    assert np.all(relative <= 2.0 * (y + 4.0) * np.finfo(float).eps)
    assert np.max(relative[y <= 20.0]) < 8e-15


def test_vectorised_loop_gives_the_bits_of_single_calls(points):
    x, n = points
    a, b = np.empty_like(x), np.empty_like(x)
    _vector_loop(x, n, a)
    _one_by_one(x, n, b)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    "x, n, expected",
    [
        (0.0, 2.0, 0.0),
        (0.0, 0.3, 0.0),
        (np.inf, 2.0, np.inf),
        (1.0, 7.3, 1.0),
        (2.0, 0.5, math.sqrt(2.0)),
        (4.0, 2.0, 16.0),
        (1e300, 3.0, np.inf),  # beyond e^709.7
        (1e-300, 3.0, 0.0),  # below e^-708: flushed
    ],
)
def test_special_and_exact_values(x, n, expected):
    assert power(x, n) == pytest.approx(expected, rel=4e-16, abs=0.0)


def test_nan_and_subnormal_inputs():
    assert np.isnan(power(np.nan, 2.0))
    # below the smallest normal number the input is taken as that number: still tiny, never NaN
    assert power(1e-310, 0.5) == pytest.approx(math.sqrt(2.2250738585072014e-308), rel=1e-14)


def test_log_and_exp_each():
    rng = np.random.default_rng(3)
    y = rng.uniform(-700.0, 700.0, 10_000)
    ours = np.array([exp(v) for v in y])
    # 2 units in the last place, plus |y|·4e-17 from reducing y by ln 2/128 in one constant
    assert np.all(np.abs(ours - np.exp(y)) / np.exp(y) < 4.5e-16 + 4e-17 * np.abs(y))
    x = np.exp(rng.uniform(-700.0, 700.0, 10_000))
    logs = np.array([log(v) for v in x])
    assert np.max(np.abs(logs - np.log(x)) / np.maximum(np.abs(np.log(x)), 1.0)) < 3e-16
    assert log(0.0) == -np.inf and log(np.inf) == np.inf
    assert abs(log(1.0)) < 1e-19  # not exactly 0 (1 is not a table centre): 2e-16 absolute is the bound
