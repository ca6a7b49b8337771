"""The ``bwbench`` command line (docs/commands.md): the argument parser only.

Each command's body lives with its concern; its module is imported only when that command runs
(``--help`` included), so ``bwbench --help`` and ``bwbench data check`` do not pay for matplotlib
and scipy.stats. A user's mistake (bad file, bad option) prints one line ``error: ...`` on
stderr and exits 2; it never shows a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
import warnings
from typing import NamedTuple

import bwbench.threads as threads
from bwbench import notices
from bwbench.errors import UserError
from bwbench.study import stop
from bwbench.text_streams import survive_any_locale
from bwbench.version import __version__

DESCRIPTION = """Fit hysteresis models of dampers to force–displacement tests, and compare optimisers on
them fairly: the same exact evaluation budget, data and seeds for every backend."""
EPILOG = """first steps:
  bwbench data check data/specimens/pom-mt24u01_0.05MPa_r1.csv
  bwbench fit data/specimens/pom-mt24u01_0.05MPa_r1.csv --out fit.json --plot fit.png
  bwbench fit mytest.csv --formulation identifiable --out fit.json   # your own data
  bwbench COMMAND --help                                           # each command's options

documentation: README.md and docs/ in the source repository"""


class Command(NamedTuple):
    module: str  # imported only when the command runs
    adder: str  # the module's function adding the command's arguments and its ``func``
    summary: str  # one line: the command's help in ``bwbench --help`` and its description
    example: str  # shown under ``bwbench COMMAND --help``


COMMANDS = {
    "data": Command(
        "bwbench.commands.data",
        "add_arguments",
        "check specimen files, or regenerate the shipped ones",
        "bwbench data check mytest.csv other.csv\n  bwbench data generate --out /tmp/specimens",
    ),
    "simulate": Command(
        "bwbench.commands.simulate",
        "add_simulate_arguments",
        "the model force of a parameter set (or a fit result) on a specimen's motion",
        "bwbench simulate --params fit.json --specimen test.csv --out force.csv",
    ),
    "evaluate": Command(
        "bwbench.commands.simulate",
        "add_evaluate_arguments",
        "MSE, F_err and RMSE of a parameter set (or a fit result) on a specimen",
        "bwbench evaluate --params fit.json --specimen test.csv",
    ),
    "optimizers": Command(
        "bwbench.commands.fit",
        "add_list_arguments",
        "list the registered optimiser backends, their options, ranges and defaults",
        "bwbench optimizers",
    ),
    "models": Command(
        "bwbench.commands.models",
        "add_arguments",
        "list the registered hysteresis models, their formulations and parameters",
        "bwbench models",
    ),
    "fit": Command(
        "bwbench.commands.fit",
        "add_fit_arguments",
        "fit one specimen, or several jointly (one parameter set), with one optimiser",
        "bwbench fit mytest.csv --formulation identifiable --out fit.json --plot fit.png\n"
        "  bwbench fit a.csv b.csv --model spencer --optimizer cmaes --budget 2000 --out joint.json",
    ),
    "predict": Command(
        "bwbench.commands.predict",
        "add_arguments",
        "a fitted model's force on other tests, every coefficient as stored, nothing refitted",
        "bwbench predict --fit fit.json other.csv --out prediction.json --plot prediction.png",
    ),
    "compare": Command(
        "bwbench.commands.compare",
        "add_arguments",
        "run or resume a study: specimens × backends × seeds, each on the same exact budget",
        "bwbench compare --config studies/quick.toml\n"
        "  bwbench compare --specimens 'tests/*.csv' --optimizers lsq-trf,cmaes,random "
        "--formulation identifiable --db study.sqlite",
    ),
    "report": Command(
        "bwbench.commands.report",
        "add_arguments",
        "a study's report: the recommended optimiser and why, figures and statistics",
        "bwbench report --db study.sqlite --out report   # report/report.html, report.md",
    ),
    "identifiability": Command(
        "bwbench.commands.simulate",
        "add_identifiability_arguments",
        "which parameter combinations a specimen cannot pin down",
        "bwbench identifiability test.csv --params fit.json",
    ),
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The full parser; a command's own options are only added when ``command`` names it."""
    parser = argparse.ArgumentParser(
        prog="bwbench", description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--version", action="version", version=f"bwbench {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, spec in COMMANDS.items():
        command_parser = sub.add_parser(
            name,
            help=spec.summary,
            description=spec.summary[0].upper() + spec.summary[1:],
            epilog=f"example:\n  {spec.example}",
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        if name == command:
            getattr(importlib.import_module(spec.module), spec.adder)(command_parser)
            from bwbench.commands import reading_options

            if name in reading_options.READS_SPECIMENS:
                reading_options.add(command_parser)
            from bwbench.commands import plugin_option

            if name in plugin_option.COMMANDS:
                plugin_option.add(command_parser)
    return parser


def _reading(args):
    """The command's ``--units`` and ``--rebuild-time`` declared while it runs (``bwbench.data.units``)."""
    import contextlib

    if not hasattr(args, "units"):
        return contextlib.nullcontext()
    from bwbench.data import units

    return units.declaring(args.units, args.rebuild_time)


def main(argv=None) -> int:
    # ArviZ 0.2x announces its coming refactor once a day at import: nothing a bwbench user can act on.
    warnings.filterwarnings("ignore", message=r"\s*ArviZ is undergoing a major refactor", category=FutureWarning)
    survive_any_locale()  # N², ≥, … on a Latin-1 or ASCII terminal: words, not a UnicodeEncodeError
    argv = sys.argv[1:] if argv is None else list(argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    stop.received.clear()
    stop.kept.clear()
    try:
        # Ctrl-C, a closed terminal (SIGHUP) or SIGTERM end every command the same way: one line and
        # the status a shell expects (128 + the signal), even if a library swallowed the exception.
        with stop.signals_raise((signal.SIGINT, signal.SIGTERM, signal.SIGHUP)):
            _check_working_folder()
            threads.check_environment()  # before a command imports numba, which fails on NUMBA_NUM_THREADS=0
            notices.writable_matplotlib_folder()  # before a command imports matplotlib
            args = build_parser(command).parse_args(argv)
            if getattr(args, "plugin", None):
                from bwbench.commands import plugin_option

                plugin_option.load(args.plugin)  # before anything looks a model or backend up by name
            # one thread per process unless --threads (or fit's --workers) asks for more
            fit_workers = getattr(args, "workers", 1) if command == "fit" else 1  # compare's are processes
            with (
                threads.environment(max(getattr(args, "threads", 1), fit_workers or 1)),
                notices.command_line_warnings(),
                _reading(args),
            ):
                status = args.func(args)
        if stop.received and status != 128 + stop.received[0]:  # swallowed on its way: still a stop
            return _stopped(command, stop.received[0])
        return status
    except (KeyboardInterrupt, stop.Interrupted) as interrupt:
        return _stopped(command, getattr(interrupt, "signum", signal.SIGINT))
    except BrokenPipeError:
        # The reader of stdout stopped early (``| head -1``): every file was written before the printing.
        # Send the rest of the output nowhere, so Python's exit does not fail on the closed pipe again.
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except UserError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except OSError as err:  # a disk full or a permission refused while writing: still one line
        where = f"{err.filename}: " if err.filename else ""  # the commands name their files; a safety net
        print(f"error: {where}{err.strerror or err}", file=sys.stderr)
        return 2
    except MemoryError:
        print(
            "error: not enough memory for this command (a file or a study too large for this machine?)", file=sys.stderr
        )
        return 2


def _check_working_folder() -> None:
    """``UserError`` when the current folder was deleted under the shell: every relative path would
    fail later with "No such file or directory" and no name."""
    import os

    try:
        os.getcwd()
    except FileNotFoundError:
        raise UserError(
            "the current folder no longer exists (deleted while the shell was in it): cd to a folder that exists"
        ) from None


def _stopped(command, signum: int) -> int:
    """One line for a command stopped by ``signum``, and its exit status (128 + the signal). Outputs
    are written at the end of a command and atomically, so nothing half-written is left behind."""
    what = "interrupted" if signum == signal.SIGINT else "terminated"
    how = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
    kept = f"; {stop.kept[-1]}" if stop.kept else ""
    stop.say(f"{what}: bwbench {command or ''} stopped ({how}){kept}; no output is left half-written")
    _quiet_streams()
    return 128 + signum


def _quiet_streams() -> None:
    """After a hangup the terminal is gone: what is left to print at exit goes nowhere, rather than
    failing (EIO) in Python's own flush at exit."""
    import os

    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            try:
                os.dup2(os.open(os.devnull, os.O_WRONLY), stream.fileno())
            except (OSError, ValueError):
                pass


def run() -> None:
    """The ``bwbench`` program: ``main``, then an exit that skips the interpreter's teardown. Freeing
    numba's, scipy's and pandas' modules takes seconds after the command's work is done and written,
    and a Ctrl-C in those seconds was lost (exit status 0); every output is closed by then, and the
    streams are flushed here. A signal until the very exit still gives its status."""
    import os

    status = 1
    try:
        with stop.signals_raise((signal.SIGINT, signal.SIGTERM, signal.SIGHUP)):
            status = main()
            _quiet_streams()  # flushed while a signal still has its status
    except (KeyboardInterrupt, stop.Interrupted) as interrupt:
        command = next((a for a in sys.argv[1:] if not a.startswith("-")), None)
        status = _stopped(command, getattr(interrupt, "signum", signal.SIGINT))
    os._exit(status)


if __name__ == "__main__":
    run()
