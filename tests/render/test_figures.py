"""Every study figure is written with its CSV, and the CSV holds the right runs."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from bwbench.analysis import statistics
from bwbench.database import reader as results_db
from bwbench.models.switched.kernel import PARAM_NAMES
from bwbench.problems.hysteresis.report import fit_figures, posterior_figures, profile_figures
from bwbench.problems.hysteresis.report import parameter_figures as switched_figures
from bwbench.render import ecdf_figures, waterfall
from bwbench.render import run_figures as figures
from study_fixture import make_study_db

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


def test_waterfall_has_one_row_per_ranking_run_sorted_per_specimen_and_backend(study, out):
    frame = _read(waterfall.waterfall(study, out))
    assert len(frame) == len(study.ranking) == 24
    keys = set(zip(frame["specimen"], frame["optimizer"], frame["replicate"]))
    assert keys == set(zip(study.ranking["specimen"], study.ranking["optimizer"], study.ranking["replicate"]))
    for _, g in frame.groupby(["specimen", "optimizer"]):  # one panel per specimen
        assert list(g["rank"]) == list(range(1, len(g) + 1))
        assert np.all(np.diff(g["ratio"]) >= 0)
    assert frame.groupby("specimen")["ratio"].min().to_numpy() == pytest.approx([1.0, 1.0])


def test_runtime_ecdf_stays_below_one_when_a_run_misses(study, out):
    frame = _read(ecdf_figures.runtime_distributions(study, out))
    target = frame[frame["view"] == "fixed target"]
    assert (target.groupby("label")["fraction"].max() < 1.0).all()  # the missed run misses every target
    best = statistics.best_known(study.runs)
    rt = statistics.runtimes(study.ranking, study.traces, ecdf_figures.ECDF_TAUS, best)
    missed = rt[(rt["specimen"] == MISS[0]) & (rt["optimizer"] == MISS[1]) & (rt["replicate"] == MISS[2])]
    assert len(missed) == 51 and not missed["reached"].any()


def test_runtime_ecdf_has_51_log_spaced_targets_from_a_thousandth_to_a_hundredfold():
    taus = np.array(ecdf_figures.ECDF_TAUS)
    assert len(taus) == 51 and taus[0] == pytest.approx(1e-3) and taus[-1] == pytest.approx(100.0)
    assert np.allclose(np.diff(np.log10(taus)), 0.1)  # ten per decade, as COCO's Δf targets are spaced


def test_the_fixed_budget_view_is_the_ecdf_of_final_losses(study, out):
    frame = _read(ecdf_figures.runtime_distributions(study, out))
    budget = frame[frame["view"] == "fixed budget"]
    best = statistics.best_known(study.runs)
    ranking = study.ranking
    for label, g in budget.groupby("label"):
        runs = ranking[ranking["optimizer"] == label]
        excess = np.sort(np.maximum(runs["mse"] / runs["specimen"].map(best) - 1, ecdf_figures.FLOOR))
        assert g["x"].to_numpy() == pytest.approx(excess, rel=1e-5)
        assert g["fraction"].to_numpy() == pytest.approx(np.arange(1, len(runs) + 1) / len(runs))


def test_ecdf_reaches_one_only_when_every_pair_is_reached():
    grid = np.array([1, 10, 100, 1000])
    assert ecdf_figures.ecdf([5, 50, 500], grid).tolist() == [0, 1 / 3, 2 / 3, 1.0]
    assert ecdf_figures.ecdf([5, 50, np.inf], grid).max() == pytest.approx(2 / 3)


def test_many_labels_are_drawn_as_small_multiples_with_the_best_highlighted():
    order = [f"b{k} [identifiable]" for k in range(11)] + ["random [identifiable]"]
    coloured, baselines, grey = ecdf_figures.highlighted(order)
    assert coloured == order[: ecdf_figures.HIGHLIGHT] and baselines == ["random [identifiable]"]
    assert grey == order[ecdf_figures.HIGHLIGHT : 11]
    few = ["a", "b", "random"]
    assert ecdf_figures.highlighted(few) == (["a", "b"], ["random"], [])
    groups = ecdf_figures.by_variant(["a [paper]", "a [identifiable]", "b [paper]"])
    assert groups == {"paper": ["a [paper]", "b [paper]"], "identifiable": ["a [identifiable]"]}


def test_convergence_has_a_median_and_quartiles_per_backend_and_panel(study, out):
    frame = _read(figures.convergence(study, out))
    pooled = frame[frame["panel"] == "all specimens (pooled)"]
    assert set(pooled["optimizer"]) == {"cmaes", "de", "random"}
    assert (pooled["runs"] == 8).all()
    ok = pooled.replace([np.inf, -np.inf], np.nan).dropna()
    assert np.all(ok["q25"] <= ok["median"] + 1e-12) and np.all(ok["median"] <= ok["q75"] + 1e-12)
    for _, g in frame.replace([np.inf, -np.inf], np.nan).dropna().groupby(["panel", "optimizer"]):
        assert np.all(np.diff(g["median"]) <= 1e-9)  # best-so-far never gets worse, in any panel


def test_convergence_panels_in_underpressure_order_and_relative_to_the_noise_floor(study, out):
    low, high = "pom-mt24u01_0.01MPa_r1", "pom-mt24u01_0.09MPa_r1"
    floors = {high: (10.0, "noise floor"), low: (5.0, "noise floor")}
    frame = _read(figures.convergence(study, out, [high, low], floors=floors))
    assert list(dict.fromkeys(frame["panel"])) == ["all specimens (pooled)", "0.01 MPa, repeat 1", "0.09 MPa, repeat 1"]
    assert set(frame["y"]) == {"mse_over_floor"}
    last = frame[(frame["panel"] == "0.09 MPa, repeat 1") & (frame["nfev"] == frame["nfev"].max())]
    runs = study.ranking[study.ranking["specimen"] == high]
    for optimizer, g in last.groupby("optimizer"):  # the last median is the median final MSE / floor
        finals = np.sort(runs.loc[runs["optimizer"] == optimizer, "mse"].to_numpy())
        assert g["median"].iloc[0] * 10.0 == pytest.approx(finals[(len(finals) - 1) // 2], rel=1e-5)


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


def test_convergence_pools_relative_to_the_floor_only_when_every_specimen_has_one(study, out):
    high = "pom-mt24u01_0.09MPa_r1"
    frame = _read(figures.convergence(study, out, floors={high: (10.0, "noise floor")}))
    kinds = frame.drop_duplicates("panel").set_index("panel")["y"].to_dict()
    assert kinds == {
        "all specimens (pooled)": "mse_over_best_known",
        "0.01 MPa, repeat 1": "mse_over_best_known",
        "0.09 MPa, repeat 1": "mse_over_floor",
    }
    pooled = frame[frame["panel"] == "all specimens (pooled)"]
    assert pooled.groupby("optimizer")["median"].min().min() >= 1.0 - 1e-9  # nothing below the best known


BAND = "posterior predictive 95 %"


def test_loops_show_the_best_ranking_run_of_the_best_backends_and_random(study, out):
    specimen = study.specimens[0]
    frame = _read(fit_figures.hysteresis_loops(study, out, specimen, order=["de", "cmaes", "random"], backends=1))
    band = frame[frame["optimizer"] == BAND]
    frame = frame[frame["optimizer"] != BAND]
    runs = study.ranking[study.ranking["specimen"] == specimen]
    best = runs.loc[runs.groupby("optimizer")["mse"].idxmin()].set_index("optimizer")
    # de is first in the order; cmaes has the best run (its fit is the loop), random is the baseline
    assert list(dict.fromkeys(frame["optimizer"])) == ["de", "cmaes", "random"]
    for optimizer, g in frame.groupby("optimizer"):
        assert g["replicate"].iloc[0] == best.loc[optimizer, "replicate"]
        assert np.allclose(g["residual_N"], g["force_model_N"] - g["force_measured_N"], atol=1e-3)
        mse = np.mean(g["residual_N"] ** 2)
        assert mse == pytest.approx(best.loc[optimizer, "mse"], rel=1e-4)  # CSV: 6 digits
    # the specimen has a posterior (the fixture's chain sits on the truth): its 95 % predictive band, which
    # holds the measured force (truth + noise) at close to 95 % of the samples
    assert len(band) == len(frame[frame["optimizer"] == "de"]) and (band["band_lower_N"] < band["band_upper_N"]).all()
    inside = (band["force_measured_N"] >= band["band_lower_N"]) & (band["force_measured_N"] <= band["band_upper_N"])
    assert 0.85 < inside.mean() <= 1.0


def test_loops_never_show_a_posterior_run_even_when_it_fits_best(study, out):
    specimen = study.chains[0].specimen
    runs = study.runs.copy()
    posterior = (runs["kind"] == "posterior") & (runs["specimen"] == specimen)
    assert posterior.sum() == 1
    runs.loc[posterior, "mse"] = 1e-6  # the posterior's 200,000-evaluation run "wins"
    rigged = dataclasses.replace(study, runs=runs)
    frame = _read(fit_figures.hysteresis_loops(rigged, out, specimen))
    frame = frame[frame["optimizer"] != BAND]
    assert set(frame["kind"]) == {"ranking"}
    assert "emcee" not in set(frame["optimizer"])
    assert set(frame["optimizer"]) == {"cmaes", "de", "random"}


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


def test_posterior_csv_has_samples_the_best_fit_truth_and_diagnostics(study, out):
    (chain,) = study.chains
    frame = _read(posterior_figures.posterior(study, out, chain))
    assert list(frame.columns) == ["source", "optimizer", *PARAM_NAMES]
    assert set(frame["source"]) == {"posterior", "best fit", "truth", "r_hat", "ess_bulk"}
    assert (frame["source"] == "posterior").sum() <= 4000
    runs = study.runs[study.runs["specimen"] == chain.specimen]
    fits = frame[frame["source"] == "best fit"]  # only the overall best fit, not one per backend
    assert len(fits) == 1 and fits["optimizer"].iloc[0] == runs.loc[runs["mse"].idxmin(), "optimizer"]


def test_parameters_against_underpressure(study, out):
    material = study.ranking["material"].iloc[0]
    frame = _read(switched_figures.parameters_vs_underpressure(study, out, "cmaes", material))
    runs = frame[frame["source"] == "cmaes"]
    assert len(runs) == 14 * 8  # 2 specimens × 4 seeds × 14 parameters
    assert sorted(frame["underpressure_MPa"].unique()) == [0.01, 0.09]
    assert (frame["source"] == "truth").sum() == 14 * 2
    # y is the position in the whole Table 5 range: every panel the same scale
    assert frame["unit_value"].between(0, 1).all() and not frame["drawn_at_edge"].any()


def test_underpressure_values_beyond_table_5_are_drawn_at_the_edge_not_dropped(study, out):
    import dataclasses

    material = study.ranking["material"].iloc[0]
    runs = study.runs.copy()
    first = runs.index[(runs["optimizer"] == "cmaes") & (runs["kind"] == "ranking")][0]
    runs.loc[first, "A+"] = 10.0  # Table 5: 0.001 … 0.025
    frame = _read(
        switched_figures.parameters_vs_underpressure(dataclasses.replace(study, runs=runs), out, "cmaes", material)
    )
    edge = frame[frame["drawn_at_edge"]]
    assert len(edge) == 1 and edge["parameter"].iloc[0] == "A+" and edge["value"].iloc[0] == 10.0
    assert len(frame[frame["source"] == "cmaes"]) == 14 * 8  # still every value


def test_profiles_figure(out):
    analysis = {
        "specimen": "toy",
        "mse": 1.0,
        "noise_rmse_N": 1.0,
        "n_data": 100,
        "params": {"wn-": 10.0},
        "profiles": {
            "wn-": [
                {"value": v, "unit": 0.0, "mse": 1.0 + (v - 10) ** 2, "evaluations": 5} for v in (2.0, 10.0, 20.0, 40.0)
            ]
        },
    }
    frame = _read(profile_figures.profiles(analysis, out))
    assert len(frame) == 4 and frame["threshold_mse"].iloc[0] == pytest.approx(1.0 + 1.96**2 / 100, rel=1e-5)
    assert set(frame["bounded"]) == {"both sides"}


def test_profiles_classify_the_95_percent_region():
    from bwbench.problems.hysteresis.report.profile_figures import bounded

    values = [0.0, 1.0, 2.0, 3.0]
    assert bounded(values, [5.0, 1.0, 1.0, 5.0], 2.0) == "both sides"
    assert bounded(values, [5.0, 1.0, 1.0, 1.5], 2.0) == "below only"
    assert bounded(values, [1.5, 1.0, 1.0, 5.0], 2.0) == "above only"
    assert bounded(values, [1.5, 1.0, 1.2, 1.9], 2.0) == "neither"
    assert bounded(values, [np.nan, 1.0, np.nan, 5.0], 2.0) == "above only"  # failed points do not count


def test_reversals_are_the_turning_points_not_the_noise():
    from bwbench.problems.hysteresis.report.figure_common import reversals

    t = np.linspace(0, 4, 401)
    x = 10 * (2 * np.abs(t - np.floor(t + 0.5)) * 2 - 1)  # triangle wave: turns at t = 0.5, 1, 1.5, ...
    x = x + np.random.default_rng(0).normal(0, 0.05, t.size)
    turns = t[reversals(x)]
    assert np.allclose(turns, np.arange(0.5, 4.0, 0.5), atol=0.02)


def test_panel_titles_name_the_material_when_a_study_has_several(study):
    import dataclasses

    from bwbench.render.run_figures import specimen_title

    specimen = study.runs["specimen"].iloc[0]
    one = specimen_title(study, specimen)
    assert "MPa" in one and study.runs["material"].iloc[0] not in one
    runs = study.runs.copy()
    runs.loc[runs["specimen"] != specimen, "material"] = "PC/ABS C12HF"
    two = specimen_title(dataclasses.replace(study, runs=runs), specimen)
    assert two == f"{study.runs['material'].iloc[0]}, {one}"


def test_twenty_labels_in_two_formulations_are_two_columns_with_the_best_four_in_colour(tmp_path):
    spreads = {f"b{k}": 0.002 * (k + 1) for k in range(9)}
    labels = {f"{b} [{v}]": s for b, s in spreads.items() for v in ("identifiable", "paper")}
    labels.update({"random [identifiable]": 0.15, "random [paper]": 0.2})
    many = results_db.load_study(
        make_study_db(tmp_path / "many.sqlite", optimizers=labels, replicates=2, posterior=False)
    )
    order = sorted(labels, key=lambda n: (n.startswith("random"), labels[n], n))
    frame = _read(figures.convergence(many, tmp_path, order=order))
    assert set(frame["variant"]) == {"identifiable", "paper"}
    for variant, g in frame.groupby("variant"):
        coloured = list(dict.fromkeys(g.loc[g["highlighted"], "optimizer"]))
        mine = [n for n in order if n.endswith(f"[{variant}]")]
        assert coloured == mine[:4] + [f"random [{variant}]"]  # the best four and the baseline
        assert set(g.loc[~g["highlighted"], "optimizer"]) == set(mine[4:-1])  # the rest in grey
        assert list(dict.fromkeys(g.loc[g["band"], "optimizer"])) == mine[: figures.BANDS]
    target = pd.read_csv(ecdf_figures.runtime_distributions(many, tmp_path, order=order).with_suffix(".csv"))
    assert set(target["variant"]) == {"identifiable", "paper"} and target["highlighted"].sum() < len(target)
