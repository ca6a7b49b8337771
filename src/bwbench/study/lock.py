"""One writer per study database: an OS lock on ``<db>.lock``, held for the whole ``compare``.

``fcntl.flock`` dies with the process that holds it, so a study killed by SIGKILL (or a power cut)
never leaves a stale lock: the file may stay, the lock does not. The file holds the holder's pid,
for the message the next ``compare`` prints. It is removed on a clean exit; a process that locks a
file some other process has just removed notices (the path no longer names the locked file) and
tries again, so two processes never both believe they hold the lock.

The lock file sits beside the database's real path (symbolic links resolved), so every spelling of
one database (``s.sqlite``, ``./s.sqlite``, ``../x/s.sqlite``, a link to it) takes the same lock.
"""

from __future__ import annotations

import os
from pathlib import Path

from bwbench.errors import UserError


def lock_path(db) -> Path:
    db = Path(os.path.realpath(db))
    return db.with_name(db.name + ".lock")


class StudyLock:
    """``with StudyLock(db):`` the one writer of ``db``, or ``UserError`` naming the pid of the other.

    Not reentrant: a second lock on the same database, even in the same process, is refused.
    """

    def __init__(self, db):
        self.db = Path(db)
        self.path = lock_path(db)
        self.fd = None

    def __enter__(self):
        import fcntl

        for _ in range(10):  # another process removing the file in between is rare; 10 is plenty
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as err:
                raise UserError(
                    f"{self.path}: cannot create the lock file of {self.db.name}: {err.strerror or err}"
                ) from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = _read_pid(fd)
                os.close(fd)
                raise UserError(
                    f"{self.db}: another bwbench compare (pid {holder}) is writing this study; "
                    "wait for it or pass another --db"
                ) from None
            except OSError as err:  # a file system without locks (some network mounts)
                os.close(fd)
                raise UserError(f"{self.path}: cannot lock: {err.strerror or err}") from None
            if _same_file(fd, self.path):
                break
            os.close(fd)  # removed by its previous holder after we opened it: take the new one
        else:
            raise UserError(f"{self.path}: cannot lock: the file keeps being replaced")
        try:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
        except OSError as err:  # a full disk: say so before any run starts
            os.close(fd)
            raise UserError(f"{self.path}: cannot write the lock file: {err.strerror or err}") from None
        self.fd = fd
        return self

    def __exit__(self, *exc):
        fd, self.fd = self.fd, None
        if fd is None:
            return
        try:
            if _same_file(fd, self.path):  # remove it while still holding the lock
                self.path.unlink()
        except OSError:  # left behind: harmless, the next compare locks it again
            pass
        finally:
            os.close(fd)  # releases the lock


def _same_file(fd: int, path: Path) -> bool:
    try:
        a, b = os.fstat(fd), os.stat(path)
    except OSError:
        return False
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def _read_pid(fd: int) -> str:
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
    except OSError:
        text = ""
    return text if text.isdigit() else "unknown"
