"""Where the shipped data are: ``SHIPPED``, the installed package ``bwbench.shipped`` (the repository's
``data/`` folder, found through ``importlib.resources`` so that an installed wheel finds it too), and
``CHECKOUT``, the source checkout it sits in (None for an installed wheel)."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

SHIPPED = Path(str(files("bwbench.shipped")))
PAPER_TABLES = SHIPPED / "paper"
SPECIMENS = SHIPPED / "specimens"
MR_DAMPER = SHIPPED / "mr_damper"
CHECKOUT = SHIPPED.parent if (SHIPPED.parent / "pyproject.toml").is_file() else None


def working_root() -> Path:
    """The folder relative data paths of a study resolve against when its TOML gives none: the source
    checkout, else the current folder."""
    return CHECKOUT if CHECKOUT is not None else Path.cwd()
