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
import time
from pathlib import Path

import pytest

from bwbench import cli
from bwbench.errors import UserError

REPO = Path(__file__).resolve().parents[2]
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


# ------------------------------------------------------------------ markup from data


def test_report_markdown_carries_no_markup_from_data(tmp_path):
    """A specimen, a manifest field and a column named with HTML: inert in report.md (a Markdown viewer
    renders inline HTML), as in report.html; "p < 0.05" still reads as written."""
    import pandas as pd

    from bwbench.render.document import Document

    name = "<img src=x onerror=alert(1)>"
    doc = Document(tmp_path)
    doc.h(3, name)
    doc.p("material <script>alert(1)</script>, p < 0.05, a [link](javascript:alert(1))")
    doc.bullets([f"{name}\n| injected | row |"])
    doc.table(pd.DataFrame({"<b onmouseover=x>": [name], "n": [1]}), caption=name)
    doc.pre("```\n<script>x</script>")
    markdown = doc.markdown()
    outside_code = markdown.split("````")[0]  # inside a fence, text is shown as text
    for raw in ("<img", "<script", "<b ", "](javascript"):
        assert raw not in outside_code, markdown
    assert "&lt;img src=x onerror=alert(1)>" in markdown and "p < 0.05" in markdown
    assert "\n| injected" not in markdown  # the list item stays one line: no table row injected
    assert markdown.count("````") == 2  # the fence outlasts the text's own backticks
    html_text = doc.html("t")
    assert "<img src=x" not in html_text and "<script>" not in html_text


def test_fit_plot_draws_a_mathtext_name_as_written(lab):
    """``r$\\undefinedmacro$.csv`` crashed ``fit --plot`` (ParseFatalException in mathtext)."""
    shutil.copy(lab / "in" / "mr.csv", lab / "r$\\undefinedmacro$.csv")
    done = bwbench(
        "fit",
        "r$\\undefinedmacro$.csv",
        "--optimizer",
        "random",
        "--budget",
        "5",
        "--out",
        "m.json",
        "--plot",
        "m.png",
        cwd=lab,
    )
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert (lab / "m.png").stat().st_size > 10_000


