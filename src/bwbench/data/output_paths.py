"""Output files a command will write: checked before any work is done, so a long fit never ends in an
unwritable path, and an input is never overwritten by an output."""

from __future__ import annotations

from pathlib import Path

from bwbench.errors import UserError

# What matplotlib writes (savefig's format comes from the file's extension).
FIGURE_FORMATS = (".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".ps", ".tif", ".tiff", ".webp")


def check_writable(*paths) -> None:
    """Refuse an output path that cannot be written before any work is done, not after."""
    for path in paths:
        if path is None:
            continue
        path = Path(path)
        folder = path.resolve().parent
        if not folder.is_dir():
            raise UserError(f"cannot write {path}: folder {folder} does not exist")
        if path.is_dir():
            raise UserError(f"cannot write {path}: it is a folder")
        # Try it: permission bits say little to root, on network folders or on /proc.
        existed = path.exists()
        try:
            with open(path, "a" if existed else "x", encoding="utf-8"):
                pass
        except OSError as err:
            raise UserError(f"cannot write {path}: {err.strerror or err}") from None
        if not existed:
            path.unlink()


def check_outputs(outputs: dict, inputs=()) -> None:
    """``outputs``: flag -> path (None = not asked for). Each must be writable, none may be one of the
    ``inputs`` (the same file by any spelling), and a ``--plot`` must name a figure format."""
    given = {flag: Path(p) for flag, p in outputs.items() if p is not None}
    for flag, path in given.items():
        for source in inputs:
            if source is not None and Path(source).exists() and path.exists() and path.samefile(source):
                raise UserError(f"{flag} {path} is an input of this command: it would be overwritten")
        if flag == "--plot" and path.suffix.lower() not in FIGURE_FORMATS:
            raise UserError(f"--plot {path}: the figure format comes from the extension; use one of "
                            f"{', '.join(FIGURE_FORMATS)}")
    resolved = [p.resolve() for p in given.values()]
    if len(set(resolved)) != len(resolved):
        raise UserError("two outputs name the same file: " + ", ".join(f"{f} {p}" for f, p in given.items()))
    check_writable(*given.values())
