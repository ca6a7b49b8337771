"""MR-damper sine tests from Spencer et al. (1997): format, energy, physics, convergence, determinism."""

from pathlib import Path

import numpy as np
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.datasets import mr_damper

DATA = Path(__file__).resolve().parents[2] / "data" / "specimens"


def one_cycle(n_per_cycle, *arrays):
    return [a[: n_per_cycle + 1] for a in arrays]


def test_file_reads_back_with_the_requested_samples_rate_and_amplitude(tmp_path):
    path = tmp_path / "mr_1hz.csv"
    test = mr_damper.write_test(path, amplitude_mm=25.0, frequency_hz=1.0, rate_hz=500.0, cycles=3, rng=3)
    spec = read_specimen(path)
    assert spec.n_samples == 3 * 500 + 1  # 3 whole cycles of 500 samples, the last closing the loop
    assert spec.t[0] == 0.0 and spec.t[-1] == pytest.approx(3.0, abs=1e-9)
    assert np.diff(spec.t) == pytest.approx(np.full(1500, 0.002), abs=1e-9)
    # 500 samples per cycle put samples on the peaks; only the 1 µm encoder noise (and the
    # 10 nm rounding of the file) is left on them.
    assert spec.x.max() == pytest.approx(25.0, abs=0.005)
    assert spec.x.min() == pytest.approx(-25.0, abs=0.005)
    assert np.abs(spec.f - test.f).max() <= 0.5e-4 + 1e-9  # the file keeps 0.1 mN


def test_loop_dissipates_the_expected_energy_and_peaks_at_the_requested_force():
    test = mr_damper.sine_test(
        amplitude_mm=25.0, frequency_hz=1.0, voltage=1.0, rate_hz=500.0, peak_force_N=1200.0, rng=0
    )
    # Spencer's damper itself (cross-checked against an SI-unit Radau solution at rtol 1e-10).
    assert test.peak_unscaled_N == pytest.approx(938.38, abs=0.01)
    assert test.scale == pytest.approx(1200.0 / 938.38, rel=1e-5)
    x, f, x_true, f_true = one_cycle(500, test.x, test.f, test.x_true, test.f_true)
    energy = mr_damper.loop_energy(x_true, f_true)
    assert energy == pytest.approx(98_944, rel=1e-3)  # N·mm: ~99 J per cycle
    # Order of magnitude: a friction-like MR loop fills most of the 2X × 2F rectangle.
    assert 0.75 < energy / (4 * 25.0 * 1200.0) < 0.9
    # The noisy record gives the same energy to 0.1 %: the offset drops out of a closed loop.
    assert mr_damper.loop_energy(x, f) == pytest.approx(energy, rel=1e-3)
    assert np.abs(test.f_true).max() == pytest.approx(1200.0, rel=1e-12)
    assert np.abs(test.f).max() == pytest.approx(1200.0, rel=0.05)


def test_noise_and_offset_have_the_requested_size():
    test = mr_damper.sine_test(frequency_hz=1.0, rate_hz=1000.0, cycles=3, rng=11)
    df = test.f - test.f_true
    assert df.mean() == pytest.approx(8.0, abs=0.5)  # σ/√3001 ≈ 0.11 N
    assert df.std() == pytest.approx(0.005 * 1200.0, rel=0.05)
    assert (test.x - test.x_true).std() == pytest.approx(0.001, rel=0.05)


def test_force_grows_with_velocity_and_voltage():
    def peak(f_hz, volts):
        return mr_damper.sine_test(
            frequency_hz=f_hz, voltage=volts, rate_hz=500.0, cycles=1, peak_force_N=None, rng=0
        ).peak_unscaled_N

    # Same ±25 mm: 0.1 Hz (≤ 16 mm/s) stays on the steep low-velocity c1 branch, 5 Hz (≤ 785 mm/s)
    # adds the post-yield c0 viscous force.
    assert peak(0.1, 1.0) == pytest.approx(520.85, abs=0.05)
    assert peak(5.0, 1.0) == pytest.approx(2343.49, abs=0.05)
    # The field raises the yield force α·z: 0 → 1 → 2.25 V at 1 Hz.
    p0, p1, p2 = peak(1.0, 0.0), peak(1.0, 1.0), peak(1.0, 2.25)
    assert p0 == pytest.approx(486.5, abs=0.1)
    assert p1 > 1.9 * p0 and p2 > 1.5 * p1


