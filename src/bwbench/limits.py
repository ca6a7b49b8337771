"""The stated maxima that keep a mistyped number from planning for minutes, filling the memory or running
"forever" — each checked before any work, each raised by an environment variable of the same name.

=========================  ===========  ==============================================================
variable                   default      what it bounds
=========================  ===========  ==============================================================
BWBENCH_MAX_BUDGET         100000000    evaluations of one run (``--budget``, ``budget =``): 10⁸ is
                                        about 4 h of one core at the paper's specimen size
BWBENCH_MAX_SEEDS          10000        replicates per (specimen, backend) (``--seeds``, ``seeds =``)
BWBENCH_MAX_RUNS           100000       runs of one study: specimens × backends × formulations × seeds
                                        (+ posterior runs); the paper's scale is 2,163
BWBENCH_MAX_WORKERS        4 per core   local worker processes (``--workers``); each costs ~0.15 GB
BWBENCH_MAX_INPUT_MB       256          size of a specimen CSV (8 million samples at 32 bytes a row)
BWBENCH_MAX_TEXT_MB        16           size of a TOML or JSON file (parameters, bounds, manifest)
BWBENCH_SCHEDULER_WAIT_S   20           seconds ``--scheduler`` waits for the Dask scheduler to accept
                                        the connection and answer its handshake
=========================  ===========  ==============================================================
"""

from __future__ import annotations

import os

from bwbench.errors import UserError

DEFAULTS = {
    "BWBENCH_MAX_BUDGET": 100_000_000,
    "BWBENCH_MAX_SEEDS": 10_000,
    "BWBENCH_MAX_RUNS": 100_000,
    "BWBENCH_MAX_WORKERS": 4 * (os.cpu_count() or 1),
    "BWBENCH_MAX_INPUT_MB": 256,
    "BWBENCH_MAX_TEXT_MB": 16,
    "BWBENCH_SCHEDULER_WAIT_S": 20,
}


def maximum(variable: str) -> int:
    """The limit ``variable`` (one of ``DEFAULTS``): the environment's value if set, else the default.
    Raises ``UserError`` for a value that is not a positive integer."""
    text = os.environ.get(variable)
    if text is None or not text.strip():
        return DEFAULTS[variable]
    try:
        value = int(text.replace("_", ""))
    except ValueError:
        value = 0
    if value < 1:
        raise UserError(f"{variable}={text!r}: must be a positive integer")
    return value


def check(label: str, value: int, variable: str, what: str = "") -> None:
    """``UserError`` naming ``label``, the limit and how to raise it if ``value`` exceeds ``variable``'s."""
    limit = maximum(variable)
    if value > limit:
        raise UserError(
            f"{label} {value:,} is above the limit of {limit:,}{what}; if you mean it, raise the "
            f"limit: {variable}={value} bwbench ..."
        )
