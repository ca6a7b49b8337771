"""No output of a command may be one of its inputs: every output flag of every command, pointed at every
input of that command by every spelling (the same name, ``./``, ``../``, absolute, a hard link, a
symlink), is one line ``error: ...``, exit status 2, before any work, every file byte-identical.

Run in-process: each case is refused before any fit runs (a hang here would be a bug of its own; the
subprocess sweep with its hang guard is ``tests/test_hostile_sweep.py``).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
from pathlib import Path

import pytest

from bwbench import cli
from bwbench.datasets.synthetic import PAPER_PARAMETERS

REPO = Path(__file__).resolve().parents[1]
NAME = "pom-mt24u01_0.01MPa_r1.csv"
SPECIMENS = REPO / "data" / "specimens"
OUTPUT_DESTS = {"out", "plot", "db", "csv"}  # the argparse destinations of every output flag ...
READ_ONLY = {(("report",), "--db")}  # ... except where the command only reads that file


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A folder with a specimen and its manifest, parameters, a box, a study TOML and a finished study."""
    lab = tmp_path_factory.mktemp("lab")
    shutil.copy(SPECIMENS / NAME, lab / NAME)
    manifest = json.loads((SPECIMENS / "manifest.json").read_text())
    (lab / "manifest.json").write_text(json.dumps(manifest))
    truth = next(row["truth"] for row in manifest["specimens"] if row["file"] == NAME)
    (lab / "p.json").write_text(json.dumps(truth))
    shutil.copy(SPECIMENS / NAME, lab / "held.csv")  # a held-out test (predict, compare --validate)
    (lab / "box.json").write_text(json.dumps({"xi+": [1.0, 50.0]}))
    (lab / "cfg.toml").write_text(
        f'[study]\nname = "c"\nseed = 1\nbudget = 20\nseeds = 1\n'
        f'[specimens]\nfiles = ["{NAME}"]\n[optimizers]\nrandom = {{}}\n'
    )
    cwd = os.getcwd()
    os.chdir(lab)
    try:
        assert (
            cli.main(
                [
                    "compare",
                    "--specimens",
                    NAME,
                    "--optimizers",
                    "random",
                    "--seeds",
                    "1",
                    "--budget",
                    "20",
                    "--workers",
                    "1",
                    "--db",
                    "study.sqlite",
                ]
            )
            == 0
        )
        assert (
            cli.main(
                [
                    "fit",
                    NAME,
                    "--optimizer",
                    "random",
                    "--budget",
                    "20",
                    "--formulation",
                    "identifiable",
                    "--out",
                    "fit.json",
                ]
            )
            == 0
        )
    finally:
        os.chdir(cwd)
    return lab


# command -> (argv with {outputs} placeholders filled per case, {output flag: [inputs it may not be]})
FILES = {
    ("simulate",): (
        ["simulate", "--params", "p.json", "--specimen", NAME, "--out", "sim.csv"],
        {"--out": ["p.json", NAME]},
    ),
    ("fit",): (
        [
            "fit",
            NAME,
            "--optimizer",
            "random",
            "--budget",
            "20",
            "--bounds",
            "box.json",
            "--out",
            "r.json",
            "--plot",
            "r.png",
        ],
        {"--out": [NAME, "box.json"], "--plot": [NAME, "box.json"]},
    ),
    ("predict",): (
        ["predict", "--fit", "fit.json", NAME, "held.csv", "--out", "pred.json", "--plot", "pred.png"],
        {"--out": ["fit.json", NAME, "held.csv"], "--plot": ["fit.json", "held.csv"]},
    ),
    ("compare", "--specimens"): (
        [
            "compare",
            "--specimens",
            NAME,
            "--optimizers",
            "random",
            "--seeds",
            "1",
            "--budget",
            "20",
            "--bounds",
            "box.json",
            "--workers",
            "1",
            "--db",
            "new.sqlite",
            "--csv",
            "runs.csv",
            "--validate",
            "held.csv",
        ],
        {
            "--db": [NAME, "box.json", "manifest.json", "held.csv"],
            "--csv": [NAME, "box.json", "manifest.json", "held.csv"],
        },
    ),
    ("compare", "--config"): (
        ["compare", "--config", "cfg.toml", "--workers", "1", "--db", "new.sqlite", "--csv", "runs.csv"],
        {"--db": ["cfg.toml", NAME, "manifest.json"], "--csv": ["cfg.toml", NAME, "manifest.json"]},
    ),
}
# Commands whose output is a folder: the folder may not be an input, nor hold an input it could overwrite.
FOLDERS = {
    ("report",): (["report", "--db", "study.sqlite", "--out", "report"], {"--out": ["study.sqlite", "."]}),
    ("data", "generate"): (["data", "generate", "--out", "specimens"], {"--out": [str(PAPER_PARAMETERS.parent)]}),
}
SPELLINGS = ["same", "dot", "up", "absolute", "hardlink", "symlink"]


