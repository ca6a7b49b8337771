"""One list of findings per fit, read the same by the command line and the API; a fit worse than a
constant force is a failed fit everywhere; the switched model's formulation follows the data."""

import json
import warnings

import numpy as np
import pandas as pd
import pytest

import bwbench
from bwbench.cli import main
from bwbench.datasets import synthetic

PAPER_SPECIMEN = synthetic.SPECIMEN_DIR / "pom-mt24u01_0.05MPa_r1.csv"


def friction_damper(seed: int = 0, rate_hz: float = 250.0, noise_N: float = 8.0) -> pd.DataFrame:
    """A user's damper not made by bwbench's generators: Dahl friction (300 N) + spring + dashpot under a
    1.2 Hz sine of 12 mm, explicit Euler on a 20× finer grid, 8 N noise; recorded from a running test
    (one cycle of motion before the record, so it starts in motion with the friction already loaded)."""
    fine = 20
    dt = 1.0 / (rate_hz * fine)
    t = np.arange(-1.0 / 1.2, 2.5 / 1.2, dt)
    x = 12.0 * np.sin(2 * np.pi * 1.2 * t)
    v = np.gradient(x, dt)
    z, zs = 0.0, np.empty_like(t)
    for k in range(len(t)):
        zs[k] = z
        z += dt * 400.0 * v[k] * (1 - np.sign(v[k]) * z / 300.0)
    f = zs + 15.0 * x + 1.5 * v
    keep = slice(int(np.searchsorted(t, -dt / 2)), None, fine)  # the record begins at t = 0
    rng = np.random.default_rng(seed)
    n = len(t[keep])
    return pd.DataFrame(
        {"time_s": np.arange(n) / rate_hz, "displacement_mm": x[keep], "force_N": f[keep] + rng.normal(0, noise_N, n)}
    )


def test_defaults_on_a_users_file_choose_the_identifiable_formulation_and_reach_the_noise():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", bwbench.FitWarning)
        fit = bwbench.fit(friction_damper(), name="dahl", budget=600)
    assert fit.problem.formulation == "identifiable" and fit.ok
    assert fit.findings[0].severity == "info" and "not the paper's synthetic specimens" in fit.findings[0].text
    assert fit.rmse_N < 1.3 * 8.0  # at the noise (8 N), not NRMSE 4 of the paper's box


def test_the_paper_specimens_keep_the_paper_formulation_by_default(tmp_path, capsys):
    assert main(
        ["fit", str(PAPER_SPECIMEN), "--budget", "40", "--optimizer", "random", "--out", str(tmp_path / "r.json")]
    ) in (0, 1)
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith(
        f"fitting {PAPER_SPECIMEN}: switched-bouc-wen in the paper formulation: the default for the paper's"
    )
    assert json.loads((tmp_path / "r.json").read_text())["formulation"] == "paper"


def test_a_fit_worse_than_a_constant_force_failed_in_the_api_and_the_cli(tmp_path, capsys):
    data = friction_damper(1)
    data.to_csv(tmp_path / "d.csv", index=False)
    # the paper's box on a damper it was not made for, a few random points: worse than the mean force
    with pytest.warns(bwbench.FitFailure) as caught:
        fit = bwbench.fit(tmp_path / "d.csv", formulation="paper", optimizer="random", budget=5)
    assert not fit.ok and "worse than a constant force" in fit.failure
    assert fit.rmse_N > float(np.std(data["force_N"]))
    texts = [str(w.message) for w in caught]
    assert not any("flipped" in t for t in texts)  # a failed fit's loop says nothing of the data's sign
    assert "status             = FAILED: " in fit.report()
    code = main(
        [
            "fit",
            str(tmp_path / "d.csv"),
            "--formulation",
            "paper",
            "--optimizer",
            "random",
            "--budget",
            "5",
            "--out",
            str(tmp_path / "r.json"),
        ]
    )
    captured = capsys.readouterr()
    assert code == 1
    errors = [line for line in captured.err.splitlines() if line.startswith("error: ")]
    assert errors == [f"error: {f.text}" for f in fit.findings if f.severity == "failure"]


def test_the_cli_prints_every_finding_the_api_keeps(tmp_path, capsys):
    data = friction_damper(2)
    data.to_csv(tmp_path / "d.csv", index=False)
    args = dict(model="bouc-wen", optimizer="lsq-trf", budget=150, seed=3)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit = bwbench.fit(tmp_path / "d.csv", **args)
    assert (
        main(
            [
                "fit",
                str(tmp_path / "d.csv"),
                "--model",
                "bouc-wen",
                "--budget",
                "150",
                "--seed",
                "3",
                "--out",
                str(tmp_path / "r.json"),
            ]
        )
        == 0
    )
    printed = capsys.readouterr()
    text = printed.out + printed.err
    for finding in fit.findings:
        assert finding.text in text, finding
    issued = {str(w.message) for w in caught if issubclass(w.category, bwbench.FitWarning)}
    assert issued == {f.text for f in fit.findings if f.severity != "info"}


def test_a_study_of_a_users_files_runs_the_identifiable_formulation_by_default(tmp_path):
    friction_damper(3).to_csv(tmp_path / "d.csv", index=False)
    study = bwbench.compare(
        specimens=[tmp_path / "d.csv"], optimizers=["random"], seeds=1, budget=10, db=tmp_path / "s.sqlite"
    )
    assert set(study.runs["formulation"]) == {"identifiable"}
