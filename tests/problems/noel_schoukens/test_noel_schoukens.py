"""The Noël–Schoukens Bouc-Wen benchmark problem: its known answer, invariance and failure modes."""

from pathlib import Path

import numpy as np
import pytest

from bwbench.engine import fitting
from bwbench.engine.objective import Objective
from bwbench.errors import InputFileError
from bwbench.problems.noel_schoukens.force_driven_bouc_wen import identifiable_combinations
from bwbench.problems.noel_schoukens.problem import (
    LOWER,
    NOISE_RMS_M,
    PARAM_NAMES,
    TRUE_PARAMS,
    UPPER,
    BoucWenBenchmarkProblem,
    default_data_dir,
    from_unit,
    read_benchmark_csv,
    to_unit,
)

DATA_DIR = Path(__file__).resolve().parents[3].parent / "shared" / "benchmarks" / "bouc-wen"
needs_data = pytest.mark.skipif(
    not (DATA_DIR / "train_multisine.csv").is_file(), reason=f"benchmark data not found at {DATA_DIR}"
)


@pytest.fixture(scope="module")
def problem():
    return BoucWenBenchmarkProblem(DATA_DIR)


def test_default_data_dir_is_beside_the_repository():
    assert default_data_dir() == DATA_DIR


@needs_data
def test_true_parameters_reproduce_test_multisine_below_a_micrometre(problem):
    # The README's figure for RK4 at 15 kHz is 2e-7 m; our 2.25 kHz gives 5.2e-7 m.
    assert problem.test_error(TRUE_PARAMS, "test_multisine") <= 1e-6


@needs_data
def test_true_parameters_leave_the_stated_noise_on_the_training_period(problem):
    rms = np.sqrt(problem.loss_batch(TRUE_PARAMS[None, :])[0])
    assert abs(rms - NOISE_RMS_M) <= 0.1 * NOISE_RMS_M, f"RMS residual {rms:.3g} m"
    assert problem.n_data == 8192
    assert problem.info["problem"] == "bouc-wen-benchmark"
    assert problem.info["specimen"] == "train_multisine"


@needs_data
def test_beta_scaling_is_an_exact_invariance(problem):
    rng = np.random.default_rng(3)
    base = TRUE_PARAMS * np.exp(0.1 * rng.standard_normal(8))
    base[6] = -1.0
    scaled = []
    for s in (0.3, 3.7):
        p = base.copy()
        p[4] *= s  # β·s, γ/s, δ/s: βγ and βδ unchanged
        p[5] /= s
        p[6] /= s
        scaled.append(p)
    losses = problem.loss_batch(np.array([base, *scaled]))
    assert np.all(np.isfinite(losses))
    np.testing.assert_allclose(losses[1:], losses[0], rtol=1e-12, atol=0)
    combos = [identifiable_combinations(p) for p in (base, *scaled)]
    for c in combos[1:]:
        assert c["beta_gamma"] == pytest.approx(combos[0]["beta_gamma"], rel=1e-14)
        assert c["beta_delta"] == pytest.approx(combos[0]["beta_delta"], rel=1e-14)


@needs_data
def test_absurd_parameters_give_inf_never_nan(problem):
    absurd = np.array(
        [
            [1e-9, 0.0, 1e12, 1e12, 1e9, 1e3, -1e3, 50.0],  # stiff beyond any step, runaway
            [2.0, 10.0, 5e4, 5e4, 1e4, 0.08, -3.0, 3.0],  # box corner: β(γ+δ) < 0 with ν = 3 runs away
            [0.0, 10.0, 5e4, 5e4, 1e3, 0.8, -1.1, 1.0],  # zero mass
            [np.nan, 10.0, 5e4, 5e4, 1e3, 0.8, -1.1, 1.0],
        ]
    )
    losses = problem.loss_batch(absurd)
    assert not np.any(np.isnan(losses))
    assert np.all(losses == np.inf)
    assert np.all(np.isinf(problem.simulate(absurd[0])))
    # A random population of the box: every loss is finite and positive or +inf.
    losses = problem.loss_batch(problem.from_unit(np.random.default_rng(0).random((40, 8))))
    assert not np.any(np.isnan(losses)) and np.all(losses > 0)


