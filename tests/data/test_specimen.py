"""Specimen CSV reading (docs/file-formats.md): valid files read exactly, every malformed file is refused
with one line ``error: FILE:LINE: what is wrong`` and exit status 2."""

from __future__ import annotations

import numpy as np
import pytest

from bwbench.cli import main
from bwbench.data.specimen import MIN_SAMPLES, Specimen, read_specimen
from bwbench.errors import InputFileError

HEADER = "time_s,displacement_mm,force_N"
N = 50


def _rows(n=N):
    """n valid samples: t = 0, 0.01, ...; x a sine in mm; f a force in N."""
    t = np.round(np.arange(n) * 0.01, 10)
    x = np.round(2.5 * np.sin(2 * np.pi * t), 6)
    f = np.round(-40.0 * x + 3.0 * np.cos(2 * np.pi * t), 6)
    return t, x, f


def _csv(t, x, f, header=HEADER, sep=",", decimal="."):
    lines = [header]
    for row in zip(t, x, f):
        lines.append(sep.join(repr(float(v)).replace(".", decimal) for v in row))
    return "\n".join(lines) + "\n"


def _valid_lines():
    return _csv(*_rows()).splitlines()


def _with_line(line_no: int, text: str) -> str:
    """The valid file with 1-based line ``line_no`` replaced."""
    lines = _valid_lines()
    lines[line_no - 1] = text
    return "\n".join(lines) + "\n"


def _write(tmp_path, content, name="spec.csv"):
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8", newline="")
    return path


