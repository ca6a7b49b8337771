import numpy as np
import pytest

from bwbench.models import excitation


def test_fit_sine_recovers_a_noisy_sine():
    rng = np.random.default_rng(3)
    t = np.arange(0, 1500.0)
    x = 1.5 + 8.0 * np.sin(2 * np.pi * t / 433.0 + 0.4) + rng.normal(0, 0.01, t.shape)
    fit = excitation.fit_sine(t, x)
    assert fit.amplitude == pytest.approx(8.0, rel=1e-3)
    assert fit.period == pytest.approx(433.0, rel=1e-4)
    assert fit.offset == pytest.approx(1.5, abs=2e-3)
    assert fit.phase == pytest.approx(0.4, abs=2e-3)


def test_sine_fit_of_a_triangle_has_the_least_squares_amplitude():
    t = np.arange(0, 1920.0)
    phase = (t % 480) / 480
    x = 10 * np.where(phase < 0.25, 4 * phase, np.where(phase < 0.75, 2 - 4 * phase, 4 * phase - 4))
    fit = excitation.fit_sine(t, x)
    assert fit.amplitude == pytest.approx(10 * 8 / np.pi**2, rel=2e-3)  # first Fourier coefficient
    # Not exactly 480 s: the period derivative is t-weighted, so harmonics do not drop out.
    assert fit.period == pytest.approx(480.0, rel=5e-3)


def test_measured_velocity_is_smooth_and_unbiased_on_a_ramp():
    rng = np.random.default_rng(5)
    t = np.arange(0, 200.0)
    x = 0.1 * t + rng.normal(0, 0.001, t.shape)
    e = excitation.measured(t, x)
    assert np.mean(e.v) == pytest.approx(0.1, rel=1e-3)
    assert np.std(e.v) < 0.001  # raw differences would jitter by ~0.0014 mm/s
    assert np.all(e.v > 0)  # no sign flip, hence no branch chatter
    assert np.max(np.abs(e.a)) < 0.01


def test_measured_refuses_uneven_sampling_and_unknown_kinds():
    t = np.array([0.0, 1.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
    with pytest.raises(ValueError, match="uniformly"):
        excitation.measured(t, t)
    with pytest.raises(ValueError, match="excitation"):
        excitation.build("triangle", t, t)


@pytest.mark.parametrize("window, polyorder", [(9, 4), (7, 2), (5, 3)])
@pytest.mark.parametrize("deriv", [0, 1, 2])
def test_the_numpy_savitzky_golay_is_scipys(window, polyorder, deriv):
    from scipy.signal import savgol_filter

    from bwbench.models.savitzky_golay import savgol

    x = np.cumsum(np.random.default_rng(1).normal(size=300))
    expected = savgol_filter(x, window, polyorder, deriv=deriv, delta=0.3, mode="interp")
    np.testing.assert_allclose(savgol(x, window, polyorder, deriv, 0.3), expected, rtol=0,
                               atol=1e-10 * np.max(np.abs(expected)))
