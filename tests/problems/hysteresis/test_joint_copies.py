"""A joint fit of two files with the same contents is the fit of one of them: the same loss at every
point (each file's MSE weighs the same), so the same search and the same optimum."""

import shutil
from pathlib import Path

import numpy as np
import pytest

import bwbench
from bwbench.data.specimen import read_specimen
from bwbench.problems.hysteresis.formulations import make_problem

SPECIMEN = Path(__file__).resolve().parents[3] / "data" / "mr_damper" / "mr_10mm_5Hz_0V.csv"


@pytest.fixture
def copies(tmp_path):
    first, second = tmp_path / "a.csv", tmp_path / "b.csv"
    shutil.copy(SPECIMEN, first)
    # the same values in other bytes (saved with CRLF line ends): a file listed twice, or a byte copy, is
    # refused in a joint fit (one test counted twice), but the same data are the same data
    second.write_bytes(SPECIMEN.read_bytes().replace(b"\n", b"\r\n"))
    return first, second


@pytest.mark.parametrize("formulation", ["identifiable", "direct"])
def test_two_copies_give_the_loss_and_residuals_of_one_file_at_every_point(copies, formulation):
    settings = {"model": "spencer", "formulation": formulation}
    single = make_problem(read_specimen(copies[0]), settings)
    joint = make_problem([read_specimen(p) for p in copies], settings)
    P = single.from_unit(np.random.default_rng(5).random((16, single.dim)))
    losses = single.loss_batch(P)
    assert np.isfinite(losses).sum() >= 8
    np.testing.assert_allclose(joint.loss_batch(P), losses, rtol=1e-10)
    R1, R2 = single.residual_batch(P), joint.residual_batch(P)
    ok = np.isfinite(losses)
    np.testing.assert_allclose(R2[ok], np.hstack([R1, R1])[ok], rtol=1e-8, atol=1e-8 * np.max(np.abs(R1[ok])))


def test_a_joint_fit_of_two_copies_of_a_file_equals_the_single_fit(copies):
    """Same loss everywhere (above, to rounding); the searches then differ only by the rounding of sums
    over twice the samples, which sends lsq-trf along slightly different paths in the flat valley of
    the optimum: both reach the force noise (6 N) with the same RMSE to 0.2 %."""
    single = bwbench.fit(copies[0], model="spencer", optimizer="lsq-trf", budget=1200, seed=1, stop="budget")
    joint = bwbench.fit(*copies, model="spencer", optimizer="lsq-trf", budget=1200, seed=1, stop="budget")
    assert single.nfev == joint.nfev == 1200
    assert single.rmse_N < 6.5  # at the generator's 6 N of force noise: the optimum, not a stop on the way
    assert joint.mse == pytest.approx(single.mse, rel=4e-3)
    for row in joint.files:
        assert row["rmse_N"] == pytest.approx(joint.rmse_N, rel=1e-12)  # the two files fit alike
        assert row["rmse_N"] == pytest.approx(single.rmse_N, rel=2e-3)
