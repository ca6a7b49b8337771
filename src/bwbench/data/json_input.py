"""Reading a user's JSON file (bounds, parameters): one line naming the file and line on error."""

from __future__ import annotations

import json
from pathlib import Path

from bwbench.data.input_files import read_text
from bwbench.errors import InputFileError


def read_json_file(path):
    """The parsed content of ``path``; ``InputFileError`` if it cannot be read or is not JSON."""
    path = Path(path)
    text = read_text(path)  # a regular file of bounded size, or one line naming it
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise InputFileError(path, err.lineno, f"not valid JSON: {err.msg}") from None
