"""``bwbench data check`` refuses what later commands cannot use and warns about what is probably
not what the header promises (units, sign)."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from bwbench.cli import main
from bwbench.data import plausibility
from bwbench.data.specimen import read_specimen
from bwbench.datasets import mr_damper

DATA = Path(__file__).resolve().parents[2] / "data" / "specimens"


def write(path, t, x, f):
    rows = "".join(f"{a:.6f},{b:.6f},{c:.4f}\n" for a, b, c in zip(t, x, f))
    path.write_text("time_s,displacement_mm,force_N\n" + rows, encoding="utf-8")
    return path


@pytest.fixture
def mr(tmp_path):
    test = mr_damper.sine_test(frequency_hz=1.0, rate_hz=200.0, cycles=2, rng=4)
    return test


def test_an_mr_damper_test_is_ok_and_dissipates(tmp_path, mr, capsys):
    path = write(tmp_path / "mr.csv", mr.t, mr.x, mr.f)
    assert main(["data", "check", str(path)]) == 0
    out = capsys.readouterr()
    assert "ok:" in out.out and "401 samples at 200 Hz" in out.out and out.err == ""
    per_cycle, cycles = plausibility.loop_work(mr.x, mr.f)
    assert per_cycle > 0 and cycles == pytest.approx(2.0, rel=0.01)


def test_a_flipped_force_and_metres_are_warned_but_valid(tmp_path, mr, capsys):
    flipped = write(tmp_path / "flipped.csv", mr.t, mr.x, -mr.f)
    metres = write(tmp_path / "metres.csv", mr.t, mr.x / 1000.0 / 10, mr.f)
    assert main(["data", "check", str(flipped), str(metres)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2
    assert err[0].startswith(f"warning: {flipped}: the loop runs clockwise") and "probably flipped" in err[0]
    assert err[1].startswith(f"warning: {metres}: displacement amplitude 0.0025 mm is below 0.01 mm")


def test_the_synthetic_specimens_run_clockwise_as_the_papers_parameters_make_them(capsys):
    path = DATA / "pom-mt24u01_0.01MPa_r1.csv"
    assert main(["data", "check", str(path)]) == 0
    out = capsys.readouterr()
    assert "note: the loop runs clockwise" in out.out and out.err == ""
    spec = read_specimen(path)
    assert plausibility.loop_work(spec.x, spec.f)[0] < 0


def test_uneven_sampling_is_refused_with_the_line(tmp_path, capsys):
    t = np.arange(100) * 0.01
    t[60:] += 0.005  # a gap of half a step
    path = write(tmp_path / "gap.csv", t, np.sin(t * 6), np.cos(t * 6))
    assert main(["data", "check", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {path}:62: time step 0.015 s here, but the file is sampled every 0.01 s")
    # jitter of printed timestamps is accepted
    jitter = np.arange(100) * 0.01 + np.random.default_rng(0).uniform(-2e-5, 2e-5, 100)
    assert main(["data", "check", str(write(tmp_path / "jitter.csv", jitter, np.sin(jitter), jitter))]) == 0


def test_check_runs_from_any_folder_on_a_copy(tmp_path, monkeypatch, capsys):
    shutil.copy(DATA / "pom-mt24u01_0.05MPa_r1.csv", tmp_path / "mine.csv")
    monkeypatch.chdir(tmp_path)
    assert main(["data", "check", "mine.csv"]) == 0
    assert "warning: mine.csv: the loop runs clockwise" in capsys.readouterr().err  # no manifest: not known synthetic
