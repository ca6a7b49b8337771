"""The switched model against an independent solve_ivp reference, and its failure modes."""

import numpy as np
import pytest

from bwbench.models.switched import simulation as model
from bwbench.models.switched.kernel import STATES, symmetric_params
from bwbench.models.switched.parameters import LOWER, UPPER
from reference import reference_force, sine_excitation

# Spanning Table 5: the paper's own fits, n below 1 and above 10, the box corners, the
# symmetric 7-parameter model as a special case.
PARAMETER_SETS = {
    "table6_pom_mt24u01_0.01": [
        0.005,
        5.019,
        1.009,
        1.171,
        3.600,
        261.893,
        3.589,
        0.341,
        2.825,
        0.068,
        0.014,
        2.814,
        -151.740,
        17.333,
    ],
    "table8_pcabs_0.01_n-_0.466": [
        0.011,
        4.351,
        0.577,
        2.452,
        5.231,
        152.329,
        5.049,
        0.717,
        0.466,
        0.028,
        0.024,
        1.952,
        -54.433,
        31.888,
    ],
    "n+_10.5": [0.02, 10.5, 0.3, 0.5, 5.0, 100, 5.0, 1.0, 4.5, 0.1, 0.02, 0.5, -300, 30],
    "n-_0.3_stiff": [0.02, 1.0, 0.3, 0.5, 1.0, 100, 5.0, 0.2, 0.3, 0.1, 0.02, 1.0, -300, 30],
    "n+_0.5": [0.01, 0.5, 0.5, 0.5, 1.0, 100, 5.0, 0.5, 2, 0.1, 0.02, 1.0, -300, 30],
    "table5_lower_corner": list(LOWER),
    "table5_upper_corner": list(UPPER),
    "symmetric_7_parameter": list(symmetric_params(0.3, 1.5, 0.2, 0.5, 1.5, 50.0, 10.0)),
}

T = np.arange(0.0, 1921.0)  # the specimens' grid: 1 Hz, 4 cycles of 480 s
AMPLITUDE, PERIOD = 10.0, 480.0


@pytest.mark.parametrize("state", STATES)
@pytest.mark.parametrize("name", PARAMETER_SETS)
@pytest.mark.parametrize("offset", [0.0, 0.37], ids=["reversal_on_sample", "reversal_between"])
def test_matches_reference_within_a_thousandth_of_force_range(name, state, offset):
    t = T + offset
    p = np.array(PARAMETER_SETS[name])
    x, v, a = sine_excitation(t, AMPLITUDE, PERIOD)
    ours = model.simulate(p, t, x, v, a, state)
    ref = reference_force(p, t, AMPLITUDE, PERIOD, state)
    error = np.max(np.abs(ours - ref))
    assert error <= 1e-3 * np.ptp(ref), f"max error {error:.3g} N on a range of {np.ptp(ref):.1f} N"


def test_conventions_differ_and_symmetric_sets_switch_nothing():
    t = T
    x, v, a = sine_excitation(t, AMPLITUDE, PERIOD)
    p = np.array(PARAMETER_SETS["table6_pom_mt24u01_0.01"])
    shared = model.simulate(p, t, x, v, a, "shared")
    split = model.simulate(p, t, x, v, a, "split")
    # The two conventions disagree right after reversals, by a visible but bounded amount.
    assert 1.0 < np.max(np.abs(shared - split)) < 0.5 * np.ptp(shared)
    sym = np.array(PARAMETER_SETS["symmetric_7_parameter"])
    # With equal sets the shared model is the original one: force odd in (x, v) after the
    # first quarter cycle, as the symmetric Bouc-Wen loop is.
    f = model.simulate(sym, t, x, v, a, "shared") - a
    half = int(PERIOD / 2)
    np.testing.assert_allclose(f[480:960], -f[480 + half : 960 + half], atol=1e-6 * np.ptp(f))


def test_runaway_parameters_give_inf_never_nan():
    # β₊ > γ₊ with the '−' branch leaving z at ~9,400: the '+' unloading equation runs away.
    p = np.array([0.001, 10, 0.5, 2.5, 0.3, 100, 5, 1.25, 0.2, 0.1, 0.001, 0.2, -300, 30])
    x, v, a = sine_excitation(T, AMPLITUDE, PERIOD)
    force = model.simulate(p, T, x, v, a)
    assert np.all(np.isposinf(force))
    assert np.isposinf(model.mse_batch(p[None], T, x, v, a, np.zeros_like(T))[0])


def test_random_table5_population_is_finite_or_inf_and_batch_matches_single():
    rng = np.random.default_rng(7)
    P = LOWER + rng.random((500, 14)) * (UPPER - LOWER)
    x, v, a = sine_excitation(T, AMPLITUDE, PERIOD)
    f_meas = model.simulate(np.array(PARAMETER_SETS["table6_pom_mt24u01_0.01"]), T, x, v, a)
    with np.errstate(all="raise"):  # no floating-point warning escapes the kernel's wrapper
        mse = model.mse_batch(P, T, x, v, a, f_meas)
    assert not np.any(np.isnan(mse))
    assert np.all((mse >= 0) | np.isposinf(mse))
    assert 0 < np.mean(np.isinf(mse)) < 0.2  # some of the box does blow up, most does not
    for i in range(0, 500, 50):
        single = model.simulate(P[i], T, x, v, a)
        expected = np.mean((single - f_meas) ** 2) if np.all(np.isfinite(single)) else np.inf
        assert mse[i] == pytest.approx(expected, rel=1e-12)


def test_bad_shapes_and_state_are_refused():
    x, v, a = sine_excitation(T, AMPLITUDE, PERIOD)
    with pytest.raises(ValueError, match="state"):
        model.simulate(LOWER, T, x, v, a, "both")
    with pytest.raises(ValueError, match="shape"):
        model.simulate(LOWER[:7], T, x, v, a)
    with pytest.raises(ValueError, match="equal length"):
        model.simulate(LOWER, T, x[:-1], v, a)


def test_a_backward_euler_step_on_the_attractor_stays_there():
    """z within a few units in the last place of the attractor z_s: g(z) is rounding noise of either
    sign, and reading a bracket from it sent 4 of these 24 stiff steps (h·stiffness ≈ 4 per substep)
    to the RK4 fallback, unstable there — a blow-up of random identifiable-box points. The step stays."""
    import math

    from bwbench.models.switched.kernel import backward_euler

    A, n, beta, gamma = 15.282839, 6.54174115, -1.98254158e08, 6.19889082e09  # a '−' branch, η ≈ −1.07
    z_att = -math.pow(A / (beta + gamma), 1.0 / n)  # moving in −x: the attractor at −z_s
    h = -0.0037625  # mm per substep
    starts = [z_att]
    for toward in (0.0, -1.0):  # 12 representable numbers on each side
        z = z_att
        for _ in range(12):
            z = float(np.nextafter(z, toward))
            starts.append(z)
    for z0 in starts:
        assert backward_euler(z0, h, A, n, beta, gamma, z_att) == z0
    # and a start clearly off the attractor still takes a real step towards it
    z1 = backward_euler(0.9 * z_att, h, A, n, beta, gamma, z_att)
    assert 0.9 * z_att > z1 >= z_att
