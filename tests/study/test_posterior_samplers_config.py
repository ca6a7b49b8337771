"""[posterior] with several samplers (``optimizer = ["nested", "emcee"]``) and a study comparing models:
every sampler on every model's posterior, each with its options; bad input is one line, exit status 2."""

import pytest

from bwbench.commands.compare import run_cli
from bwbench.errors import UserError
from bwbench.study.config import load_study_config, planned_runs
from bwbench.study.tasks import plan_tasks
from robustness_helpers import REPO

SPECIMEN = "pom-mt24u01_0.05MPa_r1"


def write(tmp_path, posterior: str, study: str = "") -> str:
    path = tmp_path / "s.toml"
    path.write_text(f"""[study]
name = "s"
seed = 1
budget = 100
seeds = 1
{study}
[specimens]
files = ["{REPO}/data/specimens/{SPECIMEN}.csv"]

[optimizers]
random = {{}}

[posterior]
budget = 5000
{posterior}
""")
    return str(path)


def test_several_samplers_each_get_their_posterior_options_and_a_run(tmp_path):
    config = load_study_config(
        write(tmp_path, 'optimizer = ["nested", "emcee"]\noptions = { emcee = { n_walkers = 32 } }')
    )
    backends = dict(config.posterior.backends)
    assert list(backends) == ["nested", "emcee"]
    assert backends["emcee"]["n_walkers"] == 32 and backends["emcee"]["start"] == "optima"  # on top of the defaults
    assert backends["nested"]["runs"] == 4
    posterior = [t for t in plan_tasks(config) if t.kind == "posterior"]
    assert [(t.optimizer, t.budget) for t in posterior] == [("nested", 5000), ("emcee", 5000)]
    stored = config.to_json_dict()["posterior"]
    assert stored["optimizer"] == ["nested", "emcee"] and stored["options"]["emcee"]["n_walkers"] == 32


def test_one_sampler_is_stored_as_before(tmp_path):
    config = load_study_config(write(tmp_path, 'optimizer = "emcee"\noptions = { n_walkers = 32 }'))
    stored = config.to_json_dict()["posterior"]
    assert stored["optimizer"] == "emcee" and stored["options"]["n_walkers"] == 32
    assert config.posterior.backends == (("emcee", config.posterior.options),)


def test_a_study_comparing_models_samples_every_model_with_every_sampler(tmp_path):
    config = load_study_config(
        write(
            tmp_path,
            'optimizer = ["nested", "emcee"]',
            'model = ["switched-bouc-wen", "spencer", "bouc-wen"]\nformulation = "identifiable"',
        )
    )
    posterior = [t.optimizer for t in plan_tasks(config) if t.kind == "posterior"]
    assert posterior == [
        f"{s} [{m}]" for m in ("switched-bouc-wen", "spencer", "bouc-wen") for s in ("nested", "emcee")
    ]
    assert planned_runs(config) == 3 + 6
    from bwbench.database.plan import planned_from_config  # a stored configuration counts the same

    assert planned_from_config(config.to_json_dict()) == 3 + 6


def test_a_model_in_two_formulations_is_sampled_in_the_last_one(tmp_path):
    config = load_study_config(
        write(tmp_path, "", 'model = ["spencer", "bouc-wen"]\nformulation = ["direct", "identifiable"]')
    )
    posterior = [t.optimizer for t in plan_tasks(config) if t.kind == "posterior"]
    assert posterior == ["nested [spencer identifiable]", "nested [bouc-wen identifiable]"]


@pytest.mark.parametrize(
    "posterior, message",
    [
        ('optimizer = ["nested", "nested"]', r"\[posterior\] optimizer names a backend twice"),
        ("optimizer = []", r"\[posterior\] optimizer must be a backend name or a non-empty list"),
        ('optimizer = ["nested", 3]', r"\[posterior\] optimizer must be a backend name or a non-empty list"),
        ('optimizer = ["nested", "emce"]', r"\[posterior\] optimizer: unknown optimiser 'emce'"),
        (
            'optimizer = ["nested", "emcee"]\noptions = { runs = 2 }',
            r"\[posterior\] options: with several samplers, one "
            r"table per sampler",
        ),
        (
            'optimizer = ["nested", "emcee"]\noptions = { cmaes = {} }',
            r"\[posterior\] options: 'cmaes' is not one of the "
            r"samplers \(nested, emcee\)",
        ),
        ('optimizer = ["nested", "emcee"]\noptions = { nested = { runz = 2 } }', r"\[posterior\] options nested"),
    ],
)
def test_bad_samplers_name_the_file_and_the_key(tmp_path, posterior, message):
    with pytest.raises(UserError, match=r"s\.toml: " + message):
        load_study_config(write(tmp_path, posterior))


def test_bad_samplers_exit_2_with_one_line_before_any_run(tmp_path, capsys):
    path = write(tmp_path, 'optimizer = ["nested", "nested"]')
    assert run_cli(["--config", path, "--db", str(tmp_path / "s.sqlite")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "[posterior] optimizer names a backend twice" in err
    assert not (tmp_path / "s.sqlite").exists()
