"""The report: self-contained HTML, a recommendation that follows its stated rule."""

import argparse
import re
import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from study_fixture import SCHEMA, make_study_db

from bwbench.report import build as report
from bwbench.study import results as results_db
from bwbench.analysis import statistics
from bwbench.errors import UserError


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    db = make_study_db(tmp_path_factory.mktemp("db") / "study.sqlite")
    out = tmp_path_factory.mktemp("report")
    html_path = report.build_report(db, out, profile_params=1, profile_grid=2)
    return db, out, html_path


def test_html_is_self_contained(built):
    _, out, html_path = built
    assert html_path == out / "report.html" and (out / "report.md").is_file()
    html = html_path.read_text(encoding="utf-8")
    assert 'src="http' not in html and 'href="http' not in html and "<script" not in html
    assert "<link" not in html and "@import" not in html and "url(" not in html
    sources = re.findall(r'<img [^>]*src="([^"]*)"', html)
    pngs = sorted(out.glob("*.png"))
    assert len(sources) == len(pngs) >= 7
    assert all(s.startswith("data:image/png;base64,") for s in sources)
    for png in pngs:
        assert png.with_suffix(".csv").is_file()
    assert "SYNTHETIC DATA" in html


def test_recommendation_names_the_best_mean_rank(built):
    _, out, _ = built
    ranking = pd.read_csv(out / "ranking.csv")
    best = ranking.loc[ranking["mean_rank"].idxmin(), "optimizer"]
    md = (out / "report.md").read_text(encoding="utf-8")
    named = re.search(r"evaluations use \*\*([^*]+)\*\*", md).group(1)
    assert named == best == "cmaes"
    # ...and it is the first row of the ranking table the report shows
    table_rows = [line for line in md.splitlines() if line.startswith("| cmaes |") or line.startswith("| de |")]
    assert table_rows[0].startswith(f"| {best} |")
    assert "Rule used: best = the backend with the lowest mean Friedman rank" in md
    assert "Holm" in md and "Friedman test over 2 specimens" in md


def test_report_has_tables_identifiability_and_mcmc_sections(built):
    _, out, _ = built
    md = (out / "report.md").read_text(encoding="utf-8")
    for heading in ("## What was compared", "## Data", "## Ranking", "## Recommendation",
                    "## Identified parameters per specimen", "## Identifiability", "## Posterior sampling",
                    "## Limits of this study"):
        assert heading in md
    assert "POM MT24u01: tension set (+)" in md and "truth (synthetic)" in md
    assert "noise_force_n | 1.0 | N" in md  # the generation settings, with units
    assert "R̂" in md and "bulk ESS" in md  # ArviZ diagnostics of the fixture chain


def _table(rows):
    return pd.DataFrame(rows, columns=["optimizer", "mean_rank", "median_rmse_N", "success_10%", "ert_10%",
                                       "median_wall_s"])


def _pairs(rows, n=30):
    """Pairwise rows (a, b, median log10 ratio a/b, Holm p) of a design with ``n`` paired runs."""
    frame = pd.DataFrame(rows, columns=["a", "b", "median_diff", "p_holm"])
    frame["significant"] = frame["p_holm"] < 0.05
    frame["wins_a"] = frame["wins_b"] = 0
    frame["n_a"] = frame["n_b"] = n
    frame["min_p"] = 2.0 / 2.0**n
    return frame


