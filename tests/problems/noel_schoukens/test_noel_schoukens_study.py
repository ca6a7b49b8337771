"""A study of the Bouc-Wen benchmark problem through the same runner, database and report as the
switched model; its configuration rules; the switched model's configuration hash unchanged."""

from __future__ import annotations

import json
import re
import sqlite3
import subprocess
import sys
from contextlib import closing
from pathlib import Path

import numpy as np
import pytest

from bwbench.errors import UserError
from bwbench.problems.noel_schoukens.data import FILES as BENCHMARK_FILES
from bwbench.problems.noel_schoukens.data import default_data_dir
from bwbench.problems.noel_schoukens.problem import PARAM_NAMES
from bwbench.report import build as report
from bwbench.study.config import load_study_config

REPO = Path(__file__).resolve().parents[3]
RUN_COMPARE = REPO / "studies" / "run_compare.py"
DATA_DIR = default_data_dir()
needs_data = pytest.mark.skipif(
    not all((DATA_DIR / f).is_file() for f in BENCHMARK_FILES),
    reason=f"Bouc-Wen benchmark data not found at {DATA_DIR} (see docs/benchmark.md)",
)
# The configuration of studies/quick.toml as databases written before specimens were identified by
# their bytes store it (issue 6's format): such a database must still resume (migrated on open).
QUICK_LEGACY = {
    "study": {
        "name": "quick",
        "seed": 20261121,
        "budget": 4100,
        "seeds": 5,
        "state": "shared",
        "excitation": "measured",
        "data": "data/specimens",
    },
    "specimens": {
        "filters": {"material": ["POM MT24u01"], "underpressure_MPa": [0.01, 0.05, 0.09], "repeat": [1]},
        "files": ["pom-mt24u01_0.01MPa_r1", "pom-mt24u01_0.05MPa_r1", "pom-mt24u01_0.09MPa_r1"],
    },
}


def write_benchmark_config(path: Path, body: str = "", optimizers: str = "random = {}\ncmaes = {}") -> Path:
    path.write_text(
        f"""
[study]
name = "bench-tiny"
problem = "bouc-wen-benchmark"
seed = 3
budget = 30
seeds = 2
{body}

[optimizers]
{optimizers}
""",
        encoding="utf-8",
    )
    return path


def run_compare(*args):
    return subprocess.run(
        [sys.executable, str(RUN_COMPARE), *map(str, args)], cwd=REPO, capture_output=True, text=True, timeout=180
    )


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """2 backends × 2 seeds × 30 evaluations, run by studies/run_compare.py in one process."""
    folder = tmp_path_factory.mktemp("bench")
    config = write_benchmark_config(folder / "bench.toml")
    db = folder / "study.sqlite"
    result = run_compare("--config", config, "--db", db, "--workers", "1")
    assert result.returncode == 0, result.stderr
    return config, db, result.stdout


@needs_data
def test_the_runner_records_problem_parameters_and_test_metrics(tiny):
    _, db, stdout = tiny
    with closing(sqlite3.connect(db)) as conn:
        conn.row_factory = sqlite3.Row
        rows = conn.execute("SELECT * FROM runs ORDER BY optimizer, replicate").fetchall()
        config = json.loads(dict(conn.execute("SELECT key, value FROM study").fetchall())["config_json"])
    assert [(r["optimizer"], r["replicate"]) for r in rows] == [
        ("cmaes", 0),
        ("cmaes", 1),
        ("random", 0),
        ("random", 1),
    ]
    for r in rows:
        assert r["problem"] == "bouc-wen-benchmark" and r["status"] == "ok" and r["nfev"] == 30
        params = json.loads(r["params_json"])
        assert tuple(sorted(params)) == tuple(sorted(PARAM_NAMES))
        assert all(np.isfinite(v) for v in params.values())
        metrics = json.loads(r["metrics_json"])
        for name in ("test_multisine_erms_m", "test_sinesweep_erms_m", "train_rmse_m"):
            assert np.isfinite(metrics[name]) and 0 < metrics[name] < 1e-2, (name, metrics)
        assert metrics["train_rmse_m"] == pytest.approx(np.sqrt(r["mse"]))
        # no model's parameters are columns; the switched problem's own columns stay, empty
        assert "A+" not in r.keys() and r["rmse_N"] is None and r["state"] is None and r["model"] is None
    assert config["study"]["problem"] == "bouc-wen-benchmark" and "data" not in config["study"]
    assert "median test e_RMS (m)" in stdout