def test_literal_text_keeps_the_tick_labels_mathtext(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from bwbench.render.literal_text import make_literal

    fig = Figure()
    ax = fig.subplots()
    ax.loglog([1, 10, 1000], [1e-3, 1, 1e5])
    ax.set_title("r$\\undefinedmacro$")
    ax.legend(["$\\nope$"])
    make_literal(fig)
    fig.savefig(tmp_path / "f.png")  # mathtext would raise on the title and the legend
    fig.canvas.draw()
    assert ax.xaxis.get_major_ticks()[2].label1.get_parse_math()
    assert not ax.title.get_parse_math()


# ------------------------------------------------------------------ signals


def test_a_closed_terminal_ends_a_study_with_129_keeping_its_runs(tmp_path):
    """``compare --workers 2`` on a terminal that closes (SIGHUP to the whole process group, and the
    terminal gone: every later write to it fails): exit 129, no worker left, the finished runs kept and
    resumed by the same command."""
    import io
    import pty
    import select

    import psutil

    from robustness_helpers import count_runs, write_config

    config = write_config(tmp_path / "hup.toml")  # 24 runs of 200 evaluations
    db = tmp_path / "hup.sqlite"
    pid, terminal = pty.fork()
    if pid == 0:  # the child: bwbench on the terminal
        os.execv(sys.executable, [sys.executable, "-m", "bwbench.cli", "compare", "--config", str(config),
                                  "--db", str(db), "--workers", "2"])  # fmt: skip
    try:
        deadline = time.monotonic() + HANG
        while count_runs(db) < 1:
            assert time.monotonic() < deadline, "hang: no run committed"
            if select.select([terminal], [], [], 0.05)[0]:
                os.read(terminal, 65536)  # keep the terminal drained, as a terminal would
        workers = psutil.Process(pid).children(recursive=True)
        os.close(terminal)  # the terminal closes: the kernel sends SIGHUP to its process group
        while not (ended := os.waitpid(pid, os.WNOHANG))[0]:
            assert time.monotonic() < deadline, "hang after SIGHUP"
            time.sleep(0.05)
    finally:
        try:
            os.kill(pid, 9)
        except ProcessLookupError:
            pass
    assert os.waitstatus_to_exitcode(ended[1]) == 129
    time.sleep(1)  # a grace period for the kernel to deliver the workers' death signals
    assert not [p for p in workers if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]
    kept = count_runs(db)
    assert 1 <= kept < 24
    from bwbench.study.config import load_study_config
    from bwbench.study.execute import run_study

    outcome = run_study(load_study_config(config), db, workers=1, log=io.StringIO())
    assert (outcome.already, outcome.recorded) == (kept, 24 - kept)


@pytest.mark.parametrize("sig", ["SIGINT", "SIGHUP"])
def test_a_signal_swallowed_by_a_library_still_ends_the_command_stopped(sig, monkeypatch, capsys):
    """A library that catches the exception of Ctrl-C (or of a hangup) and carries on cannot turn a
    stopped command into a success: exit 128 + the signal, one line."""
    import signal

    from bwbench.commands import models

    def swallowing(args):
        try:
            os.kill(os.getpid(), getattr(signal, sig))
            time.sleep(1)  # the handler runs here
        except BaseException:  # what a careless library does
            pass
        return 0

    monkeypatch.setattr(models, "list_models", swallowing)
    previous = signal.signal(signal.SIGHUP, lambda *_: None)  # should bwbench not handle it: not the test's end
    try:
        status = cli.main(["models"])
    finally:
        signal.signal(signal.SIGHUP, previous)
    assert status == 128 + getattr(signal, sig)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith("no output is left half-written") and "bwbench models stopped" in err[0]


# ------------------------------------------------------------------ networks that never answer


@pytest.fixture()
def listener():
    """A local TCP port served by ``answer(conn)`` in a thread; yields a function making one."""
    import socket
    import threading

    sockets = []

    def serve(answer):
        server = socket.socket()
        server.bind(("127.0.0.1", 0))
        server.listen(8)
        sockets.append(server)

        def loop():
            while True:
                try:
                    conn, _ = server.accept()
                except OSError:
                    return
                sockets.append(conn)
                answer(conn)

        threading.Thread(target=loop, daemon=True).start()
        return f"tcp://127.0.0.1:{server.getsockname()[1]}"

    yield serve
    for s in sockets:
        s.close()


def test_a_scheduler_that_accepts_and_never_answers_is_one_line(lab, listener):
    """The port accepts the connection and says nothing (a dead proxy, a stopped process): one line
    after the wait, exit 2, no database made. It was a wait with no end."""
    address = listener(lambda conn: None)
    done = bwbench(
        "compare", "--specimens", "in/mr.csv", "--optimizers", "random", "--seeds", "1", "--budget", "5",
        "--scheduler", address, "--db", "s.sqlite", cwd=lab, env={"BWBENCH_SCHEDULER_WAIT_S": "2"},
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    one_error(done.stderr, f"cannot connect to the Dask scheduler at {address}: no answer within 2 s")
    assert not (lab / "s.sqlite").exists()


def test_a_scheduler_port_held_by_another_protocol_is_named(listener):
    """An HTTP server on the port was reported as "not enough memory" (its answer read as a frame)."""
    from bwbench.study.cluster import reach

    def http(conn):
        conn.recv(65536)
        conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
        conn.close()

    address = listener(http)
    with pytest.raises(UserError, match="does not speak Dask's protocol"):
        reach(address)


# ------------------------------------------------------------------ a script's workers


def test_a_script_read_from_stdin_runs_its_study_on_workers(lab):
    """``python - < script.py`` with ``bwbench.compare(..., workers=2)``: every worker died trying to
    run "<stdin>" again, and compare returned a Study of 0 runs with no error."""
    script = (
        "import bwbench\n"
        "s = bwbench.compare(specimens=['in/mr.csv'], optimizers=['random'], seeds=2, budget=5, workers=2, db='s.sqlite')\n"
        "print(len(s.runs))\n"
    )
    done = subprocess.run([sys.executable, "-"], input=script, cwd=lab, capture_output=True, text=True, timeout=HANG)
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "2"


def test_workers_that_cannot_start_are_a_failure_not_an_empty_study(monkeypatch):
    """Workers that die before their first run (here: numba refuses the environment they inherit)
    raise ``WorkersCannotStart`` (a ``UserError``: the CLI's one line, the API's exception)."""
    import numba  # noqa: F401 (imported here first: only the workers meet the broken setting)

    from bwbench.study.pool import WorkersCannotStart, in_pool
    from robustness_helpers import KeyOnly, die_or_echo

    monkeypatch.setenv("NUMBA_NUM_THREADS", "0")
    with pytest.raises(WorkersCannotStart, match="cannot start .* died before their first run"):
        list(in_pool([KeyOnly(("ranking", "s", "random", i)) for i in range(3)], 2, run=die_or_echo))


# ------------------------------------------------------------------ locales


@pytest.mark.parametrize("encoding", ["latin-1", "ascii"])
def test_a_fit_prints_on_a_latin_1_or_ascii_terminal(lab, encoding):
    """N², ≥, … and ∮F·dx on a terminal that cannot show them (``LC_ALL=de_DE.ISO-8859-1``,
    ``PYTHONIOENCODING=ascii``) were a UnicodeEncodeError; now ASCII words where the encoding lacks
    the symbol, the symbol where it has it (² is Latin-1). The result file is UTF-8 JSON all the same."""
    done = subprocess.run(
        [sys.executable, "-m", "bwbench.cli", "fit", "in/mr.csv", "--optimizer", "random", "--budget", "5",
         "--out", "r.json"],
        cwd=lab, capture_output=True, timeout=HANG, stdin=subprocess.DEVNULL,
        env={**os.environ, "PYTHONIOENCODING": encoding, "LC_ALL": "de_DE.ISO-8859-1"},
    )  # fmt: skip
    out, err = done.stdout.decode(encoding), done.stderr.decode(encoding)
    assert done.returncode == 0 and "Traceback" not in err, err
    assert ("N²" if encoding == "latin-1" else "N^2") in out
    assert "loop-integral F" in out + err and "?" not in out.replace("?)", "").replace("? ", "")
    assert json.loads((lab / "r.json").read_text(encoding="utf-8"))["params"]


def test_the_ascii_words_of_the_symbols():
    from bwbench.text_streams import HANDLER

    text = "MSE 27.9 N² (∮F·dx ≥ 0 …, R̂ ≤ 1.01, ẋ < 0, 10 µm, ☃)"
    assert (
        text.encode("ascii", HANDLER) == b"MSE 27.9 N^2 (loop-integral F*dx >= 0 ..., R^ <= 1.01, dx/dt < 0, 10 um, ?)"
    )
    assert text.encode("latin-1", HANDLER).decode("latin-1") == (
        "MSE 27.9 N² (loop-integral F·dx >= 0 ..., R^ <= 1.01, dx/dt < 0, 10 µm, ?)"
    )


# ------------------------------------------------------------------ files read silently wrong


@pytest.fixture(scope="module")
def fit_json(tmp_path_factory):
    """A fit result of the specimen (5 evaluations) and the specimen, in a folder of their own."""
    folder = tmp_path_factory.mktemp("fit")
    shutil.copy(SPECIMENS / NAME, folder / "mr.csv")
    assert cli.main(["fit", str(folder / "mr.csv"), "--optimizer", "random", "--budget", "5", "--out",
                     str(folder / "f.json")]) == 0  # fmt: skip
    return folder


def test_a_fit_converted_to_si_units_is_refused_naming_the_key(fit_json, capsys):
    """Values and units converted to m by hand were read as mm (RMSE 5e5 N, no word)."""
    fit = json.loads((fit_json / "f.json").read_text())
    for b in "+-":
        for k in ("beta", "gamma"):
            fit["params"][k + b] *= 1000.0 ** fit["params"]["n" + b]
            fit["units"][k + b] = f"m^-n{b}"
    (fit_json / "si.json").write_text(json.dumps(fit))
    status = cli.main(["evaluate", "--params", str(fit_json / "si.json"), "--specimen", str(fit_json / "mr.csv")])
    assert status == 2
    one_error(capsys.readouterr().err, 'si.json: units.beta+ is "m^-n+", but bwbench computes beta+ in "mm^-n+"')


def test_a_json_key_given_twice_is_refused_naming_its_line(fit_json, capsys):
    text = (fit_json / "f.json").read_text().replace('"A+":', '"A+": 5,\n    "A+":', 1)
    (fit_json / "dup.json").write_text(text)
    line = [n for n, row in enumerate(text.splitlines(), start=1) if row.strip().startswith('"A+":')][1]
    status = cli.main(["evaluate", "--params", str(fit_json / "dup.json"), "--specimen", str(fit_json / "mr.csv")])
    assert status == 2
    one_error(capsys.readouterr().err, f'dup.json:{line}: the key "A+" appears twice in one object')


def _with_force(tmp_path, name, force) -> Path:
    lines = (SPECIMENS / NAME).read_text().splitlines()
    j = lines[0].split(",").index("force_N")
    rows = [line.split(",") for line in lines[1:]]
    for row in rows:
        row[j] = force(float(row[j]))
    (tmp_path / name).write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    return tmp_path / name


def german(value: float) -> str:
    """10 × the force in N, as a German export writes it: a point between thousands."""
    whole = round(10 * value)
    sign, whole = ("-" if whole < 0 else ""), abs(whole)
    return f"{sign}{whole // 1000}.{whole % 1000:03d}" if whole >= 1000 else f"{sign}{whole}"


@pytest.mark.parametrize(
    "name, force, problem",
    [
        ("german.csv", german, "force_N reads like numbers with a thousands separator"),
        ("subnormal.csv", lambda f: repr(f * 1e-312), "force_N is at most 6.11e-310 N in every row: effectively 0"),
    ],
)
def test_a_force_read_silently_wrong_is_refused_by_fit(tmp_path, capsys, name, force, problem):
    """German thousands separators (1.141 = 1141 N) were read as decimals; subnormal forces gave
    "MSE 0". Both are refused before the fit, naming the file; ``data check`` says the same."""
    path = _with_force(tmp_path, name, force)
    assert (
        cli.main(["fit", str(path), "--optimizer", "random", "--budget", "5", "--out", str(tmp_path / "r.json")]) == 2
    )
    one_error(capsys.readouterr().err, f"{path}: {problem}")
    assert not (tmp_path / "r.json").exists()


def test_shipped_specimens_do_not_read_as_thousands():
    from bwbench.data.plausibility import thousands_separator
    from bwbench.data.specimen import read_specimen

    assert not [p.name for p in sorted(SPECIMENS.glob("*.csv")) if thousands_separator(read_specimen(p).f)]


@pytest.mark.parametrize("content", ['{"mine": true}', "[1, 2]", '{"specimens": 5}', "{not json"])
def test_another_programs_manifest_beside_the_specimens_is_ignored_with_a_warning(fit_json, capsys, content):
    """It was a TypeError or KeyError traceback; now the specimens are read as measured data, said once."""
    folder = fit_json / "foreign"
    folder.mkdir(exist_ok=True)
    shutil.copy(fit_json / "mr.csv", folder / "mr.csv")
    (folder / "manifest.json").write_text(content)
    from bwbench import notices

    notices._said.clear()  # noqa: SLF001 (said once per process: this test runs several times in one)
    status = cli.main(["fit", str(folder / "mr.csv"), "--optimizer", "random", "--budget", "5",
                       "--out", str(folder / "r.json")])  # fmt: skip
    assert status == 0
    err = capsys.readouterr().err
    assert f"warning: {folder / 'manifest.json'} is not a bwbench manifest" in err and "Traceback" not in err


# ------------------------------------------------------------------ settings accepted silently


def _toml(tmp_path, extra_study="", tables="") -> Path:
    shutil.copy(SPECIMENS / NAME, tmp_path / "mr.csv")
    path = tmp_path / "s.toml"
    path.write_text(
        f'[study]\nname = "t"\nseed = 1\nbudget = 5\nseeds = 1\n{extra_study}'
        f'[specimens]\nfiles = ["mr.csv"]\n[optimizers]\nrandom = {{}}\n{tables}'
    )
    return path


def test_an_infinite_mass_in_a_toml_is_refused(tmp_path, capsys):
    config = _toml(tmp_path, 'formulation = "identifiable"\nfix_mass = inf\n')
    assert cli.main(["compare", "--config", str(config), "--db", str(tmp_path / "s.sqlite"), "--workers", "1"]) == 2
    one_error(capsys.readouterr().err, "[study] fix_mass must be", "a finite mass ≥ 0", "got inf")
    assert not (tmp_path / "s.sqlite").exists()


def test_a_posterior_of_an_optimiser_or_of_ten_evaluations_is_said(tmp_path):
    """``[posterior] optimizer = "cmaes"`` ran an optimiser as a sampler and the report dropped the
    section without a word; ``budget = 10`` could draw nothing. Both are accepted, with a warning."""
    import warnings

    from bwbench.notices import BwbenchWarning
    from bwbench.study.config import load_study_config

    config = _toml(tmp_path, tables='[posterior]\noptimizer = "cmaes"\nbudget = 10\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_study_config(config)
    said = [str(w.message) for w in caught if issubclass(w.category, BwbenchWarning)]
    assert any('optimizer "cmaes" is an optimiser (evolution-strategy), not a sampler' in s for s in said), said
    assert any("[posterior] budget = 10: below 1000 evaluations" in s for s in said), said


def test_weighting_without_a_joint_fit_and_a_copy_in_one_are_refused(lab, capsys):
    shutil.copy(lab / "in" / "mr.csv", lab / "in" / "copy.csv")
    fit = ["fit", "--optimizer", "random", "--budget", "5"]
    assert (
        cli.main([*fit, "--each", str(lab / "in" / "mr.csv"), "--weighting", "samples", "--out", str(lab / "o")]) == 2
    )
    one_error(
        capsys.readouterr().err, "--weighting samples weighs the files of a joint fit; --each fits every file alone"
    )
    assert cli.main([*fit, str(lab / "in" / "mr.csv"), str(lab / "in" / "copy.csv"), "--out", str(lab / "j.json")]) == 2
    one_error(
        capsys.readouterr().err, "copy.csv holds the same bytes as", "mr.csv: a joint fit would count one test twice"
    )
    assert not (lab / "j.json").exists()


def test_a_dataframe_with_complex_or_twice_named_forces_is_a_user_error():
    import pandas as pd

    from bwbench.data.specimen import read_specimen
    from bwbench.data.specimen_input import from_frame

    s = read_specimen(SPECIMENS / NAME)
    frame = pd.DataFrame({"time_s": s.t, "displacement_mm": s.x, "force_N": s.f})
    with pytest.raises(UserError, match="column force_N holds complex numbers"):
        from_frame(frame.assign(force_N=s.f + 1e-3j))
    with pytest.raises(UserError, match="column force_N appears twice"):
        from_frame(pd.concat([frame, frame[["force_N"]]], axis=1))


def test_a_deleted_working_folder_is_named(tmp_path):
    gone = tmp_path / "gone"
    gone.mkdir()
    done = subprocess.run(
        ["sh", "-c", f'cd "{gone}" && rmdir "{gone}" && exec "{sys.executable}" -m bwbench.cli data check x.csv'],
        capture_output=True, text=True, timeout=HANG, env={**os.environ, "PYTHONPATH": str(REPO / "src")},
    )  # fmt: skip
    assert done.returncode == 2
    one_error(done.stderr, "the current folder no longer exists")


def test_a_held_out_file_edited_after_the_study_is_refused_by_the_report(tmp_path):
    """The report compared fits with a [validation] file that had changed since the study ran."""
    from types import SimpleNamespace

    from bwbench.data.identity import files_sha256
    from bwbench.report.build import refuse_changed_data

    for name in ("a", "held"):
        shutil.copy(SPECIMENS / NAME, tmp_path / f"{name}.csv")
    digest = files_sha256([tmp_path / "a.csv"], [""])
    study = SimpleNamespace(
        config={"specimens": {"a": digest}, "validation": {"held": digest}},
        specimens=["a"],
        specimen_path=lambda name: tmp_path / f"{name}.csv",
    )
    refuse_changed_data(study)  # both as the study ran on them
    (tmp_path / "held.csv").write_text((tmp_path / "held.csv").read_text().replace(",", ", ", 1))
    with pytest.raises(UserError, match="held.csv: changed since the study ran"):
        refuse_changed_data(study)


def test_a_deleted_specimen_is_named_where_the_study_read_it(tmp_path):
    """After the files were deleted the report named a file of another folder (the study's default)."""
    import dataclasses

    from bwbench.database.reader import Study

    missing = dataclasses.MISSING
    fields = {f.name: None for f in dataclasses.fields(Study) if f.default is missing and f.default_factory is missing}
    study = Study(**{**fields, "data_dir": tmp_path / "elsewhere"}, recorded={"mr": "/lab/tests/mr.csv"})
    assert study.specimen_path("mr") == Path("/lab/tests/mr.csv")


def test_saving_a_fit_onto_its_own_bounds_file_is_refused(lab):
    """``FitResult.save()`` onto the bounds JSON the fit read replaced it (data loss)."""
    import bwbench

    box = lab / "box.json"
    box.write_text('{"xy+": [1.0, 50.0]}\n')
    fit = bwbench.fit(str(lab / "in" / "mr.csv"), optimizer="random", budget=5, bounds=str(box))
    with pytest.raises(UserError, match="is an input of this command"):
        fit.save(lab / "." / "box.json")
    assert box.read_text() == '{"xy+": [1.0, 50.0]}\n'


# ------------------------------------------------------------------ the third sweep's leftovers


def test_a_model_named_twice_is_refused_on_the_command_line_and_in_a_toml(tmp_path, capsys):
    shutil.copy(SPECIMENS / NAME, tmp_path / "mr.csv")
    argv = ["compare", "--specimens", str(tmp_path / "mr.csv"), "--optimizers", "random", "--seeds", "1"]
    assert cli.main([*argv, "--model", "spencer,spencer", "--db", str(tmp_path / "a.sqlite")]) == 2
    one_error(capsys.readouterr().err, "model lists a model twice")
    config = _toml(tmp_path, 'model = ["spencer", "spencer"]\n')
    assert cli.main(["compare", "--config", str(config), "--db", str(tmp_path / "b.sqlite")]) == 2
    one_error(capsys.readouterr().err, "s.toml: model lists a model twice")


def test_a_negative_bound_on_n_is_refused(lab, capsys):
    (lab / "box.json").write_text('{"n+": [-1, 2]}')
    argv = ["fit", str(lab / "in" / "mr.csv"), "--bounds", str(lab / "box.json"), "--optimizer", "random"]
    assert cli.main([*argv, "--budget", "5", "--out", str(lab / "r.json")]) == 2
    one_error(capsys.readouterr().err, "box.json: bounds of n+: lower must be > 0", "got -1")


def test_a_spencer_fit_is_analysed_and_compared_as_spencer(lab, capsys):
    """identifiability of a Spencer fit without --model, and compare --model spencer on two workers,
    use Spencer's model (both once fell back to the switched model)."""
    import sqlite3

    spec, fit = str(lab / "in" / "mr.csv"), str(lab / "sp.json")
    assert cli.main(["fit", spec, "--model", "spencer", "--optimizer", "random", "--budget", "5", "--out", fit]) == 0
    capsys.readouterr()
    assert cli.main(["identifiability", spec, "--params", fit]) == 0
    assert capsys.readouterr().out.startswith("identifiability of mr (spencer, identifiable formulation")
    db = lab / "sp.sqlite"
    argv = ["compare", "--specimens", spec, "--optimizers", "random", "--seeds", "2", "--budget", "5"]
    assert cli.main([*argv, "--model", "spencer", "--workers", "2", "--db", str(db)]) == 0
    with sqlite3.connect(db) as conn:
        assert conn.execute("SELECT DISTINCT model FROM runs").fetchall() == [("spencer",)]


def test_a_signal_after_the_work_still_ends_the_program_stopped():
    """``report`` and ``fit --each`` exited 0 on a Ctrl-C: it came once their work was done, while the
    interpreter freed its modules (seconds). The program now exits as soon as the work is done, and a
    signal up to that exit gives 128 + the signal and one line."""
    code = (
        "import os, signal, bwbench.cli as cli\n"
        "def main():\n"
        "    print('done', flush=True)\n"
        "    os.kill(os.getpid(), signal.SIGINT)\n"
        "    return 0\n"
        "cli.main = main\n"
        "cli.run()\n"
    )
    done = subprocess.run([sys.executable, "-c", code, "report"], capture_output=True, text=True, timeout=HANG)
    assert done.returncode == 130 and done.stdout == "done\n", done.stderr
    assert done.stderr.strip().splitlines() == [
        "interrupted: bwbench report stopped (Ctrl-C); no output is left half-written"
    ]
