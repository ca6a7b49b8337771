"""Output files a command will write: checked before any work is done, so a long fit never ends in an
unwritable path, and an input is never overwritten by an output.

"The same file" means the same resolved path (``./s.csv``, ``../x/s.csv``, a symlink) or the same
device and inode (a hard link): either way writing the output would destroy the input.

Every output is written whole (a hidden file in the same folder, then renamed over the name) and never
through a symbolic link that leads out of its folder: a link planted in an output folder
(``fits/a.json -> ~/.bashrc``) would otherwise let a command overwrite a file it was never asked to
write. A link named on the command line is refused before any work; one met while writing (planted
during the run) is replaced by the output, the file it names left alone. Only the streams of
``/dev`` and ``/proc`` (``--out /dev/stdout``) are written through.
"""

from __future__ import annotations

import errno
import os
from contextlib import contextmanager
from pathlib import Path

from bwbench.errors import UserError

# What matplotlib writes (savefig's format comes from the file's extension).
FIGURE_FORMATS = (".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".ps", ".tif", ".tiff", ".webp")


def same_file(a, b) -> bool:
    """True if the paths ``a`` and ``b`` name one file: equal once resolved, or one device and inode."""
    a, b = Path(a), Path(b)
    try:
        if a.resolve() == b.resolve():
            return True
        sa, sb = os.stat(a), os.stat(b)
    except (OSError, RuntimeError):  # one does not exist (or a symlink loop): not the same existing file
        return False
    return (sa.st_dev, sa.st_ino) == (sb.st_dev, sb.st_ino)


def refuse_inputs(outputs: dict, inputs) -> None:
    """``UserError`` (one line, naming the flag and the file) if an output (flag -> path; None = not
    asked for) is one of ``inputs`` (paths; None entries ignored) by any spelling."""
    sources = [Path(p) for p in inputs if p is not None]
    for flag, path in outputs.items():
        if path is None:
            continue
        path = Path(path)
        for source in sources:
            if same_file(path, source):
                spelled = "" if source == path else f" (= {source})"
                raise UserError(
                    f"{flag} {path} is an input of this command{spelled}: it would be overwritten; "
                    "choose another file name"
                )


def is_stream(path) -> bool:
    """True for a path of ``/dev`` or ``/proc`` (``/dev/stdout``, ``/dev/fd/3``): a stream the user
    names to be written through, not a file to replace."""
    return os.path.abspath(path).startswith(("/dev/", "/proc/"))


def link_out_of_folder(path) -> Path | None:
    """The file a symbolic link ``path`` names when that file is outside the link's own folder (or the
    link is a loop); None for anything else (a file, a link within its folder, a stream)."""
    path = Path(path)
    if not path.is_symlink() or is_stream(path):
        return None
    target = Path(os.path.realpath(path))
    if target.parent == Path(os.path.realpath(path.parent)) and not target.is_symlink():
        return None
    return target


def refuse_link_out(path, flag: str = "") -> None:
    """``UserError`` if the output ``path`` is a symbolic link out of its folder (see the module)."""
    target = link_out_of_folder(path)
    if target is not None:
        named = f"{flag} {path}" if flag else str(path)
        raise UserError(
            f"{named} is a symbolic link to {target}, outside {Path(path).parent}: bwbench does not write "
            "through a link out of the output's folder; remove the link, or name the file itself"
        )


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
        try_writing(path)


def try_writing(path) -> None:
    """Open ``path`` for appending and close it, changing nothing (a new file is removed again);
    ``UserError`` naming it if that fails. Permission bits say little to root, on network folders or
    on /proc: only trying tells. A named pipe is opened without blocking, so one with no reader is
    refused at once instead of waiting for a reader forever (``>(gzip > x.gz)`` has one, and works)."""
    path = Path(path)
    refuse_link_out(path)
    if path.is_symlink() and not is_stream(path):
        path = Path(os.path.realpath(path))  # a link within its folder: its file is what is written
    existed = path.exists()
    flags = os.O_WRONLY | os.O_APPEND | (0 if existed else os.O_CREAT | os.O_EXCL)
    try:
        os.close(os.open(path, flags | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0), 0o666))
    except OSError as err:
        if err.errno == errno.ENXIO:
            raise UserError(f"cannot write {path}: a named pipe (FIFO) that nothing reads") from None
        raise UserError(f"cannot write {path}: {err.strerror or err}") from None
    if not existed:
        path.unlink()


