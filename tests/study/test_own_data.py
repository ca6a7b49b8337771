"""A user's own files, end to end: no manifest, no TOML (``compare --specimens``) or a TOML with
``[specimens] files``, run from another working folder; studies extended, edited data refused."""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
import subprocess
import sys
from contextlib import closing
from pathlib import Path

import pytest

from bwbench.datasets import mr_damper
from bwbench.errors import UserError
from bwbench.study.config import load_study_config

REPO = Path(__file__).resolve().parents[2]
SYNTHETIC = REPO / "data" / "specimens"


def bwbench(*args, cwd):
    """The installed command, as a user types it, from ``cwd``."""
    return subprocess.run(
        [sys.executable, "-m", "bwbench.cli", *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=600
    )


def runs(db) -> list:
    with closing(sqlite3.connect(db)) as conn:
        return conn.execute("SELECT specimen, optimizer, replicate, status FROM runs ORDER BY 1, 2, 3").fetchall()


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A user's folder: two specimens copied without their manifest, and an MR-damper sine test
    (Spencer et al. 1997 model: ±25 mm at 2 Hz, ±1.2 kN, 500 Hz) our model did not generate."""
    folder = tmp_path_factory.mktemp("lab")
    (folder / "tests").mkdir()
    for name in ("pom-mt24u01_0.01MPa_r1", "pom-mt24u01_0.09MPa_r1"):
        shutil.copy(SYNTHETIC / f"{name}.csv", folder / "tests" / f"{name}.csv")
    mr_damper.write_test(
        folder / "tests" / "mr_damper_2hz.csv",
        amplitude_mm=25.0,
        frequency_hz=2.0,
        rate_hz=500.0,
        cycles=2,
        peak_force_N=1200.0,
        rng=7,
    )
    return folder


def test_compare_and_report_on_own_files_with_no_manifest_from_another_folder(lab, tmp_path):
    work = tmp_path / "elsewhere"
    work.mkdir()
    files = [lab / "tests" / "pom-mt24u01_0.01MPa_r1.csv", lab / "tests" / "mr_damper_2hz.csv"]
    result = bwbench(
        "compare",
        "--specimens",
        *files,
        "--optimizers",
        "cmaes,random",
        "--seeds",
        "2",
        "--budget",
        "150",
        "--workers",
        "1",
        cwd=work,
    )
    assert result.returncode == 0, result.stderr
    db = work / "study.sqlite"  # the default database is in the current folder
    assert db.is_file() and not (REPO / "study.sqlite").exists()
    got = runs(db)
    assert len(got) == 2 * 2 * 2 and {r[3] for r in got} == {"ok"}
    assert {r[0] for r in got} == {"pom-mt24u01_0.01MPa_r1", "mr_damper_2hz"}

    report = bwbench("report", "--db", db, "--out", "rep", "--profiles", "0", cwd=work)
    assert report.returncode == 0, report.stderr
    md = (work / "rep" / "report.md").read_text(encoding="utf-8")
    assert "No manifest.json beside the specimens" in md and "SYNTHETIC" not in md
    assert "| mr_damper_2hz | 501 | 500 | 1 | -25 … 25 |" in md  # read from the file: samples, rate, duration
    assert "underpressure" not in md.split("## Figures")[1].split("## Identified")[0]  # no invented figure
    assert "## Identified parameters per specimen" in md and "| mr_damper_2hz |" in md.split("## Identified")[1]


def test_a_toml_with_files_resolves_paths_against_its_folder(lab, tmp_path):
    study = lab / "studies"
    study.mkdir(exist_ok=True)
    toml = study / "mine.toml"
    toml.write_text(
        """
[study]
name = "mine"
seed = 1
budget = 120
seeds = 1
[specimens]
files = ["../tests/pom-*.csv"]
[optimizers]
random = {}
""",
        encoding="utf-8",
    )
    result = bwbench("compare", "--config", toml, "--workers", "1", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert (study / "mine.sqlite").is_file()  # the default database is next to the TOML
    assert {r[0] for r in runs(study / "mine.sqlite")} == {"pom-mt24u01_0.01MPa_r1", "pom-mt24u01_0.09MPa_r1"}
    # an equivalent spelling of the same files is the same study
    other = study / "same.toml"
    other.write_text(
        toml.read_text().replace(
            '"../tests/pom-*.csv"',
            f'"{(lab / "studies" / ".." / "tests").as_posix()}/'
            'pom-mt24u01_0.01MPa_r1.csv", "../tests/pom-mt24u01_0.09MPa_r1.csv"',
        )
    )
    assert load_study_config(other).config_hash == load_study_config(toml).config_hash


def test_a_study_is_extended_and_edited_data_are_refused(lab, tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    shutil.copy(lab / "tests" / "pom-mt24u01_0.01MPa_r1.csv", data / "a.csv")
    shutil.copy(lab / "tests" / "mr_damper_2hz.csv", data / "b.csv")
    base = ["compare", "--specimens", "a.csv", "--budget", "60", "--workers", "1"]
    assert bwbench(*base, "--optimizers", "random", "--seeds", "1", cwd=data).returncode == 0
    assert runs(data / "study.sqlite") == [("a", "random", 0, "ok")]
    before = runs(data / "study.sqlite")
    # more seeds, another backend and another specimen: only the new runs run
    more = bwbench(
        "compare",
        "--specimens",
        "a.csv",
        "b.csv",
        "--budget",
        "60",
        "--workers",
        "1",
        "--optimizers",
        "random,cmaes",
        "--seeds",
        "2",
        cwd=data,
    )
    assert more.returncode == 0, more.stderr
    assert "extends the study" in more.stderr and "1 already in" in more.stderr
    after = runs(data / "study.sqlite")
    assert len(after) == 2 * 2 * 2 and set(before) <= set(after)
    # a changed budget is another study
    changed = bwbench(*base, "--optimizers", "random", "--seeds", "1", "--budget", "61", cwd=data)
    assert changed.returncode == 2 and "study.budget" in changed.stderr.replace("60 -> 61", "")
    # the same path with other bytes is other data
    with open(data / "a.csv", "a", encoding="utf-8") as fh:
        fh.write("1921.0,0.1,0.0,0.2\n")  # time, displacement, velocity, force
    edited = bwbench(*base, "--optimizers", "random", "--seeds", "1", cwd=data)
    assert edited.returncode == 2 and "specimen a: its data changed" in edited.stderr
    assert runs(data / "study.sqlite") == after  # nothing written


@pytest.mark.parametrize(
    "body, message",
    [
        ('[specimens]\nfiles = ["nope/*.csv"]', "matches no file"),
        ('[specimens]\nfiles = ["missing.csv"]', "missing.csv: no such file"),
        ("[specimens]\nfiles = []", "must be a non-empty list"),
        ('[specimens]\nfiles = ["a.csv"]\nrepeat = [1]', "remove [study] data and the manifest filters"),
        ('[specimens]\nfiles = ["a.csv"]\n[bounds]\n"n+" = [0.0, 3.0]', "lower must be > 0"),
        ('[specimens]\nfiles = ["a.csv"]\n[bounds]\n"wn+" = [3.0, 1.0]', "lower 3 must be below upper 1"),
        ('[specimens]\nfiles = ["a.csv"]\n[bounds]\nomega = [1.0, 2.0]', "unknown parameter 'omega'"),
        ("", "no specimens: list them with [specimens] files"),
    ],
)
def test_bad_specimen_lists_and_bounds_are_one_line(tmp_path, body, message):
    shutil.copy(SYNTHETIC / "pom-mt24u01_0.01MPa_r1.csv", tmp_path / "a.csv")
    toml = tmp_path / "bad.toml"
    toml.write_text(
        f'[study]\nname = "x"\nseed = 1\nbudget = 10\nseeds = 1\nformulation = "paper"\n[optimizers]\nrandom = {{}}\n'
        f"{body}\n"
    )
    with pytest.raises(
        UserError,
        match=r"bad\.toml: .*"
        + message.replace("[", r"\[").replace("]", r"\]").replace("(", r"\(").replace("+", r"\+"),
    ):
        load_study_config(toml)


def test_two_files_of_one_name_and_a_bad_file_are_refused_before_any_run(tmp_path):
    (tmp_path / "x").mkdir()
    shutil.copy(SYNTHETIC / "pom-mt24u01_0.01MPa_r1.csv", tmp_path / "a.csv")
    shutil.copy(SYNTHETIC / "pom-mt24u01_0.01MPa_r1.csv", tmp_path / "x" / "a.csv")
    twice = bwbench("compare", "--specimens", "a.csv", "x/a.csv", "--optimizers", "random", cwd=tmp_path)
    assert twice.returncode == 2 and "two specimens are named 'a'" in twice.stderr
    (tmp_path / "bad.csv").write_text("time_s,displacement_mm,force_N\n0,1,2\n", encoding="utf-8")
    bad = bwbench("compare", "--specimens", "a.csv", "bad.csv", "--optimizers", "random", cwd=tmp_path)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "bad.csv:" in bad.stderr
    assert not (tmp_path / "study.sqlite").exists()


def test_bounds_file_sets_the_box_of_a_study(tmp_path):
    shutil.copy(SYNTHETIC / "pom-mt24u01_0.01MPa_r1.csv", tmp_path / "a.csv")
    (tmp_path / "box.json").write_text('{"xi-": [-30.0, -25.0], "A+": [0.02, 0.021]}', encoding="utf-8")
    result = bwbench(
        "compare",
        "--specimens",
        "a.csv",
        "--optimizers",
        "random",
        "--seeds",
        "1",
        "--budget",
        "50",
        "--bounds",
        "box.json",
        "--formulation",
        "paper",
        "--workers",
        "1",
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    with closing(sqlite3.connect(tmp_path / "study.sqlite")) as conn:
        params = json.loads(conn.execute("SELECT params_json FROM runs").fetchone()[0])
    xi, a = params["xi-"], params["A+"]
    assert -30.0 <= xi <= -25.0 and 0.02 <= a <= 0.021
    (tmp_path / "bad.json").write_text('{"xi-": [-30.0]}', encoding="utf-8")
    bad = bwbench(
        "compare",
        "--specimens",
        "a.csv",
        "--optimizers",
        "random",
        "--bounds",
        "bad.json",
        "--formulation",
        "paper",
        cwd=tmp_path,
    )
    assert bad.returncode == 2 and "bad.json: bounds of xi- must be [lower, upper]" in bad.stderr


def test_specimens_without_optimizers_is_one_line(tmp_path):
    result = bwbench("compare", "--specimens", "a.csv", cwd=tmp_path)
    assert result.returncode == 2 and "--specimens needs --optimizers" in result.stderr
    assert os.listdir(tmp_path) == []
