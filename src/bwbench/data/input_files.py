"""Reading an input file safely: only a regular file, and only up to a stated size.

A named pipe (FIFO) would block the reader forever, a device such as ``/dev/zero`` never ends, and a
socket cannot be read at all: each is refused at once with one line naming the file and what it is.
A regular file larger than the limit (``bwbench.limits``) is refused before a byte is read.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import bwbench.limits as limits
from bwbench.errors import InputFileError

_KINDS = (
    (stat.S_ISFIFO, "a named pipe (FIFO)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISDIR, "a directory"),
)


def not_regular(mode: int) -> str | None:
    """What a file of ``st_mode`` ``mode`` is when it is not a regular file (e.g. "a named pipe (FIFO)")."""
    if stat.S_ISREG(mode):
        return None
    return next((kind for test, kind in _KINDS if test(mode)), "not a regular file")


def check_regular(path) -> None:
    """``InputFileError`` unless ``path`` is a regular file (following symlinks)."""
    path = str(path)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise InputFileError(path, None, "no such file") from None
    except OSError as err:
        raise InputFileError(path, None, f"cannot read file: {err.strerror or err}") from None
    kind = not_regular(mode)
    if kind == "a directory":
        raise InputFileError(path, None, "is a directory, not a file")
    if kind:
        raise InputFileError(path, None, f"is {kind}, not a regular file: bwbench reads only files")


def read_bytes(path, limit_variable: str = "BWBENCH_MAX_INPUT_MB") -> bytes:
    """The bytes of the regular file ``path``, at most the limit ``limit_variable`` (MiB).

    Raises ``InputFileError(path, None, ...)`` for a missing file, a directory, a FIFO, device or
    socket, a file over the limit (saying how to raise it), or an error of the system.
    """
    path = str(path)
    check_regular(path)
    limit_mb = limits.maximum(limit_variable)
    limit = limit_mb * 2**20
    try:
        # O_NONBLOCK: had a FIFO replaced the file since the check, opening it still returns at once.
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
        with os.fdopen(fd, "rb") as fh:
            kind = not_regular(os.fstat(fh.fileno()).st_mode)
            if kind:
                raise InputFileError(path, None, f"is {kind}, not a regular file: bwbench reads only files")
            size = os.fstat(fh.fileno()).st_size
            data = b"" if size > limit else fh.read(limit + 1)
    except InputFileError:
        raise
    except MemoryError:
        raise InputFileError(path, None, "not enough memory to read the file") from None
    except OSError as err:
        raise InputFileError(path, None, f"cannot read file: {err.strerror or err}") from None
    if size > limit or len(data) > limit:
        raise InputFileError(
            path,
            None,
            f"{max(size, len(data)) / 2**20:.0f} MiB, above the limit of {limit_mb} "
            f"MiB for this kind of file; if you mean it, raise the limit: "
            f"{limit_variable}=<MiB> bwbench ...",
        )
    return data


def read_text(path, limit_variable: str = "BWBENCH_MAX_TEXT_MB") -> str:
    """The UTF-8 text of the regular file ``path`` (see ``read_bytes``); ``InputFileError`` if it is
    not UTF-8."""
    data = read_bytes(path, limit_variable)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        raise InputFileError(Path(path), line, f"not UTF-8 text (byte 0x{data[err.start]:02x})") from None


def refuse_same_content(paths) -> None:
    """``UserError`` when two of ``paths`` (different files) hold the same bytes: a copy of one test
    would count twice in a joint fit. Sizes first, so files of different sizes are never read."""
    import hashlib

    from bwbench.errors import UserError

    seen: dict[tuple, str] = {}
    by_size: dict[int, list] = {}
    for path in (p for p in paths if isinstance(p, (str, Path))):
        try:
            info = os.stat(path)
        except OSError:  # not there: the reading says so, naming it
            continue
        if stat.S_ISREG(info.st_mode):  # a FIFO or a device is refused by the reading, never read here
            by_size.setdefault(info.st_size, []).append(path)
    for same_size in (group for group in by_size.values() if len(group) > 1):
        for path in same_size:
            try:
                digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
            except OSError:
                continue
            key = (os.stat(path).st_size, digest)
            if key in seen:
                raise UserError(
                    f"{path} holds the same bytes as {seen[key]}: a joint fit would count one test twice "
                    "(a copy?); name it once"
                )
            seen[key] = str(path)