def test_recommend_weighs_effect_size_and_separates_close_from_far():
    table = _table([("x", 1.2, 2.0, 0.8, 900.0, 1.0), ("y", 1.9, 2.1, 0.6, 1200.0, 0.5),
                    ("e", 2.0, 2.05, 0.6, 1000.0, 3.0), ("z", 3.0, 3.6, 0.2, 5e4, 1.0),
                    ("v", 3.5, 12.0, 0.0, np.inf, 1.0), ("w", 3.9, 30.0, 0.1, 9e4, 1.0),
                    ("random", 5.0, 50.0, 0.0, np.inf, 1.0)])
    pairs = _pairs([("x", "y", -0.1, 0.40), ("x", "e", -0.02, 0.001), ("x", "z", -0.9, 0.01), ("x", "w", -1.0, 0.01),
                    ("x", "v", -0.8, 0.01), ("v", "random", -1.0, 0.01), ("x", "random", -2.0, 0.01),
                    ("w", "random", 0.3, 0.02), ("z", "random", -1.0, 0.01), ("e", "random", -2.0, 0.01)])
    fr = statistics.Friedman(10.0, 0.01, pd.Series(dtype=float), 6, "")
    rec = report.recommend(table, pairs, fr, 1000, 6)
    assert rec["best"] == "x"
    assert [n for n, _, _ in rec["tied"]] == ["y"]
    # significant (p = 0.001) but a median ratio of 10^0.02 = 1.047: practically equal, not "worse"
    assert [n for n, _, _ in rec["equal"]] == ["e"]
    assert [n for n, _, _ in rec["close"]] == ["z"]  # 3.6 N ≤ 2 × 2.0 N
    assert [n for n, _, _ in rec["far"]] == ["v"]  # 12 N, better than random: far behind, not "avoid"
    assert dict(rec["avoid"]).keys() == {"w"}  # random is the baseline, never a candidate
    assert rec["choice"] == "x"  # the practically equal group's fastest per run: the tie-breaker
    text = rec["text"]
    assert text.startswith("For this problem at a budget of 1,000 evaluations, **x** and **e** are as good")
    assert "use either" in text and "**x** is the fastest per run" in text
    assert "e's final losses are within 10 % of x's (median ratio 1.05, Holm p = 0.001): practically equal" in text
    assert "The tests cannot tell x from y (Holm p = 0.4, median ratio 1.26)" in text  # tied, not "as good"
    assert "Close behind (median RMSE within 2× the best's): z (3.6 N)" in text
    assert "Far behind (median RMSE more than 2× the best's): v (12 N)" in text
    assert "Random search, the baseline, ends at a median RMSE of 50 N." in text


def test_recommend_says_not_enough_runs_when_the_design_cannot_reach_alpha():
    # 3 specimens × 2 seeds = 6 pairs: the exact signed-rank test cannot go below 2/2^6 = 0.031,
    # and Holm multiplies it by the 3 comparisons: 0.094 ≥ 0.05
    table = _table([("x", 1.0, 2.0, 0.5, 10.0, 1.0), ("y", 2.0, 2.5, 0.5, 20.0, 2.0), ("z", 3.0, 3.0, 0.5, 30.0, 1.0)])
    pairs = _pairs([("x", "y", -0.1, 0.5), ("x", "z", -0.2, 0.094), ("y", "z", -0.1, 0.5)], n=6)
    rec = report.recommend(table, pairs, statistics.Friedman(1.0, 0.6, pd.Series(dtype=float), 3, ""), 50, 3)
    assert [n for n, _, _ in rec["tied"]] == ["y", "z"] and not rec["avoid"]
    assert rec["power"]["min_p_holm"] == pytest.approx(0.09375) and not rec["power"]["can_reach"]
    assert "Not enough runs to separate x from y (Holm p = 0.5" in rec["text"]
    assert "smallest Holm-corrected p the design can reach is 0.094" in rec["text"]
    assert "does not detect a difference" in rec["text"]


def _cli(args):
    parser = argparse.ArgumentParser()
    report.add_arguments(parser)
    return report.cli_main(parser.parse_args(args))


def test_cli_refuses_a_missing_database(tmp_path):
    with pytest.raises(UserError, match="missing.sqlite"):
        _cli(["--db", str(tmp_path / "missing.sqlite"), "--out", str(tmp_path / "r")])


