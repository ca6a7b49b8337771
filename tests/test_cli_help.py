"""The command line explains itself: ``--version``, a description and an example under every command's
``--help``, help that imports no numerical library, and ``fit``'s defaults those of ``bwbench.fit``."""

import argparse
import inspect
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import bwbench
from bwbench import cli

SPECIMEN = Path(__file__).resolve().parents[1] / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"
HEAVY = ("numpy", "scipy", "pandas", "numba", "matplotlib")


def run(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bwbench.cli", *argv], capture_output=True, text=True)


def commands() -> list[tuple[str, ...]]:
    """Every command and subcommand, as the words that name it."""
    found = []
    for name in cli.COMMANDS:
        parser = cli.build_parser(name)
        command = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[name]
        subs = [a for a in command._actions if isinstance(a, argparse._SubParsersAction)]
        found += [(name, sub) for action in subs for sub in action.choices] or [(name,)]
    return found


def test_version_prints_the_version():
    done = run("--version")
    assert done.returncode == 0 and done.stdout.strip() == f"bwbench {bwbench.__version__}"


def test_every_command_and_subcommand_is_listed():
    assert ("data", "check") in commands() and ("data", "generate") in commands() and ("report",) in commands()
    assert len(commands()) == len(cli.COMMANDS) + 1


@pytest.mark.parametrize("words", commands(), ids=" ".join)
def test_every_help_has_a_description_and_an_example(words, capsys):
    with pytest.raises(SystemExit) as stop:
        cli.main([*words, "--help"])
    assert stop.value.code == 0
    text = capsys.readouterr().out
    usage, _, rest = text.partition("\n\n")
    description = rest.split("\n\n")[0]
    assert usage.startswith(f"usage: bwbench {' '.join(words)}") and len(description.split()) >= 4, text
    assert not description.startswith(("positional arguments", "options")), text
    assert f"example:\n  bwbench {' '.join(words)}" in text, text


@pytest.mark.parametrize(
    "argv",
    [
        ["--help"],
        ["report", "--help"],
        ["compare", "--help"],
        ["data", "check", "--help"],
        ["models", "--help"],
        ["optimizers", "--help"],
    ],
)
def test_help_imports_no_numerical_library(argv):
    probe = (
        "import sys, contextlib, io\nfrom bwbench import cli\n"
        f"with contextlib.suppress(SystemExit), contextlib.redirect_stdout(io.StringIO()): cli.main({argv!r})\n"
        f"print([m for m in {HEAVY!r} if m in sys.modules])"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.strip() == "[]", done.stdout + done.stderr


def test_fit_defaults_are_the_apis_and_help_states_them(tmp_path):
    api = inspect.signature(bwbench.fit).parameters
    args = cli.build_parser("fit").parse_args(["fit", "s.csv", "--out", "r.json"])
    for name in ("optimizer", "budget", "seed", "weighting", "threads"):
        assert getattr(args, name) == api[name].default, name
    assert args.formulation is None and api["formulation"].default is None  # both: the model's own
    text = run("fit", "--help").stdout
    assert "default lsq-trf" in text and "default 4100" in text and "identifiable" in text


def test_fit_without_optimizer_runs_lsq_trf(tmp_path):
    shutil.copy(SPECIMEN, tmp_path / "s.csv")
    done = subprocess.run(
        [sys.executable, "-m", "bwbench.cli", "fit", "s.csv", "--budget", "40", "--out", "r.json"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "r.json").read_text())
    # s.csv has no manifest beside it: not the paper's specimen, so the identifiable formulation
    assert result["optimizer"] == "lsq-trf" and result["nfev"] == 40 and result["formulation"] == "identifiable"