def test_unit_mapping_is_log_for_positive_parameters_and_round_trips():
    np.testing.assert_allclose(from_unit(np.zeros(8)), LOWER)
    np.testing.assert_allclose(from_unit(np.ones(8)), UPPER)
    # Log-scaled: the centre of a decade-each-side range is the truth itself.
    np.testing.assert_allclose(from_unit(np.full(8, 0.5))[:6], TRUE_PARAMS[:6])
    np.testing.assert_allclose(from_unit(np.full(8, 0.5))[6:], (LOWER[6:] + UPPER[6:]) / 2)
    u = np.random.default_rng(1).random((5, 8))
    np.testing.assert_allclose(to_unit(from_unit(u)), u, atol=1e-12)
    truth_u = to_unit(TRUE_PARAMS)
    assert np.all((truth_u > 0) & (truth_u < 1))
    assert np.all(LOWER[:6] * 10 <= TRUE_PARAMS[:6] + 1e-12)
    assert np.all(UPPER[:6] / 10 >= TRUE_PARAMS[:6] - 1e-12)
    assert LOWER[6] <= -1.1 <= UPPER[6] and LOWER[7] <= 1.0 <= UPPER[7]


@needs_data
def test_random_search_runs_end_to_end(problem):
    result = fitting.run(problem, "random", 50, seed=1)
    assert result.nfev == 50
    assert set(result.params) == set(PARAM_NAMES)
    assert np.isfinite(result.mse) and result.mse > 0
    assert result.problem["problem"] == "bouc-wen-benchmark"
    x = np.array([result.params[n] for n in PARAM_NAMES])
    assert np.all((x >= LOWER * (1 - 1e-12)) & (x <= UPPER * (1 + 1e-12)))
    # One point by one and in a batch give the same losses.
    objective = Objective(problem, 4)
    u = np.random.default_rng(2).random((2, 8))
    batch = objective.batch(u)
    np.testing.assert_array_equal(batch, [objective(u[0]), objective(u[1])])


def test_bad_files_name_the_path_and_line(tmp_path):
    missing = tmp_path / "nope.csv"
    with pytest.raises(InputFileError) as err:
        read_benchmark_csv(missing)
    assert err.value.path == str(missing) and err.value.line is None

    bad_header = tmp_path / "header.csv"
    bad_header.write_text("time_s,displacement_mm,force_N\n0,1,2\n")
    with pytest.raises(InputFileError) as err:
        read_benchmark_csv(bad_header)
    assert err.value.line == 1

    rows = "time_s,force_N,displacement_m\n0.0,1.0,0.0\n0.00133333,2.0,1e-6\n0.00266667,x,1e-6\n"
    bad_cell = tmp_path / "cell.csv"
    bad_cell.write_text(rows)
    with pytest.raises(InputFileError, match="cell.csv:4:") as err:
        read_benchmark_csv(bad_cell)

    bad_rate = tmp_path / "rate.csv"
    bad_rate.write_text("time_s,force_N,displacement_m\n0.0,1.0,0.0\n0.001,2.0,1e-6\n")
    with pytest.raises(InputFileError, match="rate.csv:3:.*750 Hz"):
        read_benchmark_csv(bad_rate)

    not_finite = tmp_path / "nan.csv"
    not_finite.write_text("time_s,force_N,displacement_m\n0.0,1.0,0.0\n0.00133333,nan,1e-6\n")
    with pytest.raises(InputFileError, match="nan.csv:3:"):
        read_benchmark_csv(not_finite)

    short = tmp_path / "train_multisine.csv"
    short.write_text(rows[: rows.index("0.00266667")])
    with pytest.raises(InputFileError, match="expected 5 period"):
        BoucWenBenchmarkProblem(tmp_path)


def test_record_reads_columns_in_si_units(tmp_path):
    path = tmp_path / "ok.csv"
    path.write_text("time_s,force_N,displacement_m\n0.00000000,-10.5,1.5e-4\n0.00133333,26.25,5.7e-4\n\n")
    record = read_benchmark_csv(path)
    assert record.n_samples == 2 and record.name == "ok"
    np.testing.assert_array_equal(record.u, [-10.5, 26.25])
    np.testing.assert_array_equal(record.y, [1.5e-4, 5.7e-4])
