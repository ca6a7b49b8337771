"""``bwbench report``: its arguments; the engine (``bwbench.report.build``) is imported only to run."""

from __future__ import annotations

import argparse
import sys


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--db", required=True, help="study database (SQLite, written by bwbench compare)")
    parser.add_argument("--out", required=True, help="output folder, e.g. reports/NAME")
    parser.add_argument("--data", help="folder with the study's data files (default: where the study last found them)")
    parser.add_argument(
        "--profiles",
        type=int,
        default=2,
        help="profile likelihoods of this many parameters on the first specimen (default 2; 0 = none)",
    )
    parser.set_defaults(func=cli_main)


def cli_main(args) -> int:
    """``bwbench report --db PATH --out reports/NAME``; prints the recommendation in one line, then the
    path of report.html."""
    from bwbench.data.output_paths import writing
    from bwbench.errors import UserError
    from bwbench.report.build import build_report

    if args.profiles < 0:
        raise UserError(f"--profiles must be 0 or more, got {args.profiles}")
    with writing(args.out):  # a full disk names the report's folder
        path = build_report(
            args.db,
            args.out,
            data_dir=getattr(args, "data", None),
            profile_params=getattr(args, "profiles", 2),
            announce=sys.stdout,
        )
    print(path)
    return 0
