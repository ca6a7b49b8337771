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
    assert np.std(e.v) < 5e-4  # raw differences would jitter by ~0.0014 mm/s
    assert np.std(e.v[10:-10]) < 1.5e-4  # away from the ends, where nothing pins the spline from outside
    assert np.all(e.v > 0)  # no sign flip, hence no branch chatter
    assert np.max(np.abs(e.a)) < 0.01
    assert e.sources == {"velocity": "estimated", "acceleration": "estimated"}
    assert e.displacement_noise == pytest.approx(0.001, rel=0.15)


def test_a_recorded_velocity_drives_the_model_as_recorded():
    t = np.arange(0, 300.0)
    x = 5 * np.sin(2 * np.pi * t / 150)
    v = 0.97 * 5 * 2 * np.pi / 150 * np.cos(2 * np.pi * t / 150)  # not the displacement's: used as is
    e = excitation.measured(t, x, v)
    np.testing.assert_array_equal(e.v, v)
    np.testing.assert_array_equal(e.x, x)
    assert e.sources == {"velocity": "measured", "acceleration": "estimated"}
    a_true = -0.97 * 5 * (2 * np.pi / 150) ** 2 * np.sin(2 * np.pi * t / 150)
    np.testing.assert_allclose(e.a, a_true, atol=3e-3 * np.max(np.abs(a_true)))  # the derivative of v
    a = np.full_like(t, 0.25)
    assert excitation.measured(t, x, v, a).a is not None
    np.testing.assert_array_equal(excitation.measured(t, x, v, a).a, a)
    assert excitation.measured(t, x, v, a).sources["acceleration"] == "measured"
    assert excitation.build("sine", t, x, v, a).sources == {"velocity": "sine fit", "acceleration": "sine fit"}
    assert e.velocity_error() == 0.0  # a recorded velocity's error is not bwbench's to estimate


def test_measured_refuses_uneven_sampling_and_unknown_kinds():
    t = np.array([0.0, 1.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
    with pytest.raises(ValueError, match="uniformly"):
        excitation.measured(t, t)
    with pytest.raises(ValueError, match="excitation"):
        excitation.build("triangle", t, t)
