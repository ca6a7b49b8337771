"""Output files a command will write: checked before any work is done, so a long fit never ends in an
unwritable path."""

from __future__ import annotations

from pathlib import Path

from bwbench.errors import UserError


def check_writable(*paths) -> None:
    """Refuse an output path whose folder does not exist before any work is done, not after."""
    for path in paths:
        if path is None:
            continue
        folder = Path(path).resolve().parent
        if not folder.is_dir():
            raise UserError(f"cannot write {path}: folder {folder} does not exist")
