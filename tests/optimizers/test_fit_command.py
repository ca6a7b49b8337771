"""``bwbench fit``, ``evaluate`` and ``simulate`` refuse outputs they cannot or must not write before
any work is done, and a fit that finds nothing finite exits non-zero with strict JSON."""

import json
import shutil
from pathlib import Path

import pytest

from bwbench.cli import main

SPECIMEN = Path(__file__).resolve().parents[2] / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"
# β + γ < 0 with n ≥ 4.5: |z| runs away on loading, in both branches, everywhere in this box
RUNAWAY = {
    "n+": [9.0, 10.75],
    "n-": [4.5, 5.0],
    "gamma+": [-7.5, -7.0],
    "beta+": [0.1, 0.2],
    "gamma-": [-5.0, -4.5],
    "beta-": [0.001, 0.002],
}


@pytest.fixture
def folder(tmp_path, monkeypatch):
    shutil.copy(SPECIMEN, tmp_path / "s.csv")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--out", "s.csv"], "--out s.csv is an input of this command"),
        (["--out", "r.json", "--plot", "./s.csv"], "--plot s.csv is an input of this command"),
        (["--out", "r.json", "--plot", "fit.txt"], "--plot fit.txt: the figure format comes from the extension"),
        (["--out", "fit.png", "--plot", "./fit.png"], "two outputs name the same file"),
        (["--out", "/proc/bwbench-test.json"], "cannot write /proc/bwbench-test.json"),
        (["--out", "no/such/folder/r.json"], "folder"),
        (["--out", "."], "it is a folder"),
    ],
)
def test_bad_outputs_are_refused_before_the_fit(folder, capsys, args, message):
    before = sorted(p.name for p in folder.iterdir())
    assert main(["fit", "s.csv", "--optimizer", "random", "--budget", "20", *args]) == 2
    assert message in one_error_line(capsys)
    assert sorted(p.name for p in folder.iterdir()) == before  # nothing written, the input untouched
    assert (folder / "s.csv").read_bytes() == SPECIMEN.read_bytes()


def test_a_box_that_blows_up_at_every_probed_corner_is_refused_before_the_fit(folder, capsys):
    (folder / "box.json").write_text(json.dumps(RUNAWAY))
    assert (
        main(
            [
                *("fit", "s.csv", "--formulation", "paper", "--optimizer", "random", "--budget", "30"),
                *("--bounds", "box.json", "--out", "r.json"),
            ]
        )
        == 2
    )
    assert "blows up (force not finite) at every one of 32 corners" in one_error_line(capsys)
    assert not (folder / "r.json").exists()


def test_a_fit_that_finds_nothing_finite_exits_1_with_strict_json(folder, capsys, monkeypatch):
    # The probe of the box's corners refuses RUNAWAY before the fit; without it, the fit itself says so.
    monkeypatch.setattr("bwbench.data.bounds.refuse_if_blows_up", lambda problem, where: None)
    (folder / "box.json").write_text(json.dumps(RUNAWAY))
    assert (
        main(
            [
                "fit",
                "s.csv",
                "--formulation",
                "paper",
                "--optimizer",
                "random",
                "--budget",
                "30",
                "--bounds",
                "box.json",
                "--out",
                "r.json",
                "--plot",
                "r.png",
            ]
        )
        == 1
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("error: s.csv: none of the 30 evaluations gave a finite force"), err
    result = json.loads((folder / "r.json").read_text(), parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    assert result["mse"] is None and result["rmse_N"] is None and result["params"]["A+"] is None
    assert result["nfev"] == 30 and not (folder / "r.png").exists()


def test_bounds_of_the_paper_formulation_on_other_data_say_which_formulation_to_ask_for(folder, capsys):
    # s.csv has no manifest beside it: not the paper's specimen, so the default is identifiable
    (folder / "box.json").write_text(json.dumps({"gamma+": [1.0, 2.0]}))
    assert main(["fit", "s.csv", "--bounds", "box.json", "--out", "r.json"]) == 2
    line = one_error_line(capsys)
    assert "unknown parameter 'gamma+'" in line and "add --formulation paper" in line


def test_evaluate_of_a_blowing_up_set_prints_null_and_exits_1(folder, capsys):
    truth = json.loads((SPECIMEN.parent / "manifest.json").read_text())["specimens"][0]["truth"]
    runaway = {"beta+": 0.1, "gamma+": -7.5, "n+": 10.0, "beta-": 0.001, "gamma-": -5.0, "n-": 5.0}
    (folder / "p.json").write_text(json.dumps({**truth, **runaway}))
    assert main(["evaluate", "--params", "p.json", "--specimen", "s.csv"]) == 1
    out = capsys.readouterr()
    assert json.loads(out.out)["mse"] is None and "the model blows up" in out.err


OTHER = SPECIMEN.with_name("pom-mt24u01_0.05MPa_r1.csv")
QUICK = ["--optimizer", "random", "--budget", "20", "--seed", "3"]


def test_each_fits_every_file_as_its_own_fit_would(folder, capsys):
    shutil.copy(OTHER, folder / "t.csv")
    assert main(["fit", "s.csv", "t.csv", "--each", *QUICK, "--out", "fits"]) == 0
    assert "2 fits in" in capsys.readouterr().out
    for name in ("s", "t"):
        assert main(["fit", f"{name}.csv", *QUICK, "--out", f"{name}-alone.json"]) == 0
        each = json.loads((folder / "fits" / f"{name}.json").read_text())
        alone = json.loads((folder / f"{name}-alone.json").read_text())
        assert each["params"] == alone["params"] and each["mse"] == alone["mse"] and each["nfev"] == 20
    assert json.loads((folder / "fits" / "s.json").read_text())["mse"] != each["mse"]  # two files, two fits


@pytest.mark.parametrize(
    "files, args, message",
    [
        (["s.csv", "bad.csv"], ["--out", "fits"], "bad.csv:3: not a number in column displacement_mm"),
        (["s.csv", "sub/s.csv"], ["--out", "fits"], "has the same name 's'"),
        (["s.csv"], ["--out", "fits.json"], "with --each, --out names a folder"),
        (["s.csv"], ["--out", "fits", "--plot", "fit.png"], "with --each, --plot names a folder"),
        (["s.csv"], ["--out", "s.csv"], "--out s.csv: is a file, not a folder"),
    ],
)
def test_each_refuses_a_bad_file_or_output_before_any_fit(folder, capsys, files, args, message):
    (folder / "bad.csv").write_text("time_s,displacement_mm,force_N\n0,0,1\n0.1,abc,2\n")
    (folder / "sub").mkdir()
    shutil.copy(SPECIMEN, folder / "sub" / "s.csv")
    before = sorted(p.name for p in folder.iterdir())
    assert main(["fit", *files, "--each", *QUICK, *args]) == 2
    assert message in one_error_line(capsys)
    assert sorted(p.name for p in folder.iterdir()) == before  # no folder made, nothing written
