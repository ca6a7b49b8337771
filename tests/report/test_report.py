"""The report: self-contained HTML, a recommendation that follows its stated rule."""

import argparse
import re
import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from bwbench.analysis import statistics
from bwbench.database import reader as results_db
from bwbench.errors import UserError
from bwbench.report import build as report
from study_fixture import SCHEMA, make_study_db


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


def test_the_answer_comes_first_then_the_rule_then_the_rule_applied(built):
    _, out, _ = built
    ranking = pd.read_csv(out / "ranking.csv")
    md = (out / "report.md").read_text(encoding="utf-8")
    assert md.split("\n## ")[1].startswith("Recommendation\n\n- **Use cmaes**")  # the first section: the box
    assert (
        md.index("## Recommendation")
        < md.index("## How the recommendation is decided")
        < md.index("## The rule applied to this study")
        < md.index("## Ranking")
    )
    assert '<meta name="viewport"' in (out / "report.html").read_text(encoding="utf-8")
    named = re.search(r"\*\*Use ([^*]+)\*\*", md).group(1)
    assert named == ranking.iloc[0]["optimizer"] == "cmaes"  # the ranking table is in the rule's order
    assert list(ranking["verdict"]) == ["recommended", "behind", "baseline"]
    # the fixture's cmaes is the only backend that reaches the target: success decides, random is the baseline
    assert "Random search is the baseline, never a candidate: random ends" in md
    assert "van Elteren's stratified Wilcoxon–Mann–Whitney test" in md and "Hodges–Lehmann" in md
    comparisons = pd.read_csv(out / "comparisons.csv")
    assert set(comparisons["family"]) == {"against the reference", "against random"}
    assert {"ratio_low", "ratio_high", "p_holm"} <= set(comparisons.columns)
    assert not (out / "pairwise_tests.csv").exists()


def test_report_has_tables_identifiability_and_mcmc_sections(built):
    _, out, _ = built
    md = (out / "report.md").read_text(encoding="utf-8")
    for heading in (
        "## What was compared",
        "## Data",
        "## Ranking",
        "## Recommendation",
        "## Identified parameters per specimen",
        "## Identifiability",
        "## Posterior sampling",
        "## Limits of this study",
    ):
        assert heading in md
    assert "POM MT24u01: tension set (+)" in md and "truth (synthetic)" in md
    assert "noise_force_n | 1 | N" in md and "| seed | 20181208 |" in md  # the generation settings, with units
    assert "R̂" in md and "bulk ESS" in md  # ArviZ diagnostics of the fixture chain


def _cli(args):
    from bwbench.commands import report as report_command

    parser = argparse.ArgumentParser()
    report_command.add_arguments(parser)
    return report_command.cli_main(parser.parse_args(args))


def test_cli_refuses_a_missing_database(tmp_path):
    with pytest.raises(UserError, match="missing.sqlite"):
        _cli(["--db", str(tmp_path / "missing.sqlite"), "--out", str(tmp_path / "r")])


def test_fixture_schema_is_the_runners_contract():
    from bwbench.database import writer as study

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
optimizer = "emcee"
budget = 300
""")
    db = tmp_path / "tiny.sqlite"
    study.run_study(load_study_config(toml), db, workers=1, log=open(tmp_path / "log.txt", "w"))
    loaded = results_db.load_study(db)
    assert len(loaded.ranking) == 2 * 3 * 2 and set(loaded.optimizers) == {"random", "de", "cmaes"}
    assert loaded.data_dir.joinpath("manifest.json").is_file()
    (chain,) = loaded.chains
    # the [posterior] defaults: 3 ensembles of 2·d + 2 walkers (d = 14)
    assert chain.samples.shape[1:] == (3 * 30, 14) and chain.log_prob.shape == chain.samples.shape[:2]
    table, fr = statistics.ranking_table(loaded.runs, loaded.traces, loaded.optimizers)
    assert len(table) == 3 and np.isfinite(fr.pvalue)
    from bwbench.analysis import comparisons
    from bwbench.report.recommend import recommend

    rec = recommend(
        table,
        statistics.success_by_specimen(loaded.runs, loaded.traces, 0.01),
        comparisons.log_losses(loaded.ranking),
        statistics.compare_backends(loaded.runs),
        60,
    )
    assert rec["choice"] in {"de", "cmaes"} and rec["order"][-1] != rec["choice"]


def test_html_tables_put_text_left_and_numbers_right(built):
    _, _, html_path = built
    html = html_path.read_text(encoding="utf-8")
    # the backend column is text, the wall-time column numbers; every ranking row has both
    assert re.search(r'<td class="text">cmaes</td>', html)
    assert re.search(r"<td>\d[\d.,]*</td>", html)
    ranking = html.split('<h2 id="ranking">Ranking</h2>')[1].split("</table>")[0]
    assert not re.search(r'<td class="text">\d[\d.,]*</td>', ranking)


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


def test_a_truth_is_called_a_noise_floor_only_where_it_is_one(built):
    db, out, _ = built
    from bwbench.render.floors import floors, stated_noise_variance

    study = results_db.load_study(db)
    found = floors(study, study.specimens)
    variance = stated_noise_variance(study)
    assert variance == 1.0 and set(found) == set(study.specimens)  # the manifest states σ = 1 N
    md = (out / "report.md").read_text(encoding="utf-8")
    if all(name == "noise floor" for _, name in found.values()):
        assert "the noise floor a perfect fit reaches" in md
    else:  # e.g. a truth that misfits 5× the noise variance
        assert any(value > 1.25 * variance for value, _ in found.values())
        assert "is no noise floor" in md and "the noise floor a perfect fit reaches" not in md
        assert "relative to the best known loss" in md and "MSE / noise floor" not in md