def _check_cli(path, line, capsys) -> str:
    capsys.readouterr()
    assert main(["data", "check", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    err_lines = err.splitlines()
    assert len(err_lines) == 1, err
    prefix = f"error: {path}:{line}:" if line is not None else f"error: {path}:"
    assert err_lines[0].startswith(prefix), err_lines[0]
    return err_lines[0]


# --- valid files -----------------------------------------------------------------------------


def test_valid_file_reads_exact_values_and_cli_says_ok(tmp_path, capsys):
    t, x, f = _rows()
    path = _write(tmp_path, _csv(t, x, f), "POM_0.05.csv")
    spec = read_specimen(path)
    assert isinstance(spec, Specimen)
    assert spec.path == str(path)
    assert spec.name == "POM_0.05"
    assert spec.n_samples == N == 50
    assert spec.duration_s == pytest.approx(0.49)
    np.testing.assert_array_equal(spec.t, t)
    np.testing.assert_array_equal(spec.x, x)
    np.testing.assert_array_equal(spec.f, f)
    assert spec.x[25] == pytest.approx(2.5 * np.sin(2 * np.pi * 0.25))
    assert not spec.t.flags.writeable  # frozen means frozen

    capsys.readouterr()
    assert main(["data", "check", str(path)]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    first, protocol, signals = out.splitlines()
    assert first == f"ok: {path}: 50 samples at 100 Hz, 0.49 s, displacement 0 … 2.5 mm, force -100 … 3 N"
    assert protocol == "  protocol: 1 reversal of motion: too few cycles to name a protocol"
    assert signals.startswith("  signals: displacement measured, velocity and acceleration estimated from it")


def test_semicolon_decimal_comma_reads_same_numbers(tmp_path):
    t, x, f = _rows()
    comma = read_specimen(_write(tmp_path, _csv(t, x, f), "comma.csv"))
    euro_text = _csv(t, x, f, header="time_s;displacement_mm;force_N", sep=";", decimal=",")
    assert "0,01;" in euro_text  # really a decimal-comma file
    euro = read_specimen(_write(tmp_path, euro_text, "euro.csv"))
    for a, b in ((comma.t, euro.t), (comma.x, euro.x), (comma.f, euro.f)):
        np.testing.assert_array_equal(a, b)
    assert euro.n_samples == 50


def test_semicolon_example_from_brief(tmp_path):
    lines = ["time_s;displacement_mm;force_N"]
    lines += [f"{i / 10:.1f};{1.25 + i / 100:.2f};{-3.5 + i:.1f}".replace(".", ",") for i in range(25)]
    assert lines[1] == "0,0;1,25;-3,5"
    spec = read_specimen(_write(tmp_path, "\n".join(lines) + "\n"))
    assert spec.t[0] == 0.0 and spec.x[0] == 1.25 and spec.f[0] == -3.5
    assert spec.x[24] == pytest.approx(1.49) and spec.f[24] == pytest.approx(20.5)


def test_bom_whitespace_crlf_blank_lines_and_column_order(tmp_path):
    t, x, f = _rows()
    # columns in another order, padded header, BOM, CRLF line ends, a blank line and a trailing one
    lines = ["\ufeff force_N , time_s ,displacement_mm "]
    lines += [f"{fi!r},{ti!r},{xi!r}" for ti, xi, fi in zip(t.tolist(), x.tolist(), f.tolist())]
    lines.insert(10, "")
    spec = read_specimen(_write(tmp_path, "\r\n".join(lines) + "\r\n\r\n"))
    np.testing.assert_array_equal(spec.t, t)
    np.testing.assert_array_equal(spec.x, x)
    np.testing.assert_array_equal(spec.f, f)


def test_blank_line_does_not_shift_error_line(tmp_path):
    lines = _valid_lines()
    lines.insert(5, "")  # becomes line 6
    lines[9] = "0.08,oops,1.0"  # line 10
    with pytest.raises(InputFileError) as info:
        read_specimen(_write(tmp_path, "\n".join(lines) + "\n"))
    assert info.value.line == 10


# --- malformed files: each refused with the right line and words --------------------------------

_t, _x, _f = _rows()

MALFORMED = {
    # name: (content, line, words that must be in the problem)
    "empty": ("", 1, ["empty file"]),
    "whitespace only": ("\n  \n", 1, ["empty file"]),
    "header only": (HEADER + "\n", 1, ["header only", "no data"]),
    "header only, blank lines": (HEADER + "\n\n\n", 1, ["header only"]),
    "NUL bytes": ((HEADER + "\n0.0,0.0,1.0\n0.01,0.1,1.0\n").encode() + b"\x00\x01\x02\n", 4, ["binary", "NUL"]),
    "PNG": (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", 3, ["binary"]),
    "xlsx": (b"PK\x03\x04\x14\x00\x06\x00", 1, ["binary", "xlsx", "CSV"]),
    "UTF-16": (_csv(_t, _x, _f).encode("utf-16"), 1, ["UTF-16", "UTF-8"]),
    "Latin-1": (_with_line(3, "0.01,0.1,1.0 \u00e9").encode("latin-1"), 3, ["not UTF-8", "0xe9"]),
    "missing column": (_with_line(1, "time_s,displacement_mm,force"), 1, ["missing column", "'force_N'"]),
    "missing two columns": (_with_line(1, "time_s,x,f"), 1, ["missing columns", "'displacement_mm'", "'force_N'"]),
    "no header": ("\n".join(_valid_lines()[1:]) + "\n", 1, ["missing columns", "'time_s'"]),
    "tab separated": (_csv(_t, _x, _f, header=HEADER.replace(",", "\t"), sep="\t"), 1, ["missing column"]),
    "extra column": (_with_line(1, HEADER + ",temp_C"), 1, ["unexpected column", "'temp_C'"]),
    "duplicate column": (_with_line(1, HEADER + ",force_N"), 1, ["'force_N'", "twice"]),
    "too few cells": (_with_line(5, "0.03,0.4"), 5, ["2 cells", "expected 3"]),
    "too many cells": (_with_line(2, "0.0,0.0,1.0,7"), 2, ["4 cells", "expected 3"]),
    "trailing separator": (_with_line(30, "0.28,1.2,3.4,"), 30, ["4 cells", "expected 3"]),
    "non-numeric": (_with_line(7, "0.05,abc,1.0"), 7, ["not a number", "displacement_mm", "'abc'"]),
    "quoted number": (_with_line(8, '0.06,0.2,"1.0"'), 8, ["not a number", "force_N", "'\"1.0\"'"]),
    "empty cell": (_with_line(9, "0.07,,1.0"), 9, ["empty cell", "displacement_mm"]),
    "NaN": (_with_line(6, "0.04,0.3,nan"), 6, ["NaN", "force_N", "'nan'"]),
    "inf": (_with_line(4, "0.02,-inf,1.0"), 4, ["infinite", "displacement_mm", "'-inf'"]),
    "overflow": (_with_line(12, "0.1,0.3,1e999"), 12, ["too large", "force_N", "'1e999'"]),
    "time repeated": (_with_line(11, "0.08,0.3,1.0"), 11, ["time not strictly increasing", "0.08 s after 0.08 s"]),
    "time decreasing": (_with_line(30, "0.1,0.3,1.0"), 30, ["time not strictly increasing", "0.1 s after 0.27 s"]),
    "too few samples": (_csv(*_rows(MIN_SAMPLES - 1)), MIN_SAMPLES, ["too few samples", "19", "at least 20"]),
    "no motion": (_csv(_t, np.full(N, 1.25), _f), 2, ["no motion", "1.25 mm"]),
    "semicolon header, comma rows": (
        "time_s;displacement_mm;force_N\n" + "\n".join(_valid_lines()[1:]) + "\n",
        2,
        ["1 cell", "';'"],
    ),
    "semicolon, non-numeric keeps decimal comma text": (
        _csv(_t, _x, _f, header="time_s;displacement_mm;force_N", sep=";", decimal=",").replace("0,02;", "0,02x;", 1),
        4,
        ["not a number", "time_s", "'0,02x'"],
    ),
}


@pytest.mark.parametrize("case", list(MALFORMED), ids=list(MALFORMED))
def test_malformed_file_refused_with_line(case, tmp_path, capsys):
    content, line, words = MALFORMED[case]
    path = _write(tmp_path, content)
    with pytest.raises(InputFileError) as info:
        read_specimen(path)
    err = info.value
    assert err.path == str(path)
    assert err.line == line
    for word in words:
        assert word in err.problem, (word, err.problem)
    assert str(err) == f"{path}:{line}: {err.problem}"

    line_out = _check_cli(path, line, capsys)
    assert line_out == f"error: {path}:{line}: {err.problem}"


def test_missing_file(tmp_path, capsys):
    path = tmp_path / "nope.csv"
    with pytest.raises(InputFileError) as info:
        read_specimen(path)
    assert info.value.line is None  # no line to point at
    assert info.value.problem == "no such file"
    assert _check_cli(path, None, capsys) == f"error: {path}: no such file"


def test_directory_is_refused(tmp_path, capsys):
    with pytest.raises(InputFileError) as info:
        read_specimen(tmp_path)
    assert "directory" in info.value.problem
    _check_cli(tmp_path, None, capsys)


def test_min_samples_is_accepted(tmp_path):
    spec = read_specimen(_write(tmp_path, _csv(*_rows(MIN_SAMPLES))))
    assert spec.n_samples == MIN_SAMPLES == 20


def test_error_deep_in_a_large_file_names_its_line(tmp_path):
    t = np.arange(100_000) * 1e-3
    lines = [HEADER] + [f"{v!r},{float(np.sin(v))!r},{float(np.cos(v))!r}" for v in t.tolist()]
    lines[87_654] = "87.653,0.5,n/a"
    with pytest.raises(InputFileError) as info:
        read_specimen(_write(tmp_path, "\n".join(lines) + "\n"))
    assert info.value.line == 87_655
    assert info.value.problem == "not a number in column force_N: 'n/a'"


# --- several files -------------------------------------------------------------------------------


def test_check_several_files_one_error_line_per_bad_file(tmp_path, capsys):
    good = _write(tmp_path, _csv(*_rows()), "good.csv")
    bad_cells = _write(tmp_path, _with_line(5, "0.03,0.4"), "bad_cells.csv")
    bad_nan = _write(tmp_path, _with_line(6, "0.04,nan,1.0"), "bad_nan.csv")
    missing = tmp_path / "missing.csv"
    good2 = _write(tmp_path, _csv(*_rows(30)), "good2.csv")

    capsys.readouterr()
    status = main(["data", "check", str(good), str(bad_cells), str(bad_nan), str(missing), str(good2)])
    out, err = capsys.readouterr()
    assert status == 2
    assert [line for line in err.splitlines() if line.startswith("error:")] == [
        f"error: {bad_cells}:5: 2 cells on this row, expected 3 separated by ','",
        f"error: {bad_nan}:6: NaN in column displacement_mm: 'nan'",
        f"error: {missing}: no such file",
    ]
    assert [line.split(" at ")[0] for line in out.splitlines() if line.startswith("ok:")] == [
        f"ok: {good}: 50 samples",
        f"ok: {good2}: 30 samples",
    ]
