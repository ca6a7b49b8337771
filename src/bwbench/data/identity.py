"""The identity of a study's data: a SHA-256 over the bytes of the files a loss reads, wherever they are."""

from __future__ import annotations

import hashlib
from pathlib import Path


def files_sha256(paths, names=None) -> str:
    """SHA-256 over each file's name (``names``, default the file names) and bytes, in order.

    The same data moved to another folder give the same digest; an edited file gives another.
    """
    paths = [Path(p) for p in paths]
    names = [p.name for p in paths] if names is None else list(names)
    digest = hashlib.sha256()
    for name, path in zip(names, paths, strict=True):
        digest.update(name.encode("utf-8") + b"\0")
        digest.update(path.read_bytes())
    return digest.hexdigest()