def test_fixture_schema_is_the_runners_contract():
    from bwbench.study import store as study

    def columns(schema):
        with sqlite3.connect(":memory:") as conn:
            conn.executescript(schema)
            tables = [r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")]
            return {t: [(r[1], r[2]) for r in conn.execute(f"PRAGMA table_info({t})")] for t in tables}

    assert columns(SCHEMA) == columns(study.SCHEMA)


def test_reads_a_database_written_by_the_runner(tmp_path):
    from bwbench.study import execute as study
    from bwbench.study.config import load_study_config

    toml = tmp_path / "tiny.toml"
    data = (Path(__file__).resolve().parents[2] / "data" / "specimens").as_posix()
    toml.write_text(f"""
[study]
name = "tiny"
seed = 3
budget = 60
seeds = 2
data = "{data}"
[specimens]
material = ["POM MT24u01"]
underpressure_MPa = [0.01, 0.09]
repeat = [1]
[optimizers]
random = {{}}
de = {{}}
cmaes = {{}}
[posterior]
specimens = ["pom-mt24u01_0.01MPa_r1"]
budget = 300
""")
    db = tmp_path / "tiny.sqlite"
    study.run_study(load_study_config(toml), db, workers=1, log=open(tmp_path / "log.txt", "w"))
    loaded = results_db.load_study(db)
    assert len(loaded.ranking) == 2 * 3 * 2 and set(loaded.optimizers) == {"random", "de", "cmaes"}
    assert loaded.data_dir.joinpath("manifest.json").is_file()
    (chain,) = loaded.chains
    assert chain.samples.shape[1:] == (30, 14) and chain.log_prob.shape == chain.samples.shape[:2]
    table, fr = statistics.ranking_table(loaded.runs, loaded.traces, loaded.optimizers)
    assert len(table) == 3 and np.isfinite(fr.pvalue)
    rec = report.recommend(table, statistics.pairwise_wilcoxon(loaded.ranking), fr, 60, 2)
    assert rec["best"] == table.iloc[0]["optimizer"]


def test_pairwise_tests_read_as_a_matrix_in_ranking_order():
    pairs = _pairs([("x", "y", -0.5, 0.01), ("x", "z", -1.0, 0.01), ("y", "z", 0.2, 0.40)])
    from bwbench.report.sections import pairwise_matrix

    matrix = pairwise_matrix(pairs, ["x", "y", "z"])
    assert list(matrix.columns) == ["backend (rank)", "1", "2", "3"]
    assert list(matrix["backend (rank)"]) == ["1. x", "2. y", "3. z"]
    # antisymmetric, starred only where Holm leaves the difference significant
    assert matrix.loc[0, "2"] == "-0.5*" and matrix.loc[1, "1"] == "0.5*"
    assert matrix.loc[1, "3"] == "0.2" and matrix.loc[2, "2"] == "-0.2"
    assert matrix.loc[0, "1"] == "–"


def test_html_tables_put_text_left_and_numbers_right(built):
    _, _, html_path = built
    html = html_path.read_text(encoding="utf-8")
    # the backend column is text, the wall-time column numbers; every ranking row has both
    assert re.search(r'<td class="text">cmaes</td>', html)
    assert re.search(r"<td>\d[\d.,]*</td>", html)
    assert not re.search(r'<td class="text">\d[\d.,]*</td>', html.split("<h2>Ranking</h2>")[1].split("</table>")[0])


def test_backends_table_finds_the_backend_behind_a_formulation_label(built):
    db, _, _ = built
    from bwbench.report.sections import backends_table

    study = results_db.load_study(db)
    study.config["optimizers"] = {"cmaes": {"popsize": 8}}
    study.runs.loc[study.runs["optimizer"] == "cmaes", "optimizer"] = "cmaes [identifiable]"
    row = backends_table(study).set_index("backend").loc["cmaes [identifiable]"]
    assert row["family"] != "–" and row["evaluates"] == "populations" and row["options"] == "popsize=8"


def test_report_says_how_long_the_study_took(built):
    db, out, _ = built
    with sqlite3.connect(db) as conn:
        walls = np.array([r[0] for r in conn.execute("SELECT wall_s FROM timings")])
    md = (out / "report.md").read_text(encoding="utf-8")
    # every fixture run finished at the same instant: the study took as long as its longest run
    took = re.search(r"Computed in \*\*([0-9.e-]+) s\*\* elapsed.*in one session; ([0-9.e-]+) core-hours", md)
    assert took, md[:2000]
    assert float(took.group(1)) == pytest.approx(walls.max(), rel=2e-3)
    assert float(took.group(2)) == pytest.approx(walls.sum() / 3600, rel=2e-3)


def test_recommend_says_many_practically_equal_backends_in_one_sentence():
    table = _table([("x", 1.2, 2.0, 0.8, 900.0, 1.0), ("a", 1.9, 2.01, 0.8, 900.0, 2.0),
                    ("b", 2.0, 2.02, 0.8, 900.0, 0.5), ("c", 2.2, 2.1, 0.7, 900.0, 3.0),
                    ("random", 5.0, 50.0, 0.0, np.inf, 1.0)])
    pairs = _pairs([("x", "a", -0.001, 0.30), ("x", "b", -0.01, 0.02), ("x", "c", -0.03, 0.001),
                    ("x", "random", -2.0, 0.01), ("a", "random", -2.0, 0.01), ("b", "random", -2.0, 0.01),
                    ("c", "random", -2.0, 0.01)])
    fr = statistics.Friedman(10.0, 0.01, pd.Series(dtype=float), 6, "")
    rec = report.recommend(table, pairs, fr, 1000, 6)
    assert [n for n, _, _ in rec["equal"]] == ["a", "b", "c"] and rec["choice"] == "b"
    text = rec["text"]
    assert ("The final losses of the other 3 are within 10 % of x's (median paired ratios 1.00 to 1.07; "
            "Holm p 0.001 to 0.3;") in text
    assert "final losses are within 10 % of x's (median ratio" not in text  # no sentence per backend
