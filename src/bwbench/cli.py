"""The ``bwbench`` command line (DESIGN.md §5): the argument parser only.

Each command's body lives with its concern; its module is imported only when that command runs,
so ``bwbench data check`` does not pay for matplotlib, seaborn and scipy.stats. A user's mistake
(bad file, bad option) prints one line ``error: ...`` on stderr and exits 2; it never shows a
traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings

from bwbench import threads
from bwbench.errors import UserError

# name -> (module, function adding the command's arguments and its ``func``, help)
COMMANDS = {
    "data": ("bwbench.data.commands", "add_arguments", "check or regenerate specimen files"),
    "simulate": ("bwbench.problems.switched_vpp.commands", "add_simulate_arguments",
                 "model force for a parameter set on a specimen"),
    "evaluate": ("bwbench.problems.switched_vpp.commands", "add_evaluate_arguments",
                 "MSE, F_err and RMSE of a parameter set on a specimen"),
    "optimizers": ("bwbench.optimize.commands", "add_list_arguments", "list the registered optimiser backends"),
    "models": ("bwbench.models.commands", "add_arguments", "list the registered hysteresis models"),
    "fit": ("bwbench.optimize.commands", "add_fit_arguments", "fit one specimen, or several jointly, with one optimiser"),
    "predict": ("bwbench.problems.switched_vpp.predict_command", "add_arguments",
                "a fitted model's force on other tests, every coefficient as stored"),
    "compare": ("bwbench.study.commands", "add_arguments", "run or resume a study: specimens × backends × seeds"),
    "report": ("bwbench.report.build", "add_arguments", "figures, statistics and recommendation of a study"),
    "identifiability": ("bwbench.problems.switched_vpp.commands", "add_identifiability_arguments",
                        "which parameters a specimen cannot pin down"),
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The full parser; a command's own options are only added when ``command`` names it."""
    parser = argparse.ArgumentParser(prog="bwbench", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (module_name, adder, help_text) in COMMANDS.items():
        command_parser = sub.add_parser(name, help=help_text)
        if name == command:
            getattr(importlib.import_module(module_name), adder)(command_parser)
    return parser


def main(argv=None) -> int:
    # ArviZ 0.2x announces its coming refactor once a day at import: nothing a bwbench user can act on.
    warnings.filterwarnings("ignore", message=r"\s*ArviZ is undergoing a major refactor", category=FutureWarning)
    argv = sys.argv[1:] if argv is None else list(argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    try:
        threads.check_environment()  # before a command imports numba, which fails on NUMBA_NUM_THREADS=0
        args = build_parser(command).parse_args(argv)
        with threads.environment(getattr(args, "threads", 1)):  # one thread per process unless --threads
            return args.func(args)
    except KeyboardInterrupt:
        # Ctrl-C: one line, exit 130 (128 + SIGINT). Outputs are written at the end of a command and
        # atomically, so nothing half-written is left behind.
        print(f"interrupted: bwbench {command or ''} stopped (Ctrl-C); no output is left half-written",
              file=sys.stderr)
        return 130
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
        print("error: not enough memory for this command (a file or a study too large for this machine?)",
              file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
