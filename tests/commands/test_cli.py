"""`bwbench simulate` and `bwbench evaluate` as a user runs them."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from bwbench.cli import main
from bwbench.data import manifest

DATA = Path(__file__).resolve().parents[2] / "data" / "specimens"
SPECIMEN = DATA / "pom-mt24u01_0.01MPa_r1.csv"


@pytest.fixture
def truth_json(tmp_path):
    path = tmp_path / "truth.json"
    truth = manifest.manifest_entry(SPECIMEN)["truth"]
    path.write_text(json.dumps(truth))
    return path


def test_evaluate_prints_mse_f_err_rmse(truth_json, capsys):
    assert main(["evaluate", "--params", str(truth_json), "--specimen", str(SPECIMEN)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["f_err"] == -out["mse"]
    assert out["rmse_N"] == pytest.approx(np.sqrt(out["mse"]))
    assert 1.0 < out["mse"] < 20.0
    assert out["n"] == 1921 and out["state"] == "shared" and out["excitation"] == "measured"


def test_simulate_writes_the_model_force(truth_json, tmp_path, capsys):
    out_csv = tmp_path / "sim.csv"
    assert (
        main(
            [
                "simulate",
                "--params",
                str(truth_json),
                "--specimen",
                str(SPECIMEN),
                "--state",
                "split",
                "--out",
                str(out_csv),
            ]
        )
        == 0
    )
    frame = pd.read_csv(out_csv)
    assert list(frame.columns)[:2] == ["time_s", "displacement_mm"]
    assert len(frame) == 1921
    rms = np.sqrt(np.mean((frame.force_model_N - frame.force_measured_N) ** 2))
    assert 1.0 < rms < 100.0  # split differs from the shared truth, but not wildly


@pytest.mark.parametrize(
    "content, problem",
    [
        ("{", "not valid JSON"),
        ("[1, 2]", "JSON object"),
        ('{"A+": 1}', "missing parameter"),
    ],
)
def test_bad_parameter_file_is_one_line_and_exit_2(tmp_path, capsys, content, problem):
    bad = tmp_path / "p.json"
    bad.write_text(content)
    assert main(["evaluate", "--params", str(bad), "--specimen", str(SPECIMEN)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {bad}") and problem in err


def test_non_numeric_parameter_is_refused(tmp_path, capsys, truth_json):
    values = json.loads(truth_json.read_text())
    values["n+"] = "five"
    bad = tmp_path / "p.json"
    bad.write_text(json.dumps(values))
    assert main(["evaluate", "--params", str(bad), "--specimen", str(SPECIMEN)]) == 2
    assert "'n+' must be a finite number" in capsys.readouterr().err


@pytest.mark.parametrize("flag", ["--out", "--plot"])
def test_fit_refuses_an_output_folder_that_does_not_exist_before_fitting(tmp_path, capsys, flag):
    paths = {"--out": str(tmp_path / "r.json"), "--plot": str(tmp_path / "r.png")}
    paths[flag] = str(tmp_path / "missing" / "x.png")
    argv = [
        "fit",
        str(SPECIMEN),
        "--optimizer",
        "random",
        "--budget",
        "10",
        "--out",
        paths["--out"],
        "--plot",
        paths["--plot"],
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not exist" in err
    assert not (tmp_path / "r.json").exists()
