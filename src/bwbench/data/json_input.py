"""Reading a user's JSON file (bounds, parameters): one line naming the file and line on error."""
from __future__ import annotations

import json
from pathlib import Path

from bwbench.errors import InputFileError


def read_json_file(path):
    """The parsed content of ``path``; ``InputFileError`` if it cannot be read or is not JSON."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise InputFileError(path, None, f"cannot read: {getattr(err, 'strerror', None) or err}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise InputFileError(path, err.lineno, f"not valid JSON: {err.msg}") from None