def spell(lab: Path, target: str, how: str) -> str:
    """``target`` (relative to ``lab``, or absolute) written another way, or a link to it."""
    path = Path(target) if Path(target).is_absolute() else lab / target
    if how == "same":
        return target
    if how == "dot":
        return str(Path(os.path.relpath(path, lab))) if path == lab else "./" + os.path.relpath(path, lab)
    if how == "up":
        return os.path.join("..", lab.name, os.path.relpath(path, lab))
    if how == "absolute":
        return str(path.resolve())
    links = lab / "links"
    links.mkdir(exist_ok=True)
    link = links / f"{how}-{path.name or 'lab'}"
    if not os.path.lexists(link):
        (os.link if how == "hardlink" else os.symlink)(path.resolve(), link)
    return str(link.relative_to(lab))


def cases():
    for table, kind in ((FILES, "file"), (FOLDERS, "folder")):
        for command, (argv, outputs) in table.items():
            for flag, inputs in outputs.items():
                for target in inputs:
                    for how in SPELLINGS:
                        if kind == "folder" and how == "hardlink":
                            continue  # no hard links to folders
                        yield pytest.param(argv, flag, target, how, id=f"{' '.join(command)} {flag}={target}:{how}")


def snapshot(*folders) -> dict:
    return {
        p: p.read_bytes() for folder in folders for p in Path(folder).rglob("*") if p.is_file() and not p.is_symlink()
    }


@pytest.mark.parametrize("argv, flag, target, how", list(cases()))
def test_an_output_onto_an_input_is_refused_and_nothing_changes(lab, monkeypatch, capsys, argv, flag, target, how):
    monkeypatch.chdir(lab)
    spelled = spell(lab, target, how)
    argv = list(argv)
    argv[argv.index(flag) + 1] = spelled
    before = snapshot(lab, PAPER_PARAMETERS.parent)
    names = sorted(p.name for p in lab.iterdir())
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {flag} "), err
    assert "is an input of this command" in err[0] or "an input of this command" in err[0], err
    assert snapshot(lab, PAPER_PARAMETERS.parent) == before  # every file byte-identical
    assert sorted(p.name for p in lab.iterdir()) == names  # and nothing new: no database, no report


def output_flags() -> set:
    """(command words, flag) of every option of every command whose destination is an output."""
    found = set()

    def walk(parser, words):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, (*words, name))
            elif action.dest in OUTPUT_DESTS and action.option_strings:
                found.add((words, action.option_strings[0]))

    for name in cli.COMMANDS:
        parser = cli.build_parser(name)
        command_parser = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[name]
        walk(command_parser, (name,))
    return found


def test_every_output_flag_of_every_command_is_in_the_sweep():
    covered = {
        (command[:1] if command[0] == "compare" else command, flag)
        for table in (FILES, FOLDERS)
        for command, (_, outputs) in table.items()
        for flag in outputs
    }
    missing = output_flags() - covered - READ_ONLY
    assert not missing, f"output flags with no case in this sweep: {sorted(missing)}"


def test_data_generate_out_refuses_a_folder_holding_files_it_would_replace_unless_forced(tmp_path, capsys):
    """A user's own manifest.json and a test named like one of the dataset's: refused, naming them, both
    byte-identical; --force replaces them."""
    from bwbench.datasets import mr_dataset

    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "manifest.json").write_text('{"mine": true}\n')
    own = mr_dataset.file_names()[0]
    (folder / own).write_text("time_s,displacement_mm,force_N\n")
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    assert cli.main(["data", "generate", "--mr-damper", "--out", str(folder)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"holds {own} and manifest.json, which this command would replace" in err[0], err
    assert "--force" in err[0]
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert cli.main(["data", "generate", "--mr-damper", "--out", str(folder), "--force"]) == 0
    assert json.loads((folder / "manifest.json").read_text()) != {"mine": True}
    assert (folder / own).read_bytes() != before[own]