def test_loop_runs_anticlockwise_unlike_the_projects_synthetic_specimens():
    test = mr_damper.sine_test(frequency_hz=5.0, rate_hz=1000.0, rng=0)
    assert mr_damper.loop_energy(*one_cycle(200, test.x_true, test.f_true)) > 0
    # The docstring warns that the project's specimens have the opposite sign; keep it true.
    spec = read_specimen(DATA / "pom-mt24u01_0.01MPa_r1.csv")
    quarter = spec.n_samples // 16  # 4 cycles, 1,920 s: one cycle is 480 samples
    assert mr_damper.loop_energy(spec.x[quarter : quarter + 481], spec.f[quarter : quarter + 481]) < -2000


@pytest.mark.parametrize("f_hz, volts", [(0.1, 0.0), (1.0, 2.25), (5.0, 1.0)])
def test_integration_is_converged(f_hz, volts):
    t, x, force, m = mr_damper.damper_force(25.0, f_hz, volts, rate_hz=200.0, cycles=1)
    _, _, finer, _ = mr_damper.damper_force(25.0, f_hz, volts, rate_hz=200.0, cycles=1, substeps=2 * m)
    assert np.abs(finer - force).max() < 1e-3 * np.ptp(force)
    # Far inside that: the default step is converged to ~1e-7 of the range.
    assert np.abs(finer - force).max() < 1e-6 * np.ptp(force)


def test_same_seed_gives_identical_bytes(tmp_path):
    kwargs = dict(frequency_hz=2.0, voltage=0.5, rate_hz=400.0)
    a = mr_damper.write_test(tmp_path / "a.csv", rng=7, **kwargs)
    mr_damper.write_test(tmp_path / "b.csv", rng=np.random.default_rng(7), **kwargs)
    mr_damper.write_test(tmp_path / "c.csv", rng=8, **kwargs)
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    assert (tmp_path / "a.csv").read_bytes() != (tmp_path / "c.csv").read_bytes()
    assert (tmp_path / "a.csv").read_text().splitlines()[0] == "time_s,displacement_mm,force_N"
    assert a.t.size == 3 * 200 + 1


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError):
        mr_damper.sine_test(frequency_hz=0.0)
    with pytest.raises(ValueError):
        mr_damper.sine_test(cycles=0)


def test_a_velocity_channel_can_be_written_and_matches_the_displacement(tmp_path):
    from bwbench.data.plausibility import signal_warnings
    from bwbench.data.specimen import read_specimen

    path = tmp_path / "mr.csv"
    test = mr_damper.write_test(
        path, frequency_hz=2.0, rate_hz=500.0, cycles=2, rng=5, velocity=True, velocity_noise_mm_s=0.5
    )
    spec = read_specimen(path)
    assert spec.measured_signals == ("velocity",)
    w = 2 * np.pi * 2.0
    np.testing.assert_allclose(spec.v, 25.0 * w * np.cos(w * spec.t), atol=0.5 * 5 + 1e-3)
    assert np.std(spec.v - 25.0 * w * np.cos(w * spec.t)) == pytest.approx(0.5, rel=0.1)
    assert signal_warnings(spec) == []
    # without the channel the bytes are those of the files written before it existed
    plain = mr_damper.render(mr_damper.sine_test(frequency_hz=2.0, rate_hz=500.0, cycles=2, rng=5))
    assert plain.splitlines()[1:] == [
        ",".join(line.split(",")[i] for i in (0, 1, 3)) for line in path.read_text().splitlines()[1:]
    ]
    assert test.v is not None
