"""bwbench.compare / load_study → Study: typed runs, ranking() in the rule's order with verdicts,
recommendation, report(out_dir), and a posterior as a DataFrame and as ArviZ InferenceData."""

import math
import warnings

import numpy as np
import pandas as pd
import pytest

import bwbench
from api_toy import toy_frame


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("data")
    for k in (1, 2):
        toy_frame(k, n=300).to_csv(folder / f"toy{k}.csv", index=False)
    return folder


@pytest.fixture(scope="module")
def study(files):
    return bwbench.compare(
        specimens=[files / "toy1.csv", files / "toy2.csv"],
        optimizers=["lsq-trf", "random"],
        seeds=2,
        budget=40,
        model="bouc-wen",
        db=files / "study.sqlite",
    )


def test_runs_have_typed_columns(study):
    runs = study.runs
    assert len(runs) == 2 * 2 * 2 and "success" not in runs
    assert str(runs["nfev"].dtype) == "Int64" and runs["nfev"].eq(40).all()
    assert runs["finished"].dtype == bool and runs["finished"].all()
    assert set(runs["backend"]) == {"lsq-trf", "random"} and runs["model"].eq("bouc-wen").all()
    assert runs["formulation"].eq("identifiable").all()
    assert np.allclose(runs["rmse_N"], np.sqrt(runs["mse"]))
    # every parameter by name, the solved coefficients included
    assert runs[["xy", "n", "eta", "c", "k", "h"]].notna().all().all()


def test_ranking_follows_the_rule_and_says_each_verdict(study):
    table = study.ranking()
    assert list(table.columns[:4]) == ["optimizer", "backend", "variant", "verdict"]
    assert table.loc[table["optimizer"] == "random", "verdict"].item() == "baseline"
    assert table["verdict"].iloc[0] == "recommended" and table["optimizer"].iloc[0] == "lsq-trf"


def test_recommendation_names_label_backend_formulation_model_budget(study):
    rec = study.recommendation
    assert (rec.label, rec.backend, rec.formulation, rec.model, rec.budget) == (
        "lsq-trf",
        "lsq-trf",
        "identifiable",
        "bouc-wen",
        40,
    )
    assert rec.sentence.startswith("Use lsq-trf at a budget of 40 evaluations") and rec.sentence.endswith(".")
    assert "**" not in rec.sentence and rec.text.startswith("**Use lsq-trf**")


def test_report_writes_the_report_of_bwbench_report(study, tmp_path):
    html = study.report(tmp_path / "out", profiles=0)
    assert html == tmp_path / "out" / "report.html" and html.is_file()
    csv = pd.read_csv(tmp_path / "out" / "ranking.csv")
    ranking = study.ranking()
    assert csv["optimizer"].tolist() == ranking["optimizer"].tolist()
    assert csv["verdict"].fillna("").tolist() == ranking["verdict"].tolist()
    with pytest.raises(bwbench.UserError):
        study.report(tmp_path / "out", profiles=-1)


def test_load_study_reads_the_same_study_and_the_repr_is_short(study):
    again = bwbench.load_study(study.path)
    assert again.runs.equals(study.runs)
    assert again.recommendation == study.recommendation
    assert len(repr(again)) < 200 and "8 runs (8 finished)" in repr(again)
    assert "<table>" in again._repr_html_()
    assert again.settings["budget"] == 40 and again.traces["nfev"].max() <= 40  # the stored study read through


def test_a_complete_study_is_read_not_run_again(study, files):
    again = bwbench.compare(
        specimens=[files / "toy1.csv", files / "toy2.csv"],
        optimizers="lsq-trf,random",
        seeds=2,
        budget=40,
        model="bouc-wen",
        db=files / "study.sqlite",
    )
    assert again.runs["finished_utc"].tolist() == study.runs["finished_utc"].tolist()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({}, "either config= .* or specimens="),
        ({"specimens": ["x.csv"]}, "specimens= needs optimizers="),
        ({"specimens": [pd.DataFrame()], "optimizers": ["cmaes"]}, "write a DataFrame with frame.to_csv"),
        ({"specimens": ["missing.csv"], "optimizers": ["cmaes"]}, "missing.csv"),
        ({"specimens": ["toy1.csv"], "optimizers": ["nope"]}, "nope"),
        ({"specimens": ["toy1.csv"], "optimizers": ["cmaes"], "seeds": 0}, "--seeds must be a positive integer"),
        ({"specimens": ["toy1.csv"], "optimizers": ["cmaes"], "workers": 0}, "workers must be a positive integer"),
        ({"config": "a.toml", "optimizers": ["cmaes"]}, "optimizers= goes with specimens="),
    ],
)
def test_bad_arguments_are_user_errors(files, monkeypatch, kwargs, message):
    monkeypatch.chdir(files)
    with pytest.raises(bwbench.UserError, match=message):
        bwbench.compare(**kwargs)


@pytest.fixture(scope="module")
def posterior_study(files):
    toml = files / "posterior.toml"
    toml.write_text(f"""
[study]
name = "posterior"
seed = 5
budget = 40
seeds = 1
model = "bouc-wen"
[specimens]
files = ["{(files / "toy1.csv").as_posix()}"]
[optimizers]
lsq-trf = {{}}
[posterior]
specimens = ["toy1"]
optimizer = "emcee"
budget = 960
seeds = 1
""")
    return bwbench.compare(config=toml, db=files / "posterior.sqlite")


