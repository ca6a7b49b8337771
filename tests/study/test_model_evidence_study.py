"""A study comparing models with a [posterior]: every model's posterior is sampled, read back in its own
model's coordinates, and weighed by its evidence (end to end, small budgets)."""

import io

import numpy as np
import pytest

from bwbench.database import reader
from bwbench.problems.hysteresis.report import model_evidence
from bwbench.problems.hysteresis.report.posterior_draws import posterior_chains
from bwbench.study.config import load_study_config
from bwbench.study.execute import run_study
from robustness_helpers import REPO

SPECIMEN = "mr_10mm_5Hz_0V"  # 300 samples of an MR-damper test made from Spencer's model


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    folder = tmp_path_factory.mktemp("evidence")
    path = folder / "evidence.toml"
    path.write_text(f"""[study]
name = "evidence"
seed = 5
budget = 60
seeds = 1
model = ["switched-bouc-wen", "bouc-wen"]
formulation = "identifiable"

[specimens]
files = ["{REPO}/data/mr_damper/{SPECIMEN}.csv"]

[optimizers]
random = {{}}

[posterior]
budget = 3000
options = {{ runs = 2, live_points = 20, min_ess = 10 }}
""")
    outcome = run_study(load_study_config(path), folder / "evidence.sqlite", workers=1, log=io.StringIO())
    assert outcome.complete and outcome.errors == 0
    return reader.load_study(folder / "evidence.sqlite")


def test_each_model_is_sampled_and_read_in_its_own_coordinates(study):
    chains = {pc.chain.optimizer: pc for pc in posterior_chains(study)}
    assert set(chains) == {"nested [switched-bouc-wen]", "nested [bouc-wen]"}
    assert chains["nested [bouc-wen]"].problem.model.name == "bouc-wen"
    assert list(chains["nested [bouc-wen]"].names) == ["xy", "n", "eta"]
    assert chains["nested [switched-bouc-wen]"].problem.model.name == "switched-bouc-wen"


def test_the_evidence_table_weighs_the_models_of_the_specimen(study):
    frame = model_evidence.table(posterior_chains(study), study=study)
    assert sorted(frame["model"]) == ["bouc-wen", "switched-bouc-wen"]
    assert (frame["specimen"] == SPECIMEN).all()
    assert sorted(frame["ln B against the best"])[-1] == 0.0 and frame["ln B against the best"].min() < 0
    assert np.all(np.isfinite(frame["ln Z"])) and np.all(frame["±"] > 0)
    # the bound holds: no ln Z above its model's best log-likelihood
    assert np.all(frame["ln Z"] <= frame["best log-likelihood"])
    assert np.all((frame["outside"] >= 0) & (frame["outside"] <= 1))
