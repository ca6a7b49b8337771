"""The ``bwbench`` command line (DESIGN.md §5).

A user's mistake (bad file, bad option) prints one line ``error: ...`` on stderr and exits 2;
it never shows a traceback.
"""

from __future__ import annotations

import argparse
import sys

from bwbench.errors import UserError


def _cmd_data_check(args) -> int:
    from bwbench.specimen import read_specimen

    status = 0
    for path in args.files:
        try:
            spec = read_specimen(path)
        except UserError as err:
            print(f"error: {err}", file=sys.stderr)
            status = 2
        else:
            print(f"ok: {path}: {spec.n_samples} samples, {spec.duration_s:.1f} s")
    return status


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bwbench", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    data = sub.add_parser("data", help="check or regenerate specimen files")
    data_sub = data.add_subparsers(dest="data_command", required=True)
    check = data_sub.add_parser("check", help="validate specimen CSV files")
    check.add_argument("files", nargs="+", help="specimen CSV files")
    check.set_defaults(func=_cmd_data_check)
    return parser


class _Parser(argparse.ArgumentParser):
    pass


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except UserError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
