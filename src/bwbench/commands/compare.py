"""``bwbench compare`` and ``python studies/run_compare.py``: their arguments and the scripts' entry point;
the study runner (``bwbench.commands.compare_run``) is imported only to run."""

from __future__ import annotations

import argparse
import sys

import bwbench.notices as notices
import bwbench.threads as threads
from bwbench.errors import UserError

DESCRIPTION = "Run (or resume) a study: specimens × backends × seeds, print the ranking."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--config", help="study TOML (e.g. studies/quick.toml)")
    source.add_argument(
        "--specimens",
        nargs="+",
        metavar="FILE",
        help="your own specimen CSVs (paths or quoted globs): a study without a TOML",
    )
    own = parser.add_argument_group("with --specimens")
    # Defaults are None here and filled in by study_config: with --config, a flag that was given is
    # refused (the TOML says it), not silently ignored.
    own.add_argument("--optimizers", help="backends, comma-separated (e.g. cmaes,de,random)")
    own.add_argument("--seeds", type=int, help="replicates per (specimen, backend) (default 5)")
    own.add_argument("--budget", type=int, help="evaluations per run (default 4100)")
    own.add_argument("--seed", type=int, help="study seed (default 0)")
    own.add_argument("--name", help="study name (default 'study': database ./study.sqlite)")
    own.add_argument(
        "--model",
        help="model, or models comma-separated to compare side by side (default "
        "switched-bouc-wen; see `bwbench models`)",
    )
    own.add_argument("--state", help="hysteretic state convention of the switched model: shared (default) or split")
    own.add_argument("--excitation", help="measured (default) or sine")
    own.add_argument(
        "--formulation",
        help="paper (or direct), identifiable, or both comma-separated to compare them side by side "
        "(default: each model's own: paper for the switched model, identifiable for the others)",
    )
    own.add_argument(
        "--bounds",
        metavar="FILE.json",
        help="a JSON object of name -> [lower, upper]: the search box, and bounds on solved coefficients (m, c+, ...)",
    )
    own.add_argument(
        "--fix-mass",
        metavar="VALUE",
        help="identifiable formulation: the inertia m in N·s²/mm (1 = 1 t): a number fixes it, 'fit' "
        "always fits it, 'auto' (default) fits it only where the data separate it from the stiffness",
    )
    own.add_argument(
        "--offsets",
        help="identifiable formulation, switched model: branch (default: a constant force "
        "per branch) or continuous (one for both: no jump at a reversal)",
    )
    own.add_argument(
        "--initial-state",
        help="how every model starts each record, the same for all: auto (default), rest or pre-roll",
    )
    own.add_argument(
        "--warmup",
        metavar="SECONDS",
        help="the first SECONDS of each record simulated but left out of the loss (default 0)",
    )
    own.add_argument(
        "--validate",
        nargs="+",
        metavar="FILE",
        help="held-out specimen CSVs, never fitted: every fit predicts them with its coefficients as "
        "stored, and the report ranks by that error as well as by the training loss",
    )
    parser.add_argument(
        "--db",
        help="SQLite database (default: <name>.sqlite next to the TOML, or in the current folder with --specimens)",
    )
    parser.add_argument("--workers", type=int, help="local worker processes (default: all cores; 1 = in-process)")
    parser.add_argument(
        "--threads",
        type=int,
        default=1,
        help="numba/BLAS threads per worker (default 1: the workers already fill the cores)",
    )
    parser.add_argument("--scheduler", help="Dask scheduler address (tcp://HOST:PORT) instead of local workers")
    parser.add_argument("--csv", help="also write the runs (with timings) as a CSV file")
    parser.add_argument(
        "--data",
        help="data folder, replacing the configuration's [study] data (relative to the "
        "current directory); for bouc-wen-benchmark the folder of its three CSVs",
    )
    parser.set_defaults(func=main)


def main(args) -> int:
    """Run the study (``bwbench.commands.compare_run.main``: its exit statuses)."""
    from bwbench.commands import compare_run as commands

    return commands.main(args)


def run_cli(argv=None, prog: str | None = None) -> int:
    """Parse ``argv`` and run ``main``; a ``UserError`` (or an ``OSError``, e.g. a full disk) becomes one
    line ``error: ...`` and status 2."""
    parser = argparse.ArgumentParser(prog=prog, description=DESCRIPTION)
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        # as bwbench's own entry point does: its thread variables, and warnings in words
        with threads.environment(getattr(args, "threads", 1)), notices.command_line_warnings():
            return main(args)
    except UserError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except OSError as err:  # as bwbench's own entry point does
        where = f"{err.filename}: " if err.filename else ""
        print(f"error: {where}{err.strerror or err}", file=sys.stderr)
        return 2
    except MemoryError:
        print("error: not enough memory for this study on this machine", file=sys.stderr)
        return 2
