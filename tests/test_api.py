"""The Python API (bwbench.fit, load_fit, load_study): the README's example runs as written, and
`import bwbench` stays cheap."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import bwbench

REPO = Path(__file__).resolve().parents[1]


def readme_example() -> str:
    text = (REPO / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Python API"):]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_readme_example_runs_as_written(tmp_path, monkeypatch, capsys):
    shutil.copy(REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv", tmp_path / "s.csv")
    study = subprocess.run([sys.executable, "-m", "bwbench.cli", "compare", "--specimens", "s.csv", "--optimizers",
                            "random,cmaes", "--seeds", "1", "--budget", "30", "--workers", "2", "--db", "study.sqlite"],
                           cwd=tmp_path, capture_output=True, text=True)
    assert study.returncode == 0, study.stderr
    monkeypatch.chdir(tmp_path)
    namespace = {}
    exec(compile(readme_example(), "README.md (Python API)", "exec"), namespace)
    out = capsys.readouterr().out
    fit, p = namespace["fit"], namespace["p"]
    assert list(fit.table()["specimen"]) == ["a", "b"] and fit.nfev == 300
    assert 0 < p.nrmse < 0.05 and f"NRMSE {p.nrmse:.4f}" in out  # Spencer's model on its own generator's test
    assert (tmp_path / "fit.json").is_file() and len(namespace["frame"]) == 1001  # 3 cycles at 1.5 Hz, 500 Hz
    assert set(namespace["best"].index) == {"random", "cmaes"}


def test_import_bwbench_loads_no_numerical_library_and_the_api_is_documented():
    probe = ("import sys, bwbench; heavy = [m for m in ('numpy', 'scipy', 'pandas', 'numba', 'matplotlib') "
             "if m in sys.modules]; print(heavy)")
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
