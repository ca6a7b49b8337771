"""A user's own data get a report about their data: no paper vocabulary without a manifest saying
the data are the paper's, parameters in the coordinates searched, a model-adequacy section, honest
aggregates, and a noise floor only where the truth's MSE is one."""

import numpy as np
import pytest

from bwbench.datasets import mr_damper
from bwbench.problems.hysteresis.report import adequacy
from bwbench.problems.hysteresis.report.parameter_tables import aggregate_label, aggregate_text
from bwbench.render.floors import FACTOR, is_noise_floor
from bwbench.report import build as report

PAPER_WORDS = ("Table 5", "Tables 6–8", "Figs 20", "Figs 18", "% of Table 5", "the paper's Tables", "SYNTHETIC")


@pytest.fixture(scope="module")
def own_report(tmp_path_factory):
    """Two MR-damper sine tests (Spencer et al. 1997, not our model), no manifest, the identifiable
    formulation, 2 backends × 2 seeds × 80 evaluations, run by the runner; and its report."""
    from bwbench.study import execute
    from bwbench.study.config import load_study_config

    folder = tmp_path_factory.mktemp("lab")
    for hz in (2.0, 4.0):
        mr_damper.write_test(
            folder / f"damper_{hz:g}hz.csv",
            amplitude_mm=20.0,
            frequency_hz=hz,
            rate_hz=400.0,
            cycles=2,
            peak_force_N=1500.0,
            rng=int(hz),
        )
    toml = folder / "mine.toml"
    toml.write_text(
        """
[study]
name = "mine"
seed = 11
budget = 80
seeds = 2
formulation = "identifiable"
[specimens]
files = ["damper_*.csv"]
[optimizers]
cmaes = {}
random = {}
""",
        encoding="utf-8",
    )
    db = folder / "mine.sqlite"
    execute.run_study(load_study_config(toml), db, workers=1, log=open(folder / "log.txt", "w"))
    out = folder / "report"
    report.build_report(db, out, profile_params=1, profile_grid=3, log=open(folder / "report.txt", "w"))
    return (out / "report.md").read_text(encoding="utf-8")


def test_no_paper_vocabulary_on_a_users_data(own_report):
    for words in PAPER_WORDS:
        assert words not in own_report, words


def test_parameters_are_in_the_coordinates_the_study_searched(own_report):
    tables = own_report.split("## Identified parameters per specimen")[1].split("## Identifiability")[0]
    assert "In the identifiable coordinates, the coordinates the study searched" in tables
    assert "| x_y₊ (mm) | n₊ (–) | η₊ (–) |" in tables and "| m (N·s²/mm) | c+ (N·s/mm) |" in tables
    assert "| A₊ |" not in own_report and "ωn₊" not in tables  # no paper coordinates it never searched
    assert "both runs" in tables and "median [min, max] of 2" not in tables  # two seeds are listed, not "median"
    assert "(ranges: the box scaled from the data)" in own_report


def test_a_model_adequacy_section_says_how_well_and_where_the_fit_misses(own_report):
    section = own_report.split("## Model adequacy")[1].split("\n## ")[0]
    assert "RMSE / peak |F|" in section.replace("\\|", "|")
    assert "share of squared error within ±5% of a stroke of the reversals" in section
    assert "The best fits leave an RMSE of" in section and "of the peak force (2 specimens)" in section


def test_the_truth_is_a_noise_floor_only_within_the_stated_factor():
    assert FACTOR == 1.25
    assert is_noise_floor(1.2, 1.0) and is_noise_floor(0.85, 1.0)
    assert not is_noise_floor(5.06, 1.0)  # the synthetic truth misfits 5× the noise: not a floor
    assert not is_noise_floor(0.7, 1.0) and not is_noise_floor(1.0, None) and not is_noise_floor(np.inf, 1.0)


def test_the_residual_share_at_the_reversals_is_measured_against_the_samples_there():
    t = np.linspace(0.0, 4.0, 801)
    x = 10 * np.sin(2 * np.pi * t)  # 8 reversals
    f = 100 * np.cos(2 * np.pi * t)
    fitted = f + np.where(adequacy.reversal_windows(x), 5.0, 0.1)  # the misfit sits at the reversals
    summary = adequacy.residual_summary(x, f, fitted)
    assert summary["reversals"] == 8 and 0.05 < summary["sample_share"] < 0.15
    assert summary["error_share"] > 0.99 and summary["max_at_reversal"]
    text = adequacy.verdict_text(__import__("pandas").DataFrame([{"specimen": "s", **summary}]))
    assert "the residual concentrates at the reversals of travel" in text


def test_aggregates_say_what_they_are():
    assert aggregate_text([3.0]) == "3" and aggregate_label(1) == "its one run"
    assert aggregate_text([3.0, 5.0]) == "3, 5" and aggregate_label(2) == "both runs"  # not a "median" of 2
    assert aggregate_text([1.0, 3.0, 5.0]) == "3 [1, 5]" and aggregate_label(3) == "median [min, max] of 3 runs"
