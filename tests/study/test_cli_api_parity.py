"""The same study run through the command line and through the Python API gives the same rankings,
recommendation and findings (the seeds set every number the rule reads; only measured times differ,
and they decide nothing within their noise)."""

import os
import subprocess
import sys

import numpy as np
import pandas as pd

import bwbench

SEED_COLUMNS = ["optimizer", "backend", "variant", "verdict", "success_1%", "ert_1%", "median_rmse"]


def _damper(path, amplitude, frequency, seed):
    """An asymmetric Bouc-Wen-like damper written here (not by bwbench's generators)."""
    t = np.arange(0.0, 2.0 / frequency, 1.0 / 200.0)
    x = amplitude * np.sin(2 * np.pi * frequency * t)
    z = np.tanh(np.gradient(x, t) / 5.0) * 200.0
    f = z + 10.0 * x + np.where(np.gradient(x, t) > 0, 30.0, -10.0)
    rng = np.random.default_rng(seed)
    pd.DataFrame({"time_s": t, "displacement_mm": x, "force_N": f + rng.normal(0, 3.0, len(t))}).to_csv(
        path, index=False
    )


def test_cli_and_api_studies_give_identical_rankings_recommendation_and_findings(tmp_path):
    _damper(tmp_path / "a.csv", 8.0, 1.0, 1)
    _damper(tmp_path / "b.csv", 5.0, 2.0, 2)
    common = dict(optimizers=["lsq-trf", "random"], seeds=2, budget=60)
    cli = subprocess.run(
        [
            sys.executable,
            "-m",
            "bwbench.cli",
            "compare",
            "--specimens",
            "a.csv",
            "b.csv",
            "--optimizers",
            "lsq-trf,random",
            "--seeds",
            "2",
            "--budget",
            "60",
            "--db",
            "cli.sqlite",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={**os.environ, "BWBENCH_PROGRESS": "0"},
    )
    assert cli.returncode == 0, cli.stderr
    api = bwbench.compare(specimens=[tmp_path / "a.csv", tmp_path / "b.csv"], db=tmp_path / "api.sqlite", **common)
    via_cli = bwbench.load_study(tmp_path / "cli.sqlite")
    a, c = api.ranking(), via_cli.ranking()
    columns = [k for k in SEED_COLUMNS if k in a.columns]
    pd.testing.assert_frame_equal(a[columns].reset_index(drop=True), c[columns].reset_index(drop=True))
    assert api.recommendation.label == via_cli.recommendation.label
    assert api.recommendation.line.split(" (")[0] == via_cli.recommendation.line.split(" (")[0]
    assert api.recommendation.line.split("(")[0] in cli.stdout + cli.stderr
    runs = ["optimizer", "specimen", "replicate", "mse", "nfev", "formulation"]
    key = ["optimizer", "specimen", "replicate"]
    pd.testing.assert_frame_equal(
        api.runs[runs].sort_values(key).reset_index(drop=True),
        via_cli.runs[runs].sort_values(key).reset_index(drop=True),
    )
