"""The velocity estimator for files without a velocity column (``bwbench.models.derivatives``), on
exact motions built independently of the synthetic generator (``exact_motions``)."""

import numpy as np
import pytest

import exact_motions as em
from bwbench.models import derivatives

RESOLUTION_MM = 1e-5  # files print the displacement to 10 nm


def _ramp(rate_hz, noise_mm, seed=0):
    t = np.arange(0.0, em.ramp_duration() - 0.3, 1.0 / rate_hz) + 0.0123  # no sample on a reversal
    x, v, a = em.ramp(t)
    recorded = x + np.random.default_rng(seed).normal(0.0, noise_mm, x.shape)
    return t, np.round(recorded / RESOLUTION_MM) * RESOLUTION_MM, x, v, a


def test_noise_free_ramps_with_reversals_give_the_velocity_to_the_print_resolution():
    # 2 Hz, 8 s half-cosine reversals at 5 mm/min: the former Savitzky-Golay (9, 4) was 5.5e-5 mm/s
    # rms, 4.7e-4 max off; 1e-5 mm/s is 0.18 N of force at the largest 2ξωn of Tables 6-8.
    t, recorded, _, v, _ = _ramp(2.0, 0.0)
    e = derivatives.estimate(t, recorded)
    error = e.v - v
    assert np.sqrt(np.mean(error**2)) < 2.5e-5
    assert np.max(np.abs(error)) < 5e-4


def test_encoder_noise_is_averaged_away_on_the_ramps_and_kept_small_at_reversals():
    t, recorded, x, v, a = _ramp(1.0, 1e-3, seed=4)
    e = derivatives.estimate(t, recorded)
    assert e.noise == pytest.approx(1e-3, rel=0.1)
    # measured 5.7e-4 (FITPACK's adaptive spline, super-linear: 3.7e-4); SG(9, 4): 5.0e-4; raw differences 1.4e-3
    assert np.sqrt(np.mean((e.v - v) ** 2)) < 6e-4
    assert np.sqrt(np.mean((e.x - x) ** 2)) < 0.85e-3  # smoothed below the 1 µm noise (measured 0.81 µm)
    ramps = (np.abs(a) == 0) & (t > 20) & (t < t[-1] - 20)  # constant speed, away from the record's ends
    # measured 3.9e-4: one smoothing for the whole record, which the reversals limit (FITPACK: 2.5e-4)
    assert np.sqrt(np.mean((e.v - v)[ramps] ** 2)) < 4.5e-4  # SG(9, 4): 3.4e-4 of noise alone


def test_the_record_ends_are_guarded():
    # 0.5 Hz: four samples per reversal; the smoothing spline alone is 2 mm/s off at the last sample.
    t, recorded, _, v, _ = _ramp(0.5, 0.0)
    e = derivatives.estimate(t, recorded)
    assert e.ends_replaced > 0
    assert np.max(np.abs(e.v - v)) < 5e-3


def test_a_fast_sine_test_of_a_damper():
    # MR-damper style: ±2 mm at 5 Hz sampled at 200 Hz, 1 µm encoder noise.
    t = np.arange(0.0, 3.0, 1 / 200) + 1e-4
    x, v, a = em.sine(t, amplitude=2.0, period=0.2)
    e = derivatives.estimate(t, x + np.random.default_rng(1).normal(0, 1e-3, t.shape))
    assert np.sqrt(np.mean((e.v - v) ** 2)) < 2e-3 * np.max(np.abs(v))
    assert np.sqrt(np.mean((e.a - a) ** 2)) < 2e-2 * np.max(np.abs(a))


@pytest.mark.parametrize("rate_hz, noise_mm", [(1.0, 1e-3), (2.0, 1e-4), (10.0, 1e-3)])
def test_the_velocity_error_estimate_tracks_the_true_error(rate_hz, noise_mm):
    t, recorded, _, v, _ = _ramp(rate_hz, noise_mm, seed=2)
    e = derivatives.estimate(t, recorded)
    true = np.sqrt(np.mean((e.v - v) ** 2))
    assert 0.4 < derivatives.velocity_error(t, recorded, e) / true < 2.0


def test_robust_noise_sees_white_noise_and_not_the_motion():
    t = np.arange(0.0, 2000.0)
    x, _, _ = em.ramp(t)
    assert derivatives.robust_noise(x) < 1e-6
    noisy = x + np.random.default_rng(3).normal(0, 2e-3, t.shape)
    assert derivatives.robust_noise(noisy) == pytest.approx(2e-3, rel=0.1)


def test_bad_arrays_are_refused():
    with pytest.raises(ValueError, match="equal length"):
        derivatives.estimate(np.arange(10.0), np.arange(9.0))
    with pytest.raises(ValueError, match="uniformly"):
        derivatives.estimate(np.r_[np.arange(10.0), 12.0], np.arange(11.0))