def test_posterior_draws_in_physical_units(posterior_study):
    (chain,) = posterior_study.chains
    walkers, steps = chain.walkers, chain.steps
    draws = posterior_study.posterior("toy1")
    kept = steps - steps // 2
    assert len(draws) == walkers * kept and draws["walker"].nunique() == walkers
    assert draws["step"].min() == steps // 2
    assert list(draws.columns[2:]) == ["xy", "n", "eta", "m", "c", "k", "h", "f"]
    assert draws.attrs["units"]["xy"] == "mm" and draws.attrs["units"]["h"] == "N"
    # the sampled θ mapped out of the unit box: row 0 is walker 0's first kept step
    problem_xy = draws["xy"].iloc[0]
    from bwbench.api.posterior import chain_of

    p = chain_of(posterior_study._stored, "toy1")
    assert problem_xy == pytest.approx(p.problem.from_unit(chain.samples[steps // 2, 0])[0])
    assert draws["h"].between(20, 100).all()  # truth 60 N: the solved coefficient drawn near it


@pytest.mark.filterwarnings("ignore:More chains")  # a tiny chain: 24 walkers, 12 kept draws each
def test_inference_data_holds_the_same_draws(posterior_study):
    import arviz as az

    idata = posterior_study.to_inference_data("toy1", thin=2)
    draws = posterior_study.posterior("toy1", thin=2)
    post = idata.posterior
    assert post.sizes["chain"] == draws["walker"].nunique() and post.sizes["draw"] * post.sizes["chain"] == len(draws)
    assert np.allclose(post["xy"].values.ravel(), draws["xy"].to_numpy())
    assert "lp" in idata.sample_stats and "xy" in az.summary(idata, var_names=["xy"]).index
    with pytest.raises(bwbench.UserError, match="no posterior of 'toy2'"):
        posterior_study.posterior("toy2")
    with pytest.raises(bwbench.UserError, match="thin must be a positive integer"):
        posterior_study.posterior("toy1", thin=0)


def test_a_study_without_a_posterior_says_so(study):
    with pytest.raises(bwbench.UserError, match="no posterior run"):
        study.posterior("toy1")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert math.isfinite(study.ranking()["median_rmse_N"].iloc[0])


def test_report_and_posterior_leave_a_notebook_matplotlib_as_it_was(posterior_study, tmp_path):
    # The report's figure modules select Agg and set a theme when imported: a notebook keeps its own.
    import subprocess
    import sys

    script = f"""
import matplotlib
matplotlib.use("pdf")
import matplotlib.pyplot as plt
plt.rcParams["font.size"] = 13.0
before = matplotlib.rcParams.copy()
import bwbench
study = bwbench.load_study({str(posterior_study.path)!r})
study.posterior("toy1")
study.report({str(tmp_path / "out")!r}, profiles=0)
print(plt.get_backend(), matplotlib.rcParams.copy() == before, matplotlib.rcParams["font.size"])
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["pdf", "True", "13.0"]
    assert (tmp_path / "out" / "report.html").is_file()


@pytest.fixture(scope="module")
def cut_posterior_study(files):
    """Nested sampling on a budget too small for its runs to end (each is cut), the mass held at 0."""
    toml = files / "cut.toml"
    toml.write_text(f"""
[study]
name = "cut"
seed = 5
budget = 40
seeds = 1
model = "bouc-wen"
fix_mass = 0
[specimens]
files = ["{(files / "toy1.csv").as_posix()}"]
[optimizers]
lsq-trf = {{}}
[posterior]
specimens = ["toy1"]
budget = 1500
options = {{ live_points = 40, min_ess = 20 }}
""")
    return bwbench.compare(config=toml, db=files / "cut.sqlite")


def test_a_cut_posterior_gives_each_runs_weighted_draws_and_its_verdict(cut_posterior_study):
    import json

    draws = cut_posterior_study.posterior("toy1")
    verdict = cut_posterior_study.posterior_verdict("toy1")
    assert draws.attrs["converged"] is False and verdict.converged is False
    assert "cut by the budget" in draws.attrs["reasons"][0] and draws.attrs["verdict"] == verdict.line
    # every run's weighted points (its distinct draws with their weights), each run worth its effective
    # draws — a run cut this early puts nearly all its weight on its best point — and nothing NaN
    assert sorted(set(draws["run"])) == [0, 1, 2, 3] and "weight" in draws
    assert np.allclose(draws.groupby("run")["weight"].sum(), 0.25) and draws["weight"].sum() == pytest.approx(1)
    assert len(draws.attrs["effective_draws"]) == 4 and min(draws.attrs["effective_draws"]) >= 1
    assert np.isfinite(draws[["xy", "n", "eta", "c", "k", "h"]].to_numpy()).all()
    # the held mass is named, not a column of zeros; the units are a dict
    assert "m" not in draws and draws.attrs["held"] == {"m": 0.0}
    assert draws.attrs["units"]["xy"] == "mm"
    idata = cut_posterior_study.to_inference_data("toy1")
    assert idata.attrs["converged"] == 0 and json.loads(idata.attrs["reasons"]) == verdict.reasons
    assert json.loads(idata.posterior.attrs["units"])["h"] == "N" and "m" not in idata.posterior
    assert idata.posterior.sizes["chain"] == 4 and idata.posterior.sizes["draw"] >= 1000
    # the terminal's line after `bwbench compare` is the same verdict
    from bwbench.commands.compare_run import posterior_lines

    assert posterior_lines(cut_posterior_study.path) == [f"toy1 (nested): {verdict.line}"]
