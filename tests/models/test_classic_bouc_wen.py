"""The classic symmetric Bouc-Wen model against an independent solve_ivp reference, and its maps."""

from types import SimpleNamespace

import numpy as np
import pytest

from bwbench.models.classic_bouc_wen import MODEL
from bwbench.models.switched import simulation as switched
from bwbench.models.switched.kernel import symmetric_params
from reference_mr import classic_force, random_motion

# Hysteresis that matters in the force: Table 6's compression set with ξ made positive, a sharp
# n = 1 loop and a smooth n = 3 one.
PARAMETER_SETS = {
    "table6_compression": [0.341, 2.825, 0.068, 0.014, 2.814, 151.74, 17.333],
    "sharp_n1": [1.0, 1.0, 0.2, 0.5, 0.5, 20.0, 5.0],
    "smooth_n3": [0.5, 3.0, 0.3, 0.1, 0.9, 40.0, 8.0],
}


def _sine(amplitude, period, rate, cycles=2):
    w = 2 * np.pi / period
    t = np.arange(0.0, cycles * period, 1.0 / rate) + 0.37 / rate  # no sample on a reversal
    return (
        lambda s: amplitude * np.sin(w * s),
        lambda s: amplitude * w * np.cos(w * s),
        lambda s: -amplitude * w * w * np.sin(w * s),
        t,
    )


@pytest.mark.parametrize("name", PARAMETER_SETS)
@pytest.mark.parametrize("motion", ["sine", "random"])
def test_matches_solve_ivp_to_a_millionth_of_the_force_range(name, motion):
    if motion == "sine":
        x_of, v_of, a_of, t = _sine(10.0, 20.0, 20.0)
    else:
        x_of, v_of, a_of = random_motion(seed=5, amplitude=10.0, f_max=0.2)
        t = np.arange(0.0, 40.0, 1.0 / 40.0)
    p = np.array(PARAMETER_SETS[name])
    signal = SimpleNamespace(t=t, x=x_of(t), v=v_of(t), a=a_of(t))
    ours = MODEL.force_batch(p[None], signal)[0]
    ref = classic_force(p, t, x_of, v_of, a_of)
    assert np.max(np.abs(ours - ref)) <= 1e-6 * np.ptp(ref)


def test_is_the_switched_model_with_equal_sets():
    x_of, v_of, a_of, t = _sine(5.0, 10.0, 50.0)
    p = np.array(PARAMETER_SETS["smooth_n3"])
    signal = SimpleNamespace(t=t, x=x_of(t), v=v_of(t), a=a_of(t))
    np.testing.assert_array_equal(
        MODEL.force_batch(p[None], signal)[0],
        switched.simulate(symmetric_params(*p), t, signal.x, signal.v, signal.a),
    )
    mse = MODEL.mse_batch(p[None], signal, signal.x * 3.0)[0]
    assert mse == pytest.approx(np.mean((MODEL.force_batch(p[None], signal)[0] - signal.x * 3.0) ** 2), rel=1e-12)


@pytest.mark.parametrize("name", PARAMETER_SETS)
def test_identifiable_coordinates_give_the_same_force_and_map_back(name):
    x_of, v_of, a_of, t = _sine(10.0, 20.0, 20.0)
    signal = SimpleNamespace(t=t, x=x_of(t), v=v_of(t), a=a_of(t))
    p = np.array(PARAMETER_SETS[name])
    theta, coef = MODEL.from_direct(p)
    w = MODEL.trajectories(theta[None], signal)[0]
    force = coef["m"] * signal.a + coef["c"] * signal.v + coef["k"] * signal.x + coef["h"] * w + coef["f"]
    np.testing.assert_allclose(force, MODEL.force_batch(p[None], signal)[0], rtol=1e-9, atol=1e-9 * np.ptp(force))
    back = MODEL.to_direct(theta, coef)
    np.testing.assert_allclose(
        MODEL.force_batch(back[None], signal)[0],
        MODEL.force_batch(p[None], signal)[0],
        rtol=1e-9,
        atol=1e-9 * np.ptp(force),
    )


def test_direct_parameters_leave_out_mass_and_offset():
    theta = np.array([1.0, 2.0, 0.0])
    coef = {"m": 1.0, "c": 10.0, "k": 5.0, "h": 20.0, "f": 0.0}
    direct = MODEL.to_direct(theta, coef)
    np.testing.assert_array_equal(MODEL.to_direct(theta, {**coef, "f": 3.0, "m": 0.2}), direct)
    assert MODEL.to_direct(theta, {**coef, "k": -5.0, "h": -20.0}) is None  # ωn² < 0 in every gauge
