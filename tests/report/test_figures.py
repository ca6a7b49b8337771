"""Every study figure is written with its CSV, and the CSV holds the right runs."""

import numpy as np
import pandas as pd
import pytest
from study_fixture import make_study_db

from bwbench.problems.switched_vpp import figures as switched_figures
from bwbench.report import figures
from bwbench.study import results as results_db
from bwbench.analysis import statistics
from bwbench.models.switched_bouc_wen import PARAM_NAMES

MISS = ("pom-mt24u01_0.01MPa_r1", "cmaes", 0)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    # One cmaes run misses every target, so no backend's ECDF may reach 1.
    return results_db.load_study(make_study_db(tmp_path_factory.mktemp("db") / "study.sqlite", miss=MISS))


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    return tmp_path_factory.mktemp("figures")


def _read(png):
    assert png.is_file() and png.stat().st_size > 10_000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return pd.read_csv(png.with_suffix(".csv"))


def test_waterfall_has_one_row_per_ranking_run(study, out):
    frame = _read(figures.waterfall(study, out))
    assert len(frame) == len(study.ranking) == 24
    keys = set(zip(frame["specimen"], frame["optimizer"], frame["replicate"]))
    assert keys == set(zip(study.ranking["specimen"], study.ranking["optimizer"], study.ranking["replicate"]))
    for _, g in frame.groupby("optimizer"):
        assert list(g["rank"]) == list(range(1, len(g) + 1))
        assert np.all(np.diff(g["ratio"]) >= 0)
    assert frame["ratio"].min() == pytest.approx(1.0)


def test_ecdf_stays_below_one_when_a_run_misses(study, out):
    frame = _read(figures.runtime_ecdf(study, out))
    assert len(frame) == 24 * len(figures.ECDF_TAUS)
    missed = frame[(frame["specimen"] == MISS[0]) & (frame["optimizer"] == MISS[1]) & (frame["replicate"] == MISS[2])]
    assert len(missed) == 3 and not missed["reached"].any()
    grid = np.geomspace(1, 1e6, 50)
    for _, g in frame.groupby("optimizer"):
        assert figures.ecdf(g["evals"].astype(float), grid).max() < 1.0


def test_ecdf_reaches_one_only_when_every_triple_is_reached():
    grid = np.array([1, 10, 100, 1000])
    assert figures.ecdf([5, 50, 500], grid).tolist() == [0, 1 / 3, 2 / 3, 1.0]
    assert figures.ecdf([5, 50, np.inf], grid).max() == pytest.approx(2 / 3)


def test_convergence_has_a_median_and_band_per_backend(study, out):
    frame = _read(figures.convergence(study, out))
    pooled = frame[frame["panel"] == "all specimens (pooled)"]
    assert set(pooled["optimizer"]) == {"cmaes", "de", "random"}
    assert (pooled["runs"] == 8).all()
    ok = pooled.dropna()
    assert np.all(ok["q25"] <= ok["median"] + 1e-12) and np.all(ok["median"] <= ok["q75"] + 1e-12)
    for _, g in ok.groupby("optimizer"):
        assert np.all(np.diff(g["median"]) <= 1e-9)  # best-so-far never gets worse


def test_best_so_far_is_the_last_improvement_at_or_before_n():
    values = figures.best_so_far([1, 10, 100], [9.0, 5.0, 1.0], [0, 1, 9, 10, 99, 1000])
    assert np.isposinf(values[0])  # nothing found yet
    assert values[1:].tolist() == [9.0, 9.0, 5.0, 5.0, 1.0]


def test_a_median_of_best_so_far_curves_never_rises():
    # Two runs find their first finite loss late and high: they must not pull the median up.
    early = [([1, 50], [4.0, 1.0])] * 3
    late = [([30], [100.0])] * 2
    grid = np.arange(1, 61)
    curves = np.array([figures.best_so_far(n, m, grid) for n, m in early + late])
    median = np.percentile(curves, 50, axis=0, method="inverted_cdf")
    assert np.all(np.diff(median) <= 0)
    assert median[0] == 4.0 and median[-1] == 1.0


def test_loops_show_the_best_run_of_each_backend(study, out):
    specimen = study.specimens[0]
    frame = _read(switched_figures.hysteresis_loops(study, out, specimen))
    runs = study.runs[study.runs["specimen"] == specimen]
    best = runs.loc[runs.groupby("optimizer")["mse"].idxmin()]
    shown = frame.drop_duplicates("optimizer").set_index("optimizer")["replicate"].to_dict()
    assert shown == dict(zip(best["optimizer"], best["replicate"]))
    for optimizer, g in frame.groupby("optimizer"):
        mse = np.mean((g["force_model_N"] - g["force_measured_N"]) ** 2)
        assert mse == pytest.approx(best.set_index("optimizer").loc[optimizer, "mse"], rel=1e-4)  # CSV: 6 digits


def test_spread_holds_only_runs_within_tolerance_and_the_truth(study, out):
    frame = _read(switched_figures.parameter_spread(study, out))
    best = statistics.best_known(study.runs)
    runs = frame[frame["optimizer"] != "truth"]
    assert np.all(runs["mse"] <= runs["specimen"].map(best) * (1 + switched_figures.SPREAD_TOLERANCE))
    ok = study.ranking[study.ranking["status"] == "ok"]
    expected = ok[ok["mse"] <= ok["specimen"].map(best) * (1 + switched_figures.SPREAD_TOLERANCE)]
    assert len(runs) == 14 * len(expected)
    truth = frame[frame["optimizer"] == "truth"]
    assert len(truth) == 14 * len(study.specimens)
    assert truth["unit_value"].between(0, 1).all()


def test_posterior_csv_has_samples_best_fits_and_truth(study, out):
    (chain,) = study.chains
    frame = _read(switched_figures.posterior(study, out, chain))
    assert list(frame.columns) == ["source", "optimizer", *PARAM_NAMES]
    assert set(frame["source"]) == {"posterior", "best fit", "truth"}
    assert (frame["source"] == "posterior").sum() <= 4000
    assert set(frame.loc[frame["source"] == "best fit", "optimizer"]) == {"cmaes", "de", "random"}


def test_parameters_against_underpressure(study, out):
    material = study.ranking["material"].iloc[0]
    frame = _read(switched_figures.parameters_vs_underpressure(study, out, "cmaes", material))
    runs = frame[frame["source"] == "cmaes"]
    assert len(runs) == 14 * 8  # 2 specimens × 4 seeds × 14 parameters
    assert sorted(frame["underpressure_MPa"].unique()) == [0.01, 0.09]
    assert (frame["source"] == "truth").sum() == 14 * 2


def test_profiles_figure(out):
    analysis = {"specimen": "toy", "mse": 1.0, "noise_rmse_N": 1.0, "n_data": 100, "params": {"wn-": 10.0},
                "profiles": {"wn-": [{"value": v, "unit": 0.0, "mse": 1.0 + (v - 10) ** 2, "evaluations": 5}
                                     for v in (2.0, 10.0, 20.0, 40.0)]}}
    frame = _read(switched_figures.profiles(analysis, out))
    assert len(frame) == 4 and frame["threshold_mse"].iloc[0] == pytest.approx(1.0 + 1.96**2 / 100, rel=1e-5)
