"""``fit --workers N``: the independent parts of an evaluation on N threads (the files of a joint fit,
else the points of a batch), the same result as one worker, number for number."""

import json
import os
import shutil
from pathlib import Path

import numba
import pytest

from bwbench.cli import main

DATA = Path(__file__).resolve().parents[2] / "data" / "mr_damper"
pytestmark = pytest.mark.skipif(
    (os.cpu_count() or 1) < 2 or numba.config.NUMBA_NUM_THREADS < 2,  # type: ignore[attr-defined]
    reason="needs two cores",
)


@pytest.mark.parametrize(
    "files, jacobian",
    [(["mr_10mm_5Hz_0V.csv"], "differences"), (["mr_10mm_5Hz_0V.csv", "mr_5mm_5Hz_2.25V.csv"], "auto")],
    ids=["one file, batched differences", "joint, exact Jacobians"],
)
def test_two_workers_give_the_result_of_one(tmp_path, monkeypatch, files, jacobian):
    for name in files:
        shutil.copy(DATA / name, tmp_path / name)
    monkeypatch.chdir(tmp_path)
    results = []
    for workers in (1, 2):
        out = f"w{workers}.json"
        assert (
            main(
                [
                    "fit",
                    *files,
                    "--model",
                    "spencer",
                    "--optimizer",
                    "lsq-trf",
                    "--budget",
                    "60",
                    "--seed",
                    "2",
                    "--option",
                    f"jacobian={jacobian}",
                    "--stop",
                    "budget",
                    "--workers",
                    str(workers),
                    "--out",
                    out,
                ]
            )
            == 0
        )
        results.append(json.loads(Path(out).read_text()))
    one, two = results
    assert one["nfev"] == two["nfev"] == 60
    assert one["mse"] == two["mse"] and one["params"] == two["params"]
    assert one["trace"] == two["trace"]


def test_workers_beyond_the_cores_are_refused(tmp_path, monkeypatch, capsys):
    shutil.copy(DATA / "mr_10mm_5Hz_0V.csv", tmp_path / "a.csv")
    monkeypatch.chdir(tmp_path)
    assert (
        main(["fit", "a.csv", "--model", "spencer", "--optimizer", "lsq-trf", "--workers", "999", "--out", "r.json"])
        == 2
    )
    assert "--workers must be 1 to" in capsys.readouterr().err
    assert not Path("r.json").exists()
