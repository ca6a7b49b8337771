"""One answer everywhere: on a study whose measured times decide the tie-break, the Python API
(``Study.recommendation``, ``Study.ranking()``), the terminal line of ``bwbench compare`` and
``bwbench report`` and the report itself name the same label and the same ties (one function,
``bwbench.report.decision.decide_study``, makes them all)."""

import io
import shutil
import sqlite3
import sys
from contextlib import closing
from pathlib import Path

import pytest

import bwbench
from bwbench.commands.compare_run import recommendation_line
from bwbench.report.build import build_report

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from study_fixture import make_study_db  # noqa: E402

PEERS = {"cmaes": 2e-5, "de": 2e-5, "pso": 2e-5, "random": 0.15}


@pytest.fixture(scope="module")
def timed_db(tmp_path_factory):
    """Three peers as good by the rule; pso's runs take 4× as long: slower beyond the time noise, so
    time decides that pso is not tied (an API that ignores the times would call it tied)."""
    folder = tmp_path_factory.mktemp("one_answer")
    db = make_study_db(folder / "base.sqlite", optimizers=PEERS, posterior=False)
    timed = folder / "study.sqlite"
    shutil.copyfile(db, timed)
    with closing(sqlite3.connect(timed)) as conn:
        conn.execute("UPDATE timings SET wall_s = wall_s * 4 WHERE optimizer = 'pso'")
        conn.commit()
    return timed


def test_api_terminal_and_report_give_the_same_recommendation_and_ties(timed_db, tmp_path):
    study = bwbench.load_study(timed_db)
    rec = study.recommendation
    ranking = study.ranking().set_index("optimizer")
    assert rec.label == "cmaes"
    assert ranking.loc["pso", "verdict"] == "as good, slower"  # time decided: beyond the noise
    assert ranking.loc["de", "verdict"] == "tied on time"
    assert ranking.loc["cmaes", "verdict"] == "recommended"

    line = recommendation_line(timed_db)
    assert line == rec.line
    assert "use cmaes" in line and "tied on time: de " in line and "pso" not in line

    announced = io.StringIO()
    build_report(timed_db, tmp_path / "rep", profile_params=0, log=io.StringIO(), announce=announced)
    assert announced.getvalue().strip() == line
    md = (tmp_path / "rep" / "report.md").read_text(encoding="utf-8")
    assert "**Use cmaes**" in md and "**Tied**: de (" in md and "slower beyond the time noise: pso" not in md
    csv = (tmp_path / "rep" / "ranking.csv").read_text(encoding="utf-8")
    for label, verdict in ranking["verdict"].items():
        assert f"{label}," in csv and verdict in csv
