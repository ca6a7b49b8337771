"""Run (or resume) a comparison study: the same entry point as ``bwbench compare``.

python studies/run_compare.py --config studies/quick.toml [--db PATH] [--workers N]
                              [--scheduler tcp://HOST:PORT] [--csv runs.csv]
"""

import sys

from bwbench.commands.compare import run_cli

if __name__ == "__main__":  # guard: the worker processes are spawned and re-import this file
    sys.exit(run_cli(prog="run_compare.py"))