@needs_data
def test_the_report_is_the_benchmark_report(tiny, tmp_path):
    _, db, _ = tiny
    html_path = report.build_report(db, tmp_path, log=open(tmp_path / "log.txt", "w"))
    html = html_path.read_text(encoding="utf-8")
    assert 'src="http' not in html and "<script" not in html and "<link" not in html and "url(" not in html
    sources = re.findall(r'<img [^>]*src="([^"]*)"', html)
    assert len(sources) == 5 and all(s.startswith("data:image/png;base64,") for s in sources)
    for png in tmp_path.glob("*.png"):
        assert png.with_suffix(".csv").is_file()
    md = (tmp_path / "report.md").read_text(encoding="utf-8")
    # the published figures, in one table with the backends
    table = md[md.index("| model | kind |") :].split("\n\n")[0]
    for model in (
        "identified by cmaes",
        "identified by random",
        "dynoNet",
        "NFIR",
        "PNLSS, 217 parameters",
        "RK4 at 15 kHz",
    ):
        assert model in table
    counts = re.search(
        r"reached e_RMS < 1e-05 m on test_multisine within the budget of 30 evaluations: "
        r"(\w+) \d/2 and (\w+) \d/2\.",
        md,
    )
    assert counts and {counts.group(1), counts.group(2)} == {"cmaes", "random"}
    assert "Noël and M. Schoukens" in md and "SYNTHETIC" not in md
    # the answer first, as in every report; the data named for what they are
    assert md.split("\n## ")[1].startswith("Recommendation\n\n- **Use ")
    assert "> **BENCHMARK DATA (Noël & Schoukens 2016: a simulated Bouc-Wen system with noise) — not measured.**" in md
    # one data set: the seeds are independent samples, and the power statement names the test run
    assert "Power: every comparison uses the unpaired Mann–Whitney U test" in md
    assert "1 specimen × up to 2 seeds per label the smallest p it can give is 0.33" in md
    assert "Wilcoxon signed-rank" not in md and "paired (specimen, seed)" not in md
    assert "β, γ and δ are not separately identifiable" in md and "| βγ (1/m) | βδ (1/m) |" in md
    # the generic Jacobian/SVD finds the exact scaling invariance and names it
    finding = re.search(
        r"The smallest singular value is σ/σmax = ([0-9.e+-]+), numerically zero.*?"
        r"its direction, ([^,]+), is the tangent of the exact scaling invariance",
        md,
    )
    assert finding, md[md.index("## Identifiability") :][:1500]
    assert float(finding.group(1)) < 1e-6
    assert {"β", "γ", "δ"} <= set(re.findall(r"[βγδ]", finding.group(2)))


@needs_data
def test_moved_data_resume_the_same_study(tiny, tmp_path):
    config, db, _ = tiny
    moved = tmp_path / "elsewhere"
    moved.mkdir()
    for name in BENCHMARK_FILES:
        (moved / name).symlink_to(DATA_DIR / name)
    assert load_study_config(config, data=moved).config_hash == load_study_config(config).config_hash
    resumed = run_compare("--config", config, "--db", db, "--workers", "1", "--data", moved)
    assert resumed.returncode == 0, resumed.stderr
    assert "all 4 runs already in" in resumed.stderr
    with closing(sqlite3.connect(db)) as conn:
        assert dict(conn.execute("SELECT key, value FROM study"))["data_dir"] == str(moved.resolve())


@needs_data
def test_changed_data_are_refused(tiny, tmp_path):
    config, db, _ = tiny
    changed = tmp_path / "changed"
    changed.mkdir()
    for name in BENCHMARK_FILES:
        (changed / name).write_bytes((DATA_DIR / name).read_bytes())
    with open(changed / "test_multisine.csv", "a", encoding="utf-8") as fh:
        fh.write("\n")
    result = run_compare("--config", config, "--db", db, "--workers", "1", "--data", changed)
    assert result.returncode == 2 and "study.data_sha256 changed" in result.stderr


