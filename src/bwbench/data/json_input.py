"""Reading a user's JSON file (bounds, parameters): one line naming the file and line on error."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from bwbench.data.input_files import read_text
from bwbench.errors import InputFileError


class _Duplicate(ValueError):
    def __init__(self, key: str):
        super().__init__(key)
        self.key = key


def _no_duplicates(pairs):
    """An object of ``pairs``; ``_Duplicate`` for a key given twice: json.loads would keep the last one
    silently, and a file edited by hand may mean the first."""
    out = {}
    for key, value in pairs:
        if key in out:
            raise _Duplicate(key)
        out[key] = value
    return out


def read_json_file(path):
    """The parsed content of ``path``; ``InputFileError`` if it cannot be read, is not JSON, or has a key
    twice in one object."""
    path = Path(path)
    text = read_text(path)  # a regular file of bounded size, or one line naming it
    try:
        return json.loads(text, object_pairs_hook=_no_duplicates)
    except json.JSONDecodeError as err:
        raise InputFileError(path, err.lineno, f"not valid JSON: {err.msg}") from None
    except _Duplicate as dup:
        raise InputFileError(
            path,
            _line_of_duplicate(text),
            f"the key {json.dumps(dup.key)} appears twice in one object: JSON readers keep one of them "
            "silently; remove the other",
        ) from None


def _line_of_duplicate(text: str) -> int | None:
    """The line of the second occurrence of the first key given twice in one object of ``text``: parsed
    again with the pure-Python scanner, which tells where that object starts (only on this error)."""
    import json.scanner
    import re

    decoder: Any = json.JSONDecoder(object_pairs_hook=_no_duplicates)  # its scanner hooks are untyped
    starts: list[int] = []
    parse_object = decoder.parse_object

    def located(s_and_end, *args):
        try:
            return parse_object(s_and_end, *args)
        except _Duplicate:
            starts.append(s_and_end[1])  # innermost first: the object holding the duplicate
            raise

    decoder.parse_object = located
    decoder.scan_once = json.scanner.py_make_scanner(decoder)  # type: ignore[attr-defined]
    try:
        decoder.decode(text)
    except _Duplicate as dup:
        keys = [m.start() for m in re.finditer(re.escape(json.dumps(dup.key)) + r"\s*:", text[starts[0] :])]
        if len(keys) > 1:
            return text.count("\n", 0, starts[0] + keys[1]) + 1
    except ValueError:
        pass
    return None