def check_folder(flag: str, folder) -> None:
    """``UserError`` if the output folder ``folder`` exists and is not a folder."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise UserError(f"{flag} {folder}: is a file, not a folder; name a folder for the output")


def check_outputs(outputs: dict, inputs=()) -> None:
    """``outputs``: flag -> path (None = not asked for). None may be one of the ``inputs`` (the same
    file by any spelling), no two may be the same file, each must be writable, and a ``--plot`` must
    name a figure format."""
    refuse_inputs(outputs, inputs)
    given = {flag: Path(p) for flag, p in outputs.items() if p is not None}
    for flag, path in given.items():
        if flag == "--plot" and path.suffix.lower() not in FIGURE_FORMATS:
            raise UserError(
                f"--plot {path}: the figure format comes from the extension; use one of {', '.join(FIGURE_FORMATS)}"
            )
    for flag, path in given.items():
        refuse_link_out(path, flag)
    flags = list(given)
    for i, first in enumerate(flags):
        if any(same_file(given[first], given[second]) for second in flags[i + 1 :]):
            raise UserError("two outputs name the same file: " + ", ".join(f"{f} {p}" for f, p in given.items()))
    check_writable(*given.values())


def refuse_inputs_in_folder(flag: str, folder, inputs, suffixes) -> None:
    """For an output folder (``report --out``): ``UserError`` if an input file lies in ``folder`` with
    one of ``suffixes`` (the kinds of file written there), since its name could be one the command
    writes; or if ``folder`` is itself an input file."""
    folder = Path(folder)
    for source in (Path(p) for p in inputs if p is not None):
        if same_file(folder, source):
            raise UserError(f"{flag} {folder} is an input of this command: it needs a folder for its output")
        if source.suffix.lower() in suffixes and same_file(source.parent, folder):
            raise UserError(
                f"{flag} {folder} holds {source.name}, an input of this command, and it writes "
                f"{'/'.join(suffixes)} files there: choose another folder"
            )


@contextmanager
def writing(path):
    """Turn an ``OSError`` of writing ``path`` into a ``UserError`` that names it: a full disk raises
    ``OSError`` with no file name (``write`` and ``close`` do not know it)."""
    try:
        yield
    except OSError as err:
        if err.filename:  # the error knows its file (which may be another one than ``path``)
            raise UserError(f"{err.filename}: {err.strerror or err}") from None
        raise UserError(f"cannot write {path}: {err.strerror or err}") from None


@contextmanager
def replaced_whole(path):
    """Yield the path to write ``path``'s content to: a hidden file beside it (same suffix, so a figure
    keeps its format) that replaces ``path`` only once written, so an interrupted or failed write
    (Ctrl-C, a full disk) leaves the old file or none, never half a file. A stream (``/dev/stdout``) or
    a path that is not a regular file (a FIFO) is written directly: it cannot be replaced. A symbolic
    link within its folder has the file it names replaced (the link is kept); a link out of its folder
    is itself replaced, never written through (see the module)."""
    path = Path(path)
    if is_stream(path):
        yield path
        return
    if path.is_symlink() and link_out_of_folder(path) is None:
        path = Path(os.path.realpath(path))  # write the file the link names, and keep the link
    if path.exists() and not path.is_file() and not path.is_symlink():
        yield path
        return
    partial = path.with_name(f".{path.stem}.partial-{os.getpid()}{path.suffix}")
    try:  # O_EXCL: never through a link planted at the hidden name either
        os.close(os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    except OSError:  # a folder that takes no new file (the file itself is writable): write in place
        if path.is_symlink():
            raise UserError(
                f"cannot write {path}: a symbolic link out of its folder, in a folder that takes no new file"
            ) from None
        yield path
        return
    try:
        yield partial
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)


def write_text(path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` whole (``replaced_whole``)."""
    with replaced_whole(path) as partial:
        Path(partial).write_text(text, encoding="utf-8")


def write_frame(frame, path, **to_csv) -> None:
    """Write the DataFrame ``frame`` as CSV (``DataFrame.to_csv`` options) to ``path`` whole."""
    with replaced_whole(path) as partial:
        frame.to_csv(partial, **to_csv)
