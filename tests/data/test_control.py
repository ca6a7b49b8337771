"""The control channel of a test (``bwbench.data.control``): read, resolved per file, checked, reported."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bwbench.cli import main
from bwbench.data import control
from bwbench.errors import UserError

HEADER = "time_s,displacement_mm,force_N"


def _write(path, control_column: str | None = None, values=None, n: int = 200, force_N: float = 40.0):
    t = np.arange(n) * 0.01
    x = 5 * np.sin(2 * np.pi * t)
    f = force_N * np.cos(2 * np.pi * t) + 3 * x
    rows = [HEADER + (f",{control_column}" if control_column else "")]
    for k in range(n):
        cells = [f"{t[k]:.4f}", f"{x[k]:.5f}", f"{f[k]:.4f}"]
        if control_column:
            cells.append(str(values[k]) if values is not None else "0.5")
        rows.append(",".join(cells))
    path.write_text("\n".join(rows) + "\n")
    return str(path)


def test_a_named_column_is_read_and_summarised(tmp_path):
    u = np.where(np.arange(200) % 50 < 25, 0.0, 2.25)  # switching every 0.25 s
    spec = control.read(_write(tmp_path / "a.csv", "voltage_V", u), control.parse("voltage_V"))
    assert spec.control_name == "voltage_V"
    np.testing.assert_array_equal(spec.control, u)
    s = control.summary(spec)
    assert (s.low, s.high, s.levels, s.switches) == (0.0, 2.25, (0.0, 2.25), 7)
    assert s.text() == "control: voltage_V 0 … 2.25 V, 2 levels (0, 2.25 V), 7 changes of level (3.52 per s)"


def test_a_constant_for_files_without_the_column_and_a_manifest_level(tmp_path):
    path = _write(tmp_path / "b.csv")
    assert control.level_of(control.read(path, control.parse("current_A=0.5"))) == 0.5
    (tmp_path / "manifest.json").write_text(json.dumps({"specimens": [{"file": "b.csv", "current_A": 0.75}]}))
    assert control.level_of(control.read(path, control.parse("current_A"))) == 0.75
    with pytest.raises(UserError, match=r"b.csv: the current_A level is given twice: manifest.json \(0.75\) and "):
        control.read(path, control.parse("current_A=0.5"))


def test_a_column_and_a_level_for_the_same_file_is_given_twice(tmp_path):
    path = _write(tmp_path / "c.csv", "current_A")
    with pytest.raises(UserError, match="given twice: the file's column and a level for the file"):
        control.read(path, control.parse("current_A"), level=0.25)


def test_the_shipped_vpp_specimens_carry_their_underpressure():
    spec = control.read("data/specimens/pom-c9021_0.07MPa_r2.csv", control.parse("underpressure_MPa"))
    assert control.level_of(spec) == 0.07


@pytest.mark.parametrize(
    "content, flags, message",
    [
        ("none", ["--control", "current_A"], "no column current_A and no current_A level for this file"),
        ("nan", ["--control", "current_A"], ":7: NaN in column current_A: 'nan'"),
        ("word", ["--control", "current_A"], ":7: not a number in column current_A: 'high'"),
        ("none", ["--control", "current_A=0.5", "--control", "current_A=1"], "--control current_A is given twice"),
        ("none", ["--control", "current_A=lots"], "the level 'lots' is not a number"),
        ("none", ["--control", "current"], "a control is named <quantity>_<unit>"),
        ("column", [], "unexpected column 'current_A'"),
    ],
)
def test_bad_control_input_is_one_line_and_exit_2(tmp_path, capsys, content, flags, message):
    values = ["0.5"] * 200
    if content == "nan":
        values[5] = "nan"
    if content == "word":
        values[5] = "high"
    path = _write(tmp_path / "t.csv", None if content == "none" else "current_A", values)
    assert main(["data", "check", path, *flags]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and message in err, err


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--control", "current_A=0.5", "--law", "alpha=linear"], "spencer (identifiable) has no parameter 'alpha'"),
        (["--law", "vy=linear"], "--law and --control-filter need the control: --control COLUMN"),
        (["--control", "current_A=0.5", "--law", "vy=cubic"], "unknown law 'cubic' for vy"),
        (["--control", "current_A=0.5", "--law", "vy=linear"], "a linear law needs 2 control levels, the files have 1"),
        (["--control", "current_A=0.5", "--law", "vy=linear", "--each"], "--each fits each file alone"),
    ],
)
def test_bad_laws_are_one_line_and_exit_2(tmp_path, capsys, flags, message):
    paths = [_write(tmp_path / f"{k}.csv", force_N=f) for k, f in (("a", 40.0), ("b", 50.0))]  # two tests, not copies
    status = main(["fit", *paths, "--model", "spencer", "--out", str(tmp_path / "fit.json"), *flags])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "fit.json").exists()


def test_a_dataframe_carries_its_control_column_and_a_nan_there_is_refused(tmp_path):
    import pandas as pd

    from bwbench.problems.hysteresis.control.setup import read_controlled

    frame = pd.read_csv(_write(tmp_path / "f.csv", "current_A", [0.25] * 200))
    frame.attrs["name"] = "f"
    (spec,), laws = read_controlled([frame], None, "current_A", None, "vy=linear", False)
    assert control.level_of(spec) == 0.25 and laws == {"vy": "linear"}
    frame.loc[7, "current_A"] = float("nan")
    with pytest.raises(UserError, match="DataFrame 'f', row 7: current_A is nan: every value must be finite"):
        read_controlled([frame], None, "current_A", None, "vy=linear", False)
