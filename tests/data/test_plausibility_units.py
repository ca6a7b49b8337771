"""``data check``'s warnings for a time column in milliseconds and a zero or flat force: given where
they are meant, silent on every specimen we ship and on MR-damper tests at usual rates."""

from pathlib import Path

import numpy as np
import pytest

from bwbench.data import plausibility
from bwbench.data.specimen import Specimen, read_specimen
from bwbench.datasets import mr_damper

DATA = Path(__file__).resolve().parents[2] / "data" / "specimens"


def specimen(t, x, f) -> Specimen:
    return Specimen(path="x.csv", name="x", t=np.asarray(t, float), x=np.asarray(x, float), f=np.asarray(f, float))


def test_no_warning_on_any_shipped_specimen():
    for path in sorted(DATA.glob("*.csv")):
        spec = read_specimen(path)
        assert plausibility.time_unit_warnings(spec) == [] and plausibility.force_warnings(spec) == [], path


@pytest.mark.parametrize("frequency_hz, rate_hz", [(0.1, 500.0), (1.0, 500.0), (5.0, 2000.0), (1.0, 10000.0)])
def test_no_warning_on_mr_damper_tests_in_seconds(frequency_hz, rate_hz):
    test = mr_damper.sine_test(frequency_hz=frequency_hz, rate_hz=rate_hz, cycles=2, rng=1)
    spec = specimen(test.t, test.x, test.f)
    assert plausibility.time_unit_warnings(spec) == [] and plausibility.force_warnings(spec) == []


def test_a_synthetic_specimen_in_ms_is_warned_by_its_sample_spacing():
    spec = read_specimen(DATA / "pom-mt24u01_0.01MPa_r1.csv")
    (text,) = plausibility.time_unit_warnings(specimen(spec.t * 1000, spec.x, spec.f))
    assert text.startswith("samples are 1000 s apart (0.001 Hz)") and "milliseconds" in text


def test_an_mr_damper_test_at_1_khz_in_ms_is_warned_by_its_cycle_length():
    test = mr_damper.sine_test(frequency_hz=1.0, rate_hz=1000.0, cycles=3, rng=2)
    (text,) = plausibility.time_unit_warnings(specimen(test.t * 1000, test.x, test.f))
    assert text.startswith("one loading cycle takes 1000 s (3 cycles") and "milliseconds" in text


def test_a_zero_a_constant_and_a_flat_force_are_warned_and_a_small_real_one_is_not():
    test = mr_damper.sine_test(frequency_hz=1.0, rate_hz=200.0, cycles=2, rng=3)
    zero = plausibility.force_warnings(specimen(test.t, test.x, 0 * test.f))
    constant = plausibility.force_warnings(specimen(test.t, test.x, 0 * test.f + 12.5))
    flat = plausibility.force_warnings(specimen(test.t, test.x, 1000.0 + 1e-7 * test.f / test.f.max()))
    small = plausibility.force_warnings(specimen(test.t, test.x, 1e-3 * test.f))  # mN-scale: still a loop
    assert zero == ["force_N is 0 in every row: no force was recorded (load cell off, or an empty column?)"]
    assert constant[0].startswith("force_N is flat (12.5 N, varying by 0 N)")
    assert flat[0].startswith("force_N is flat (1000 N")
    assert small == []
