"""Optional velocity and acceleration columns in specimen files (docs/design.md#signals): read in any order and
both formats, part of the data identity, named by ``data check``, and checked against the displacement."""

import numpy as np
import pytest

import exact_motions as em
from bwbench.cli import main
from bwbench.data.identity import files_sha256
from bwbench.data.plausibility import signal_warnings
from bwbench.data.specimen import read_specimen
from bwbench.errors import InputFileError


def _motion(n=361, rate=2.0):
    """Three 60 s cycles of a ±5 mm sine; the force of a spring and dashpot (dissipating)."""
    t = np.arange(n) / rate
    x, v, a = em.sine(t, amplitude=5.0, period=60.0)
    return t, x, v, a, 30.0 * x + 200.0 * v


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_velocity_and_acceleration_columns_are_read_in_any_order(tmp_path):
    t, x, v, a, f = _motion()
    plain = read_specimen(_write(tmp_path, "plain.csv", em.render_csv(t, x, f)))
    assert plain.v is None and plain.a is None and plain.measured_signals == ()
    both = read_specimen(_write(tmp_path, "both.csv", em.render_csv(t, x, f, v=v, a=a)))
    np.testing.assert_allclose(both.v, v, atol=1e-7)
    np.testing.assert_allclose(both.a, a, atol=1e-9)
    np.testing.assert_array_equal(both.x, plain.x)
    assert both.measured_signals == ("velocity", "acceleration")
    assert not both.v.flags.writeable
    lines = em.render_csv(t, x, f, v=v, a=a, sep=";", decimal=",").splitlines()
    order = [4, 2, 0, 3, 1]  # acceleration, force, time, velocity, displacement
    text = "\n".join(";".join(np.array(line.split(";"))[order]) for line in lines) + "\n"
    export = read_specimen(_write(tmp_path, "export.csv", text))
    for name in ("t", "x", "f", "v", "a"):
        np.testing.assert_array_equal(getattr(export, name), getattr(both, name))
    only_a = read_specimen(_write(tmp_path, "only_a.csv", em.render_csv(t, x, f, a=a)))
    assert only_a.measured_signals == ("acceleration",)


def test_bad_signal_columns_are_refused_with_their_line(tmp_path):
    t, x, v, _, f = _motion()
    text = em.render_csv(t, x, f, v=v)
    twice = text.replace("velocity_mm_s", "velocity_mm_s,velocity_mm_s", 1)
    with pytest.raises(InputFileError, match="'velocity_mm_s' appears twice"):
        read_specimen(_write(tmp_path, "twice.csv", twice))
    with pytest.raises(InputFileError, match="column 'velocity_mm_h': unknown unit; velocity may be velocity_mm_s"):
        read_specimen(_write(tmp_path, "unit.csv", text.replace("velocity_mm_s", "velocity_mm_h", 1)))
    lines = text.splitlines()
    lines[7] = lines[7].rsplit(",", 1)[0]  # row 8 lost its velocity
    with pytest.raises(InputFileError, match="3 cells on this row, expected 4") as err:
        read_specimen(_write(tmp_path, "short.csv", "\n".join(lines) + "\n"))
    assert err.value.line == 8
    lines = text.splitlines()
    lines[9] = lines[9].rsplit(",", 1)[0] + ",nan"
    with pytest.raises(InputFileError, match="NaN in column velocity_mm_s") as err:
        read_specimen(_write(tmp_path, "nan.csv", "\n".join(lines) + "\n"))
    assert err.value.line == 10


def test_the_velocity_column_is_part_of_the_data_identity(tmp_path):
    t, x, v, _, f = _motion()
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = _write(tmp_path / "a", "s.csv", em.render_csv(t, x, f, v=v))
    b = _write(tmp_path / "b", "s.csv", em.render_csv(t, x, f, v=1.001 * v))  # only the velocity differs
    assert files_sha256([a]) != files_sha256([b])


def test_data_check_says_which_signals_are_measured_and_which_estimated(tmp_path, capsys):
    t, x, v, _, f = _motion()
    measured = _write(tmp_path, "measured.csv", em.render_csv(t, x, f, v=v))
    estimated = _write(tmp_path, "estimated.csv", em.render_csv(t, x, f))
    only_a = _write(tmp_path, "only_a.csv", em.render_csv(t, x, f, a=_motion()[3]))
    capsys.readouterr()
    assert main(["data", "check", str(measured), str(estimated), str(only_a)]) == 0
    out, err = capsys.readouterr()
    lines = [line for line in out.splitlines() if line.startswith("  signals:")]  # one per file
    assert len(lines) == 3, out
    assert lines[0] == (
        "  signals: displacement and velocity measured (velocity_mm_s), acceleration estimated from the velocity"
    )
    assert lines[1].startswith(
        "  signals: displacement measured, velocity and acceleration estimated from it "
        "(quintic smoothing spline; displacement noise "
    )
    assert "expected velocity error" in lines[1] and "per 1000 N·s/mm" in lines[1]
    assert lines[2].startswith(
        "  signals: displacement measured, velocity estimated from it, acceleration measured "
        "(acceleration_mm_s2) (quintic smoothing spline"
    )
    assert err == ""


@pytest.mark.parametrize(
    "recorded, hint",
    [
        (lambda v: -v, "-1 × the one the displacement implies (the opposite sign convention?)"),
        (lambda v: 60 * v, "60 × the one the displacement implies (mm/min instead of the header's unit?)"),
        (lambda v: -60 * v, "-60 × the one the displacement implies (the opposite sign convention and mm/min"),
        (lambda v: 1000 * v, "1e+03 × the one the displacement implies (time_s in milliseconds"),
    ],
)
def test_a_velocity_column_inconsistent_with_the_displacement_gets_a_warning(tmp_path, capsys, recorded, hint):
    t, x, v, _, f = _motion()
    path = _write(tmp_path, "bad.csv", em.render_csv(t, x, f, v=recorded(v)))
    capsys.readouterr()
    assert main(["data", "check", str(path)]) == 0  # a warning, not an error: the file is valid
    _, err = capsys.readouterr()
    assert (
        f"warning: {path}: column velocity_mm_s does not match the displacement: the velocity recorded is {hint}" in err
    )


def test_a_velocity_of_another_channel_or_shifted_in_time_gets_a_warning(tmp_path):
    t, x, v, a, f = _motion()
    shifted = read_specimen(_write(tmp_path, "shifted.csv", em.render_csv(t, x, f, v=np.interp(t - 10.0, t, v))))
    assert any("does not follow the displacement" in w for w in signal_warnings(shifted))
    fine = read_specimen(
        _write(
            tmp_path, "fine.csv", em.render_csv(t, x + np.random.default_rng(0).normal(0, 1e-3, t.shape), f, v=v, a=a)
        )
    )
    assert signal_warnings(fine) == []
    wrong_a = read_specimen(_write(tmp_path, "wrong_a.csv", em.render_csv(t, x, f, v=v, a=-a)))
    assert [w.split(":")[0] for w in signal_warnings(wrong_a)] == [
        "column acceleration_mm_s2 does not match the displacement"
    ]