@pytest.mark.parametrize(
    "body, message",
    [
        ('state = "shared"', r"\[study\] state does not apply to problem 'bouc-wen-benchmark' .*: remove it"),
        ('excitation = "sine"', r"\[study\] excitation does not apply to problem 'bouc-wen-benchmark'"),
        ("budgett = 3", r"\[study\] unknown key 'budgett'"),
        ('problem2 = "x"', r"\[study\] unknown key 'problem2'"),
    ],
)
def test_settings_that_do_not_apply_are_refused(tmp_path, body, message):
    with pytest.raises(UserError, match=message):
        load_study_config(write_benchmark_config(tmp_path / "bad.toml", body))


def test_a_specimens_table_is_refused(tmp_path):
    path = write_benchmark_config(tmp_path / "bad.toml", optimizers="random = {}\n[specimens]\nrepeat = [1]")
    with pytest.raises(UserError, match=r"\[specimens\] does not apply to problem 'bouc-wen-benchmark'"):
        load_study_config(path)


@needs_data  # checked after the data folder
def test_posterior_specimens_other_than_train_multisine_are_refused(tmp_path):
    path = write_benchmark_config(
        tmp_path / "bad.toml", optimizers='random = {}\n[posterior]\nspecimens = ["x"]\nbudget = 10'
    )
    with pytest.raises(UserError, match=r'\[posterior\] specimens: .* \["train_multisine"\]'):
        load_study_config(path)


def test_unknown_problem_is_refused(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(
        '[study]\nname = "x"\nseed = 1\nbudget = 5\nseeds = 1\nproblem = "duffing"\n[optimizers]\nrandom = {}\n'
    )
    with pytest.raises(UserError, match=r"\[study\] problem must be one of 'hysteresis', 'bouc-wen-benchmark'"):
        load_study_config(path)


def test_missing_data_folder_is_one_line_saying_where_and_how(tmp_path):
    missing = tmp_path / "no-such-folder"
    result = run_compare(
        "--config", write_benchmark_config(tmp_path / "b.toml"), "--db", tmp_path / "x.sqlite", "--data", missing
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert str(missing) in lines[0] and "--data PATH" in lines[0] and "[study] data" in lines[0]
    assert not (tmp_path / "x.sqlite").exists()


def test_a_database_of_the_old_format_still_resumes_the_same_study(tmp_path):
    from bwbench.database.writer import extension_conflicts

    # quick.toml as it was when such databases were written: 5 seeds, the paper's formulation only
    text = (REPO / "studies" / "quick.toml").read_text(encoding="utf-8")
    text = text.replace("seeds = 4\n", "seeds = 5\n", 1).replace('formulation = ["paper", "identifiable"]\n', "")
    text = text.replace('data = "../data/specimens"', f'data = "{(REPO / "data" / "specimens").as_posix()}"')
    assert "seeds = 5" in text and "formulation" not in text.split("[optimizers]")[0].split("[study]")[1]
    (tmp_path / "quick.toml").write_text(text, encoding="utf-8")
    config = load_study_config(tmp_path / "quick.toml")
    assert config.problem == "hysteresis" and "problem" not in config.to_json_dict()["study"]
    new = config.to_json_dict()
    legacy = {
        **QUICK_LEGACY,
        "optimizers": new["optimizers"],
        "posterior": {k: v for k, v in new["posterior"].items() if k != "sha256"},
    }
    assert extension_conflicts(legacy, new) == []
    fewer = {**legacy, "study": {**legacy["study"], "budget": 4000}}
    assert extension_conflicts(fewer, new) == ["study.budget: 4000 -> 4100"]


def test_naming_the_default_problem_keeps_the_hash(tmp_path):
    text = (
        (REPO / "studies" / "quick.toml")
        .read_text(encoding="utf-8")
        .replace('data = "../data/specimens"', f'data = "{(REPO / "data" / "specimens").as_posix()}"')
    )
    implicit, explicit = tmp_path / "implicit.toml", tmp_path / "explicit.toml"
    implicit.write_text(text, encoding="utf-8")
    explicit.write_text(text.replace("[study]\n", '[study]\nproblem = "switched-bouc-wen"\n', 1), encoding="utf-8")
    assert load_study_config(explicit).config_hash == load_study_config(implicit).config_hash
