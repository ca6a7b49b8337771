"""Output that survives any locale: what bwbench prints uses symbols (N², ≥, …, ∮F·dx, R̂) that a
Latin-1 or ASCII terminal cannot show (``LC_ALL=de_DE.ISO-8859-1``, ``PYTHONIOENCODING=ascii``, a
C locale); printing one raised ``UnicodeEncodeError`` and ended the command with a traceback.

The command line's stdout and stderr keep their encoding (a UTF-8 terminal sees every symbol) and
write what it cannot hold in ASCII words instead: ``N^2``, ``>=``, ``...``, ``loop-integral F*dx``,
``R^``; a letter with an accent loses it (``ẋ`` -> ``x``); anything else becomes ``?``. Files are
always written in UTF-8, whatever the locale.
"""

from __future__ import annotations

import codecs
import sys
import unicodedata

HANDLER = "bwbench-ascii"

# the symbols bwbench's own messages use, in words of ASCII
FALLBACK = {
    "…": "...",
    "≥": ">=",
    "≤": "<=",
    "≠": "!=",
    "≈": "~",
    "±": "+/-",
    "×": "x",
    "·": "*",
    "−": "-",
    "–": "-",
    "—": "--",
    "→": "->",
    "←": "<-",
    "²": "^2",
    "³": "^3",
    "⁻": "^-",
    "¹": "^1",
    "∮": "loop-integral ",
    "∫": "integral ",
    "∞": "inf",
    "√": "sqrt",
    "µ": "u",
    "μ": "u",
    "°": " deg",
    "Δ": "Delta ",
    "η": "eta",
    "γ": "gamma",
    "β": "beta",
    "α": "alpha",
    "ξ": "xi",
    "σ": "sigma",
    "θ": "theta",
    "ẋ": "dx/dt",
    "ẍ": "d2x/dt2",
    "\u0302": "^",  # the hat of R̂
    "‘": "'",
    "’": "'",
    "“": '"',
    "”": '"',
    "✓": "ok",
    "✗": "x",
    "█": "#",
    "▏": "|",
    "▎": "|",
    "▍": "|",
    "▌": "|",
    "▋": "|",
    "▊": "|",
    "▉": "|",
}


def _words(err: UnicodeError) -> tuple[str, int]:
    if not isinstance(err, UnicodeEncodeError):
        raise err
    text = err.object[err.start : err.end]
    return "".join(_word(c, err.encoding) for c in text), err.end


def _word(char: str, encoding: str) -> str:
    if char in FALLBACK:
        return FALLBACK[char]
    kept = "".join(part if part in FALLBACK or part.isascii() else "" for part in unicodedata.normalize("NFKD", char))
    return "".join(FALLBACK.get(part, part) for part in kept) or "?"


codecs.register_error(HANDLER, _words)


def survive_any_locale(*streams) -> None:
    """Have ``streams`` (default stdout and stderr) write what their encoding cannot hold as ASCII words
    instead of raising; a UTF-8 stream is left as it is."""
    for stream in streams or (sys.stdout, sys.stderr):
        encoding = (getattr(stream, "encoding", None) or "").lower().replace("_", "-")
        if encoding in ("utf-8", "utf8", "utf-16", "utf-32") or not hasattr(stream, "reconfigure"):
            continue
        try:
            stream.reconfigure(errors=HANDLER)
        except (ValueError, OSError):  # a closed or detached stream: nothing will be written to it
            pass
