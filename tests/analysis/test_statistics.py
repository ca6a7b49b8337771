"""Success rates, ERT, Friedman, Wilcoxon-Holm and MCMC diagnostics on hand-made and fixture data."""

import sqlite3

import numpy as np
import pandas as pd
import pytest
import scipy.stats

from bwbench.analysis import comparisons, mcmc, statistics
from bwbench.database import reader as results_db
from bwbench.errors import UserError
from study_fixture import make_study_db


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    return results_db.load_study(make_study_db(tmp_path_factory.mktemp("db") / "study.sqlite"))


def test_holm_on_a_known_example():
    assert comparisons.holm([0.01, 0.04, 0.03]) == pytest.approx([0.03, 0.06, 0.06])


def test_holm_is_monotone_capped_and_keeps_nan():
    # sorted 0.001, 0.4, 0.5 times 3, 2, 1 = 0.003, 0.8, 0.5; running maximum -> 0.003, 0.8, 0.8
    adjusted = comparisons.holm([0.5, np.nan, 0.001, 0.4])
    assert np.isnan(adjusted[1])
    assert adjusted[[0, 2, 3]] == pytest.approx([0.8, 0.003, 0.8])
    assert comparisons.holm([0.6, 0.7]) == pytest.approx([1.0, 1.0])


def test_ert_on_a_hand_computed_example():
    # Two successes after 100 and 300 evaluations, two failures that spent 1000 each:
    # (100 + 300 + 1000 + 1000) / 2 = 1200.
    evals = [100, 300, np.inf, np.inf]
    nfev = [1000, 1000, 1000, 1000]
    assert statistics.ert(evals, nfev, np.isfinite(evals)) == 1200.0
    assert statistics.ert([np.inf], [500], [False]) == np.inf


def test_evaluations_to_target_reads_the_step_function():
    nfev, mse = np.array([1, 10, 50, 200]), np.array([100.0, 20.0, 5.0, 1.0])
    assert statistics.evaluations_to_target(nfev, mse, 5.0) == 50
    assert statistics.evaluations_to_target(nfev, mse, 4.9) == 200
    assert statistics.evaluations_to_target(nfev, mse, 0.5) == np.inf


def test_runtimes_and_ert_from_traces():
    runs = pd.DataFrame(
        {
            "kind": "ranking",
            "specimen": "s",
            "optimizer": ["a", "a", "b"],
            "replicate": [0, 1, 0],
            "status": "ok",
            "nfev": [100.0, 100.0, 100.0],
            "mse": [1.0, 1.05, 3.0],
        }
    )
    traces = pd.DataFrame(
        {
            "kind": "ranking",
            "specimen": "s",
            "optimizer": ["a", "a", "a", "a", "b"],
            "replicate": [0, 0, 1, 1, 0],
            "nfev": [1, 40, 1, 70, 1],
            "mse": [9.0, 1.0, 9.0, 1.05, 3.0],
        }
    )
    rt = statistics.runtimes(runs, traces, taus=(0.01, 0.1))
    a10 = rt[(rt["optimizer"] == "a") & (rt["tau"] == 0.1)]
    assert list(a10["evals"]) == [40, 70]
    a1 = rt[(rt["optimizer"] == "a") & (rt["tau"] == 0.01)]
    assert list(a1["reached"]) == [True, False]  # 1.05 > 1.01
    table = statistics.success_and_ert(rt).set_index(["optimizer", "tau"])
    assert table.loc[("a", 0.01), "ert"] == (40 + 100) / 1
    assert table.loc[("a", 0.1), "ert"] == (40 + 70) / 2
    assert table.loc[("b", 0.1), "success_rate"] == 0 and table.loc[("b", 0.1), "ert"] == np.inf


def test_best_known_counts_posterior_runs_and_failures_are_infinite(study):
    best = statistics.best_known(study.runs)
    ok = study.runs[study.runs["status"] == "ok"]
    assert best.to_dict() == ok.groupby("specimen")["mse"].min().to_dict()
    failed = study.runs.assign(status="error")
    assert np.all(np.isinf(statistics.final_mse(failed)))


def test_friedman_p_value_equals_scipys_on_the_same_table(study):
    table = statistics.median_table(study.ranking)
    assert table.shape == (2, 3)
    ours = statistics.friedman(table)
    theirs = scipy.stats.friedmanchisquare(*table.to_numpy().T)
    assert ours.pvalue == pytest.approx(theirs.pvalue)
    assert ours.statistic == pytest.approx(theirs.statistic)
    # The fixture's spreads make cmaes best and random worst on every specimen.
    assert list(ours.mean_ranks.index) == ["cmaes", "de", "random"]
    assert ours.mean_ranks["cmaes"] == 1.0


def test_friedman_needs_three_backends():
    table = pd.DataFrame({"a": [1.0, 2.0], "b": [2.0, 3.0]}, index=["s1", "s2"])
    result = statistics.friedman(table)
    assert np.isnan(result.pvalue) and "not applicable" in result.note
    assert result.mean_ranks["a"] == 1.0


def test_failed_runs_rank_last_and_count_as_errors(tmp_path):
    db = make_study_db(tmp_path / "err.sqlite", error=("pom-mt24u01_0.01MPa_r1", "cmaes", 0), posterior=False)
    loaded = results_db.load_study(db)
    values = comparisons.log_losses(loaded.ranking)
    spec = values[values["specimen"] == "pom-mt24u01_0.01MPa_r1"]
    is_failed = (spec["optimizer"] == "cmaes") & (spec["replicate"] == 0)
    assert spec.loc[is_failed, "value"].iloc[0] == pytest.approx(spec.loc[~is_failed, "value"].max() + 1.0)
    ranking, _ = statistics.ranking_table(loaded.runs, loaded.traces)
    row = ranking.set_index("optimizer").loc["cmaes"]
    assert row["errors"] == 1 and row["success_1%"] < 1


