"""The report's "Posterior samplers" table and model-evidence table on a fixture study whose specimen has
two posteriors, a nested one (two modes of masses 0.7/0.3, written by ``test_nested_posterior_report``)
and the fixture's emcee chain around the truth, which lies in the heavier mode only."""

import re
import sqlite3
from contextlib import closing

import numpy as np
import pytest

from problems.hysteresis.report import test_nested_posterior_report as nested_fixture
from study_fixture import make_study_db

TABLES = ("runs", "timings", "chains")


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    from bwbench.report import build

    folder = tmp_path_factory.mktemp("samplers")
    db = make_study_db(folder / "study.sqlite")
    with closing(sqlite3.connect(db)) as conn:  # the emcee posterior, kept aside
        saved = {t: conn.execute(f"SELECT * FROM {t} WHERE kind = 'posterior'").fetchall() for t in TABLES}
        columns = {t: [c[1] for c in conn.execute(f"PRAGMA table_info({t})")] for t in TABLES}
    nested_fixture.nested_posterior(db, np.random.default_rng(5))
    with closing(sqlite3.connect(db)) as conn:
        for table in TABLES:
            for row in saved[table]:
                values = dict(zip(columns[table], row), optimizer="emcee")
                conn.execute(
                    f"INSERT INTO {table} ({', '.join(values)}) VALUES ({', '.join('?' * len(values))})",
                    list(values.values()),
                )
        conn.commit()
    build.build_report(db, folder / "report", profile_params=0)
    return (folder / "report" / "report.md").read_text(encoding="utf-8")


def test_the_samplers_table_finds_the_missed_mode(report):
    part = report.split("### Posterior samplers")[1]
    assert "| sampler | finds every mode | mass in each mode | R̂/ESS verdict | evaluations | wall time (s) |" in part
    nested = re.search(r"^\| nested \(reference\) \| yes \(2 of 2\) \| mode 1: 0\.[67]\d \(reference", part, flags=re.M)
    emcee = re.search(
        r"^\| emcee \| no: misses mode 2 \(1 of 2\) \| mode 1: 0\.\d\d .*; mode 2: 0\.00 \(reference 0\.[23]",
        part,
        flags=re.M,
    )
    assert nested and emcee


def test_the_evidence_table_has_its_columns_and_its_checks(report):
    part = report.split("### Model evidence")[1]
    assert "| model | ln Z | ± | ln B against the best | specimen | Δ ln Z, every box ×2 |" in part
    row = re.search(
        r"^\| switched-bouc-wen \| (-?\d+\.\d\d) \| \d+\.\d\d \| \+0\.00 \| pom-mt24u01_0\.01MPa_r1 \| "
        r"(-\d+\.\d) \| (-?\d+\.\d) \| (\d+\.\d) % \|",
        part,
        flags=re.M,
    )
    assert row, part[:1500]
    # (the fixture's ln Z is made up, −10 in the sampler's units: it is not checked against the bound here)
    # the fixture's draws sit at the truth: the measured force stays inside the band at about 95 % of samples
    assert float(row[4]) < 20.0
    assert "one model (switched-bouc-wen), nothing to weigh it against" in part
