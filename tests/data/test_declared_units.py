"""Declared units (``<quantity>_<unit>`` column names, ``--units``), the warning naming inches and kips
on a file that declares none, and a rounded time column: files written here by hand as another lab's
export would be, commands run from another folder."""

import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from bwbench.cli import main
from bwbench.data import plausibility, units
from bwbench.data.specimen import read_specimen
from bwbench.data.specimen_input import from_frame
from bwbench.errors import UserError

KIP = 4448.2216152605


def friction_damper_inches_kips(n=400):
    """A ±1 in, ±5 kip loop with a velocity in in/s (as an inch–kip lab records it)."""
    t = np.arange(n) * 0.02
    x = np.sin(2 * np.pi * 0.5 * t)
    v = np.pi * np.cos(2 * np.pi * 0.5 * t)
    f = 5.0 * np.tanh(8 * v) + 0.3 * x
    return t, x, v, f


def write(path, header, columns, fmt="%.9g"):
    np.savetxt(path, np.column_stack(columns), delimiter=",", header=header, comments="", fmt=fmt)
    return path


@pytest.fixture
def elsewhere(tmp_path):
    """Run from a folder that is not the repository's."""
    before = os.getcwd()
    os.chdir(tmp_path)
    yield tmp_path
    os.chdir(before)


def test_declared_columns_read_as_their_converted_twin(elsewhere):
    t, x, v, f = friction_damper_inches_kips()
    declared = read_specimen(write("fd.csv", "time_s,displacement_in,velocity_in_s,force_kip", [t, x, v, f]))
    twin = read_specimen(
        write("twin.csv", "time_s,displacement_mm,velocity_mm_s,force_N", [t, 25.4 * x, 25.4 * v, KIP * f])
    )
    for ours, theirs in ((declared.x, twin.x), (declared.v, twin.v), (declared.f, twin.f)):
        np.testing.assert_allclose(ours, theirs, rtol=1e-8)  # the twin printed to 9 digits
    assert declared.reading_notes[0] == "displacement in inches (× 25.4 → mm)"
    assert plausibility.all_warnings(declared) == []  # a declared unit is not second-guessed
    ms = read_specimen(write("ms.csv", "time_ms,displacement_m,force_kN", [1000 * t, x / 1000, f]))
    np.testing.assert_allclose([ms.t[-1], ms.x.max(), ms.f.max()], [t[-1], x.max(), 1000 * f.max()], rtol=1e-9)


def test_units_option_declares_what_a_header_cannot_and_refuses_a_contradiction(elsewhere, capsys):
    t, x, v, f = friction_damper_inches_kips()
    write("plain.csv", "time_s,displacement_mm,force_N", [t, x, f])
    assert main(["data", "check", "plain.csv", "--units", "displacement=in,force=kip"]) == 0
    out, err = capsys.readouterr()
    assert "displacement -25.4 … 25.4 mm" in out and "read: displacement in inches" in out and "warning" not in err
    assert units.declared().units == {}  # declared for that command only
    write("declared.csv", "time_s,displacement_in,force_kip", [t, x, f])
    assert main(["data", "check", "declared.csv", "--units", "displacement=mm"]) == 2
    assert capsys.readouterr().err.strip() == (
        "error: declared.csv:1: column displacement_in declares displacement in inches, --units says mm: which is it?"
    )
    assert main(["data", "check", "plain.csv", "--units", "force=lb"]) == 2
    assert "force cannot be in 'lb'; known: N, kN, MN, kip, lbf" in capsys.readouterr().err
    write("typo.csv", "time_s,displacement_inch,force_N", [t, x, f])
    assert main(["data", "check", "typo.csv"]) == 2
    assert "column 'displacement_inch': unknown unit; displacement may be displacement_mm" in capsys.readouterr().err


def test_an_inch_kip_file_that_declares_nothing_is_warned_about_naming_inches_and_kips(elsewhere, capsys):
    t, x, v, f = friction_damper_inches_kips()
    write("undeclared.csv", "time_s,displacement_mm,force_N", [t, x, f])
    assert main(["data", "check", "undeclared.csv"]) == 0
    err = capsys.readouterr().err
    assert "an inch–kip file?" in err and "displacement_in and force_kip" in err
    # the velocity of an inch file next to a displacement in mm: its factor named as in/s
    write("mixed.csv", "time_s,displacement_mm,velocity_mm_s,force_N", [t, 25.4 * x, v, KIP * f])
    (text,) = plausibility.signal_warnings(read_specimen("mixed.csv"))
    assert "0.0394 ×" in text and "in/s (velocity_in_s)" in text


def test_a_rounded_time_column_gets_the_advice_to_rebuild_it_or_is_rebuilt_on_request(elsewhere, capsys):
    k = np.arange(3000)
    t = np.round(k / 3000, 5)  # 3 kHz printed to 10 µs: steps of 0.00033 and 0.00034 s
    write(
        "rounded.csv",
        "time_s,displacement_mm,force_N",
        [t, 5 * np.sin(2 * np.pi * 2 * t), 100 * np.sin(2 * np.pi * 2 * t)],
        "%.5f",
    )
    assert main(["data", "check", "rounded.csv"]) == 2
    err = capsys.readouterr().err
    assert "fs = 3000 Hz): rebuild it as t = t₀ + k/fs, or add --rebuild-time" in err and "numpy.interp" not in err
    with units.declaring(rebuild_time=True):
        spec = read_specimen("rounded.csv")
    np.testing.assert_allclose(spec.t, k / 3000, rtol=0, atol=1e-15)
    # a lost sample is not a rounding: refused with the advice to resample, even with --rebuild-time
    gap = np.delete(k / 100, 50)
    write("gap.csv", "time_s,displacement_mm,force_N", [gap, np.sin(gap), np.cos(gap)])
    with units.declaring(rebuild_time=True), pytest.raises(UserError, match="numpy.interp"):
        read_specimen("gap.csv")


def test_a_dataframe_may_declare_units_too():
    t, x, v, f = friction_damper_inches_kips()
    spec = from_frame(pd.DataFrame({"time_s": t, "displacement_in": x, "force_kN": f}), "fd")
    assert spec.x.max() == pytest.approx(25.4) and spec.f.max() == pytest.approx(1000 * f.max())


def test_the_shipped_specimens_get_no_unit_warning():
    data = Path(__file__).resolve().parents[2] / "data"
    for path in sorted([*data.glob("specimens/*.csv"), *data.glob("mr_damper/*.csv")]):
        assert plausibility.unit_warnings(read_specimen(path)) == [], path