def test_ranking_table_is_sorted_by_mean_rank(study):
    table, fr = statistics.ranking_table(study.runs, study.traces, study.optimizers)
    assert list(table["optimizer"]) == ["cmaes", "de", "random"]
    assert set(table.columns) >= {
        "median_rmse_N",
        "best_rmse_N",
        "success_1%",
        "success_10%",
        "ert_1%",
        "ert_10%",
        "mean_rank",
    }
    assert (table["runs"] == 8).all()


def test_chain_diagnostics_warn_on_a_short_chain_only():
    rng = np.random.default_rng(1)

    def ar_chain(steps, phi):
        x = np.zeros((steps, 20, 3))
        for s in range(1, steps):
            x[s] = phi * x[s - 1] + rng.normal(size=(20, 3))
        return x

    short = mcmc.chain_diagnostics(ar_chain(100, 0.95), 0.3)
    assert short["tau_max"] > 2 and any("shorter than 50·τ" in w for w in short["warnings"])
    long = mcmc.chain_diagnostics(ar_chain(3000, 0.3), 0.3)
    assert long["warnings"] == []
    assert long["ess"] == pytest.approx(3000 * 20 / long["tau_max"])


def test_stuck_walker_is_found_from_log_prob():
    rng = np.random.default_rng(2)
    samples = rng.normal(size=(200, 10, 2))
    log_prob = -0.5 * (samples**2).sum(axis=2)
    log_prob[:, 3] -= 1000.0
    mask = mcmc.stuck_walkers(samples, log_prob)
    assert mask.tolist() == [i == 3 for i in range(10)]
    d = mcmc.chain_diagnostics(samples, 0.3, log_prob)
    assert d["stuck"] == 1 and any("stuck" in w for w in d["warnings"])


def test_chains_round_trip_in_unit_coordinates(study):
    (chain,) = study.chains
    assert chain.samples.shape == (300, 30, 14)
    assert chain.log_prob.shape == (300, 30)
    assert np.all((chain.samples >= 0) & (chain.samples <= 1))
    from bwbench.models.switched.parameters import LOWER, UPPER

    physical = chain.physical(lambda u: LOWER + u * (UPPER - LOWER), 100)
    assert physical.shape == (200 * 30, 14)
    assert np.all((physical >= LOWER) & (physical <= UPPER))


def test_load_refuses_missing_and_foreign_files(tmp_path):
    with pytest.raises(UserError, match="nope.sqlite"):
        results_db.load_study(tmp_path / "nope.sqlite")
    text = tmp_path / "notes.sqlite"
    text.write_text("hello, not a database\n" * 100)
    with pytest.raises(UserError, match="notes.sqlite"):
        results_db.load_study(text)
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as conn:
        conn.execute("CREATE TABLE t (x)")
    with pytest.raises(UserError, match="other.sqlite.*not a bwbench study"):
        results_db.load_study(other)


def test_one_specimen_uses_kruskal_wallis_and_names_the_unpaired_test():
    mse = {"a": [1.0, 2.0, 3.0, 4.0, 5.0], "b": [10.0, 11.0, 12.0, 13.0, 14.0], "c": [1.5, 2.5, 3.5, 4.5, np.inf]}
    runs = pd.DataFrame(
        [
            {"kind": "ranking", "specimen": "s", "optimizer": o, "replicate": r, "status": "ok", "mse": v}
            for o, values in mse.items()
            for r, v in enumerate(values)
        ]
    )
    runs.loc[(runs["optimizer"] == "c") & (runs["replicate"] == 4), "status"] = "error"
    kw = statistics.kruskal_wallis(runs)
    assert kw.n_groups == 3 and kw.pvalue < 0.05
    tests = statistics.compare_backends(runs)
    assert tests.omnibus_name == "Kruskal–Wallis test" and tests.n_specimens == 1 and tests.seeds == 5
    assert tests.test_name.startswith("the unpaired Mann–Whitney U test")
    values = comparisons.log_losses(runs)
    ab = comparisons.compare(values, "a", "b")
    assert ab["p"] == pytest.approx(2 / 252) == ab["min_p"]  # every run of a beats every run of b
    assert ab["ratio"] < 1 and ab["ratio_high"] < 1


def test_ranking_table_has_the_cost_of_an_evaluation_and_the_expected_time_to_target(study):
    table, _ = statistics.ranking_table(study.runs, study.traces, study.optimizers)
    ranking = study.ranking
    for row in table.itertuples():
        mine = ranking[ranking["optimizer"] == row.optimizer]
        assert row.s_per_eval == pytest.approx(mine["wall_s"].sum() / mine["nfev"].sum())
    rows = table.set_index("optimizer")
    for name in rows.index:
        ert, time = rows.loc[name, "ert_1%"], rows.loc[name, "time_1%"]
        assert time == (ert * rows.loc[name, "s_per_eval"] if np.isfinite(ert) else np.inf)
    success = statistics.success_by_specimen(study.runs, study.traces, 0.01)
    assert set(success.columns) == set(study.optimizers) and len(success) == 2
    assert success.mean().to_dict() == pytest.approx(rows["success_1%"].to_dict())
