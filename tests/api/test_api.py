"""The Python API (bwbench.fit, load_fit, load_study): the README's example runs as written, and
`import bwbench` stays cheap."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import bwbench

REPO = Path(__file__).resolve().parents[2]


def readme_example() -> str:
    text = (REPO / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Python API") :]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_readme_example_runs_as_written(tmp_path, monkeypatch, capsys):
    shutil.copy(REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv", tmp_path / "s.csv")
    study = subprocess.run(
        [
            sys.executable,
            "-m",
            "bwbench.cli",
            "compare",
            "--specimens",
            "s.csv",
            "--optimizers",
            "random,cmaes",
            "--seeds",
            "1",
            "--budget",
            "30",
            "--workers",
            "2",
            "--db",
            "study.sqlite",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert study.returncode == 0, study.stderr
    monkeypatch.chdir(tmp_path)
    namespace = {}
    exec(compile(readme_example(), "README.md (Python API)", "exec"), namespace)
    out = capsys.readouterr().out
    fit, p = namespace["fit"], namespace["p"]
    # at most the budget: the joint fit stops earlier once its searches agree (240 of 300 measured)
    assert list(fit.table()["specimen"]) == ["a", "b"] and fit.nfev <= 300
    assert 0 < p.nrmse < 0.05 and f"NRMSE {p.nrmse:.4f}" in out  # Spencer's model on its own generator's test
    assert (tmp_path / "fit.json").is_file() and len(namespace["frame"]) == 1001  # 3 cycles at 1.5 Hz, 500 Hz
    assert set(namespace["best"].index) == {"random", "cmaes"}


def test_import_bwbench_loads_no_numerical_library_and_the_api_is_documented():
    probe = (
        "import sys, bwbench; heavy = [m for m in ('numpy', 'scipy', 'pandas', 'numba', 'matplotlib') "
        "if m in sys.modules]; print(heavy)"
    )
    assert subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True).stdout.strip() == "[]"
    for name in ("fit", "load_fit", "load_study", "FitResult", "FittedModel", "Prediction"):
        assert name in bwbench.__all__ and getattr(bwbench, name).__doc__, name
    with pytest.raises(AttributeError):
        bwbench.not_a_thing  # noqa: B018


def test_bad_input_is_a_user_error_naming_it(tmp_path):
    from bwbench.errors import UserError

    with pytest.raises(UserError, match="no such file|not found|No such"):
        bwbench.fit(tmp_path / "missing.csv")
    with pytest.raises(UserError, match="unknown model"):
        bwbench.fit(REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv", model="nope")
    (tmp_path / "p.json").write_text('{"A+": 1}')
    with pytest.raises(UserError, match="not a fit result"):
        bwbench.load_fit(tmp_path / "p.json")


# -- the API holds to the command line's promises: every bad input is a UserError with the CLI's words --------
SPECIMEN = REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"
MR = REPO / "data" / "mr_damper" / "mr_10mm_2Hz_1V.csv"
BAD_FITS = [
    ("fix_mass=-1", dict(formulation="identifiable", fix_mass=-1), "--fix-mass must be 'auto', 'fit' or a mass"),
    ("state split with Spencer", dict(model="spencer", state="split"), "--state does not apply to model 'spencer'"),
    ("fix_mass with Spencer", dict(model="spencer", fix_mass=0.0), "--fix-mass does not apply to model 'spencer'"),
    ("model ''", dict(model=""), "--model must be a model name"),
    ("an unknown model", dict(model="nope"), "nope"),
    ("state 'sideways'", dict(state="sideways"), "--state must be one of 'shared', 'split'"),
    ("excitation 'chirp'", dict(excitation="chirp"), "--excitation must be one of"),
    ("budget 0", dict(budget=0), "--budget must be a positive number of evaluations"),
    ("budget 'many'", dict(budget="many"), "--budget must be a positive number of evaluations"),
    ("seed -1", dict(seed=-1), "--seed must be a non-negative integer"),
    ("an unknown optimizer", dict(optimizer="nope"), "nope"),
    ("options a list", dict(options=[1]), "options must be a dict"),
    ("bounds a number", dict(bounds=3), "bounds must be a dict"),
    ("weighting 'heavy'", dict(weighting="heavy"), "--weighting must be one of 'equal', 'samples'"),
    ("threads 999", dict(threads=999), "--threads must be 1 to"),
]


@pytest.mark.parametrize("case", BAD_FITS, ids=[c[0] for c in BAD_FITS])
def test_a_bad_argument_of_fit_is_a_user_error_with_the_cli_words(case):
    _, kwargs, words = case
    with pytest.raises(bwbench.errors.UserError, match=re.escape(words)):
        bwbench.fit(SPECIMEN, **{"optimizer": "random", "budget": 5, **kwargs})


def test_the_api_refuses_one_file_twice_by_identity(tmp_path):
    shutil.copy(SPECIMEN, tmp_path / "a.csv")
    (tmp_path / "b.csv").symlink_to(tmp_path / "a.csv")
    for second in (tmp_path / "a.csv", tmp_path / "b.csv", str(tmp_path / "." / "a.csv")):
        with pytest.raises(bwbench.errors.UserError, match="a specimen is named twice"):
            bwbench.fit(tmp_path / "a.csv", second, optimizer="random", budget=5)


def test_the_api_refuses_a_dead_velocity_channel_naming_file_and_column(tmp_path):
    lines = SPECIMEN.read_text().splitlines()
    j = lines[0].split(",").index("velocity_mm_s")
    rows = [line.split(",") for line in lines[1:]]
    for row in rows:
        row[j] = "0"
    (tmp_path / "dead.csv").write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    with pytest.raises(bwbench.errors.UserError, match=r"dead.csv: column velocity_mm_s is 0 in every row"):
        bwbench.fit(tmp_path / "dead.csv", model="spencer", optimizer="random", budget=5)


def test_fit_result_save_refuses_the_fits_own_input_and_leaves_it_byte_identical(tmp_path):
    shutil.copy(SPECIMEN, tmp_path / "s.csv")
    before = (tmp_path / "s.csv").read_bytes()
    result = bwbench.fit(tmp_path / "s.csv", optimizer="random", budget=5)
    for spelling in (tmp_path / "s.csv", str(tmp_path / "." / "s.csv")):
        with pytest.raises(bwbench.errors.UserError, match="is an input of this command"):
            result.save(spelling)
    assert (tmp_path / "s.csv").read_bytes() == before
    result.save(tmp_path / "fit.json")
    assert bwbench.load_fit(tmp_path / "fit.json").model == "switched-bouc-wen"


@pytest.mark.parametrize(
    "call, words",
    [
        (lambda: bwbench.load_fit(3), "load_fit needs the path"),
        (lambda: bwbench.load_study(None), "load_study: db must be a path"),
        (lambda: bwbench.FittedModel("spencer", "direct", []), '"params" is []'),
        (lambda: bwbench.FittedModel("spencer", "direct", {}, excitation="chirp"), "\"excitation\" is 'chirp'"),
    ],
    ids=["load_fit a number", "load_study None", "params a list", "excitation chirp"],
)
def test_the_other_api_calls_raise_user_errors(call, words):
    with pytest.raises(bwbench.errors.UserError, match=re.escape(words)):
        call()


def test_predict_refuses_something_that_is_not_a_file(tmp_path):
    result = bwbench.fit(SPECIMEN, optimizer="random", budget=5)
    with pytest.raises(bwbench.errors.UserError, match="a test is a specimen CSV's path"):
        result.predict(42)
