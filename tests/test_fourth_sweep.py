"""The fourth hardening sweep's classes (issue 42), one test or more each: outputs through planted
symbolic links, markup from data in report.md and figures, two spellings of one study database, a
scheduler that never answers, SIGHUP and SIGINT, a Latin-1 locale, a script's workers started from
standard input, and the files and settings that were read silently wrong.

Timeouts are hang detectors only (the machine may be slow and shared); nothing asserts how fast
anything is.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from bwbench.errors import UserError

REPO = Path(__file__).resolve().parents[1]
NAME = "pom-mt24u01_0.01MPa_r1.csv"
SPECIMENS = REPO / "data" / "specimens"
HANG = 300  # s: a hang detector only


def bwbench(*argv, cwd, env=None, **kwargs) -> subprocess.CompletedProcess:
    """``bwbench ARGV`` in a process of its own, as a user runs it."""
    return subprocess.run(
        [sys.executable, "-m", "bwbench.cli", *map(str, argv)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=HANG,
        stdin=subprocess.DEVNULL,
        env={**os.environ, **(env or {})},
        **kwargs,
    )


def one_error(err: str, *parts) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for part in parts:
        assert part in lines[0], err
    return lines[0]


@pytest.fixture()
def lab(tmp_path):
    """A specimen (not one of ours by name) in a folder of its own, and a secret file outside it."""
    (tmp_path / "in").mkdir()
    shutil.copy(SPECIMENS / NAME, tmp_path / "in" / "mr.csv")
    (tmp_path / "secret.txt").write_text("secret\n")
    return tmp_path


# ------------------------------------------------------------------ outputs through symbolic links


def test_fit_each_refuses_a_link_planted_in_its_output_folder(lab):
    """``fits/mr.json -> ../secret.txt``: refused before any fit, the outside file untouched."""
    (lab / "fits").mkdir()
    (lab / "fits" / "mr.json").symlink_to(lab / "secret.txt")
    done = bwbench("fit", "--each", "in/mr.csv", "--optimizer", "random", "--budget", "5", "--out", "fits", cwd=lab)
    assert done.returncode == 2, done.stderr
    one_error(done.stderr, "fits/mr.json is a symbolic link to", "secret.txt")
    assert (lab / "secret.txt").read_text() == "secret\n"


def test_fit_out_refuses_a_link_out_of_its_folder_dangling_or_not(lab):
    """A link named as ``--out`` that leads out of its folder (to a file, or to none yet, which writing
    would create) is refused before any work; one within its folder is written through as before."""
    (lab / "sub").mkdir()
    (lab / "sub" / "r.json").symlink_to(lab / "secret.txt")
    (lab / "sub" / "new.json").symlink_to(lab / "elsewhere.json")
    for out in ("sub/r.json", "sub/new.json"):
        with pytest.raises(UserError, match=f"--out {out} is a symbolic link to .*, outside sub"):
            cli_main_raising(["fit", "in/mr.csv", "--optimizer", "random", "--budget", "5", "--out", out], lab)
    assert (lab / "secret.txt").read_text() == "secret\n" and not (lab / "elsewhere.json").exists()
    (lab / "sub" / "latest.json").symlink_to("mine.json")
    assert (
        cli_main_raising(
            ["fit", "in/mr.csv", "--optimizer", "random", "--budget", "5", "--out", "sub/latest.json"], lab
        )
        == 0
    )
    assert (lab / "sub" / "latest.json").is_symlink() and json.loads((lab / "sub" / "mine.json").read_text())["params"]


def cli_main_raising(argv, cwd):
    """Run the command in this process and let its ``UserError`` through (not turned into exit 2)."""
    from bwbench.cli import build_parser

    old = os.getcwd()
    os.chdir(cwd)
    try:
        args = build_parser(argv[0]).parse_args(argv)
        return args.func(args)
    finally:
        os.chdir(old)


def test_a_link_met_while_writing_is_replaced_never_written_through(tmp_path):
    """Planted after the checks (during the run): the output replaces the link; the file it named is
    untouched. A link within the folder still has the file it names written (and is kept)."""
    from bwbench.data.output_paths import write_text

    (tmp_path / "out").mkdir()
    (tmp_path / "secret.txt").write_text("secret\n")
    planted = tmp_path / "out" / "report.md"
    planted.symlink_to(tmp_path / "secret.txt")
    write_text(planted, "# report\n")
    assert not planted.is_symlink() and planted.read_text() == "# report\n"
    assert (tmp_path / "secret.txt").read_text() == "secret\n"
    (tmp_path / "out" / "latest.md").symlink_to("report.md")  # within the folder
    write_text(tmp_path / "out" / "latest.md", "# again\n")
    assert (tmp_path / "out" / "latest.md").is_symlink() and planted.read_text() == "# again\n"
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["latest.md", "report.md"]  # no leftovers


# ------------------------------------------------------------------ one lock per database


def test_two_spellings_of_one_database_take_one_lock(tmp_path):
    """``s.sqlite`` and a symbolic link to it, ``./`` and ``../``: the second writer is refused."""
    from bwbench.study.lock import StudyLock

    db = tmp_path / "s.sqlite"
    db.write_bytes(b"")
    (tmp_path / "link.sqlite").symlink_to(db)
    (tmp_path / "sub").mkdir()
    with StudyLock(db):
        for spelled in (tmp_path / "link.sqlite", tmp_path / "sub" / ".." / "s.sqlite"):
            with pytest.raises(UserError, match="another bwbench compare .* is writing this study"):
                with StudyLock(spelled):
                    pass
    with StudyLock(tmp_path / "link.sqlite"):  # released: any spelling takes it
        pass
