"""Held-out checks of the velocity handling through bwbench's problem, on specimen files written from
an independent test machine (``exact_motions``: ramps with half-cosine reversals) and an independent
solver (``reference``: LSODA in time), read back as a user's files are. The full 15-set version is
``benchmarks/held_out_velocity.py``."""

import numpy as np
import pytest

import exact_motions as em
from bwbench.data.specimen import read_specimen
from bwbench.datasets.synthetic import read_paper_parameters
from paper_problems import IdentifiableProblem, SwitchedBoucWenProblem
from reference import reference_force_of_motion

# POM C9021 0.05 MPa: the largest viscous coefficient of Tables 6-8 (2·ξ₋·ωn₋ ≈ 18,000 N·s/mm), where
# a velocity error weighs most.
TRUTH = next(
    r["params"]
    for r in read_paper_parameters()
    if r["material"] == "POM C9021" and float(r["underpressure_MPa"]) == 0.05
)


@pytest.fixture(scope="module")
def machine():
    t = np.arange(0.0, em.ramp_duration() - 0.3, 0.5) + 0.0123  # 2 Hz, no sample on a reversal
    x, v, a = em.ramp(t)
    return t, x, v, a, reference_force_of_motion(TRUTH, t, em.ramp, em.ramp_reversals())


def _truth_mse(tmp_path, name, text, problem=SwitchedBoucWenProblem):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return float(problem(read_specimen(path)).loss_batch(TRUTH[None])[0])


def test_a_noise_free_ramp_test_without_velocity_is_reproduced_by_its_truth(machine, tmp_path):
    t, x, _, _, force = machine
    rms = np.sqrt(_truth_mse(tmp_path, "ramps.csv", em.render_csv(t, x, force)))
    assert rms <= 0.5  # N; 0.21 N here


def test_a_velocity_column_makes_the_truth_the_noise_floor(machine, tmp_path):
    t, x, v, _, force = machine
    rng = np.random.default_rng(11)
    f = force + rng.normal(0.0, 2.0, t.shape)  # 2 N load-cell noise: 4 N²
    x_rec = x + rng.normal(0.0, 1e-3, t.shape)  # 1 µm encoder noise
    realised = np.mean((np.round(f, 4) - force) ** 2)
    with_v = _truth_mse(tmp_path, "with.csv", em.render_csv(t, x_rec, f, v=v))
    assert with_v == pytest.approx(4.0, rel=0.10)
    assert with_v == pytest.approx(realised, rel=0.01)  # the velocity adds < 1 % to the noise
    # the same file without the column: the velocity estimated from the noisy displacement
    without_v = _truth_mse(tmp_path, "without.csv", em.render_csv(t, x_rec, f))
    assert without_v > 2.0 * with_v
    # semicolon / decimal-comma export with the columns in another order reads the same
    swapped = em.render_csv(t, x_rec, f, v=v, sep=";", decimal=",").splitlines()
    header = swapped[0].split(";")
    order = [header.index(c) for c in ("velocity_mm_s", "force_N", "time_s", "displacement_mm")]
    text = "\n".join(";".join(np.array(line.split(";"))[order]) for line in swapped) + "\n"
    assert _truth_mse(tmp_path, "export.csv", text) == pytest.approx(with_v, rel=1e-12)


def test_the_recorded_velocity_is_what_the_model_uses_and_it_changes_the_result(machine, tmp_path):
    t, x, v, _, force = machine
    exact = tmp_path / "exact.csv"
    exact.write_text(em.render_csv(t, x, force, v=v), encoding="utf-8")
    slow = tmp_path / "slow.csv"
    slow.write_text(em.render_csv(t, x, force, v=0.99 * v), encoding="utf-8")  # a 1 % low speed reading
    for problem_type in (SwitchedBoucWenProblem, IdentifiableProblem):
        problem = problem_type(read_specimen(slow))
        np.testing.assert_allclose(problem.signal.v, 0.99 * v, atol=1e-7)
        assert problem.signal.sources["velocity"] == "measured"
    mse_exact = float(SwitchedBoucWenProblem(read_specimen(exact)).loss_batch(TRUTH[None])[0])
    mse_slow = float(SwitchedBoucWenProblem(read_specimen(slow)).loss_batch(TRUTH[None])[0])
    assert mse_exact < 1e-4  # N²: the exact velocity, the independent solver's force
    # 1 % of 0.083 mm/s times ∂F/∂ẋ = 2ξωn on each branch: the force error the model must show
    c = np.where(v >= 0, 2 * TRUTH[5] * TRUTH[6], 2 * TRUTH[12] * TRUTH[13])
    assert mse_slow == pytest.approx(np.mean((c * 0.01 * v) ** 2), rel=0.02)


def test_the_branch_follows_the_recorded_velocity(machine, tmp_path):
    t, x, v, _, force = machine
    lagging = np.interp(t - 4.0, t, v)  # a velocity channel 4 s late: its sign changes 4 s after x turns
    path = tmp_path / "lagging.csv"
    path.write_text(em.render_csv(t, x, force, v=lagging), encoding="utf-8")
    problem = SwitchedBoucWenProblem(read_specimen(path))
    force_model = problem.simulate(TRUTH)
    wrong_branch = (lagging >= 0) != (v >= 0)
    assert wrong_branch.sum() >= 8 * 4 * 2 - 4  # ~8 samples around each of the 8 reversals
    # on those samples the '+'/'−' parameter set follows the recorded velocity: the force is the other
    # branch's, far from the truth; elsewhere the error is only the lag's c·Δv
    assert np.median(np.abs(force_model - force)[wrong_branch]) > 50.0
