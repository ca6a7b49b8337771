"""The options saying how a command reads specimen files: ``--units`` and ``--rebuild-time``."""

from __future__ import annotations

import argparse

# Commands that read specimen files given on their command line (data check adds the options itself).
READS_SPECIMENS = ("simulate", "evaluate", "fit", "predict", "identifiability")


def add(parser: argparse.ArgumentParser) -> None:
    """``--units`` and ``--rebuild-time``: how to read the specimen files (``bwbench.data.units``)."""
    parser.add_argument(
        "--units",
        metavar="QUANTITY=UNIT,...",
        help="the units the specimen files' numbers are in, whatever their headers say, e.g. "
        "displacement=in,force=kip (converted to mm, N, s on reading; a header may declare them "
        "itself: displacement_in, force_kip, force_kN, velocity_in_s, time_ms, ...)",
    )
    parser.add_argument(
        "--rebuild-time",
        action="store_true",
        help="rebuild a time column printed with too few digits as t0 + k/fs (only an even grid that was rounded)",
    )
