"""A study's [posterior] runs nested sampling by default and stores each run's draws and ln Z, which the
reader gives back (a tiny budget: the runs are cut, and the verdict says so)."""

import io
import json
import sqlite3
from contextlib import closing
from pathlib import Path

import numpy as np

from bwbench.database import reader
from bwbench.study.config import load_study_config
from bwbench.study.execute import run_study

DATA = (Path(__file__).resolve().parents[2] / "data" / "specimens").as_posix()


def test_the_default_posterior_is_nested_sampling_and_its_evidence_is_stored(tmp_path):
    toml = tmp_path / "tiny.toml"
    toml.write_text(f"""
[study]
name = "tiny"
seed = 3
budget = 40
seeds = 1
formulation = "identifiable"
data = "{DATA}"
[specimens]
material = ["POM MT24u01"]
underpressure_MPa = [0.01]
repeat = [1]
[optimizers]
random = {{}}
[posterior]
specimens = ["pom-mt24u01_0.01MPa_r1"]
budget = 1200
options = {{ live_points = 20, min_ess = 20 }}
""")
    config = load_study_config(toml)
    assert config.posterior.optimizer == "nested" and config.posterior.options["runs"] == 4
    db = tmp_path / "tiny.sqlite"
    outcome = run_study(config, db, workers=1, log=io.StringIO())
    assert outcome.complete and outcome.errors == 0
    with closing(sqlite3.connect(db)) as conn:
        (stored,) = conn.execute("SELECT evidence_json FROM evidence").fetchone()
        nfev, message = conn.execute("SELECT nfev, message FROM runs WHERE kind = 'posterior'").fetchone()
    evidence = json.loads(stored)
    assert len(evidence["log_z"]) == len(evidence["log_z_err"]) == 4 and evidence["live_points"] == 20
    assert nfev <= 1200 and sum(evidence["run_nfev"]) <= nfev
    assert "not converged" in message
    (chain,) = reader.load_study(db).chains
    assert chain.evidence == evidence and chain.walkers == 4  # the runs side by side
    assert chain.log_prob.shape == chain.samples.shape[:2] and np.all(np.isfinite(chain.log_prob))
