"""Report content as blocks, rendered to markdown and to one self-contained HTML file.

The HTML has its figures as base64 data URIs, inline CSS, no scripts and no external links or
fonts: it opens from a file with no network. It reads on a phone and prints: a viewport, figures
that scale (on a narrow screen they keep a readable size in their own scrolling box, and open full
size from the PNG beside the report), wide tables that scroll in their own box with the label column
fixed, and tables longer than ``COLLAPSE_ROWS`` collapsed (``<details>``) with their CSV beside.
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

import pandas as pd

COLLAPSE_ROWS = 30  # a table longer than this is collapsed, its CSV written beside the report


class Document:
    """Report content as blocks, rendered to markdown and to self-contained HTML."""

    def __init__(self, out_dir: Path):
        self.out_dir = out_dir
        self.blocks: list[tuple] = []

    def h(self, level: int, text: str):
        self.blocks.append(("h", level, text))

    def p(self, text: str):
        self.blocks.append(("p", text))

    def banner(self, text: str):
        self.blocks.append(("banner", text))

    def bullets(self, items):
        self.blocks.append(("ul", list(items)))

    def box(self, items):
        """The answer at a glance: bullets in a framed box."""
        self.blocks.append(("box", list(items)))

    def table(self, frame: pd.DataFrame, caption: str = "", csv: str | None = None):
        """A table; one longer than ``COLLAPSE_ROWS`` rows is collapsed and written as ``csv`` (default:
        a name made from the caption) into the output folder."""
        frame = frame.astype(str)
        if len(frame) > COLLAPSE_ROWS:
            csv = csv or f"table_{_slug(caption or 'data')}.csv"
            self.out_dir.mkdir(parents=True, exist_ok=True)
            from bwbench.data.output_paths import write_frame

            write_frame(frame, self.out_dir / csv, index=False)
        self.blocks.append(("table", frame, caption, csv if len(frame) > COLLAPSE_ROWS else None))

    def figure(self, png: Path, caption: str):
        self.blocks.append(("img", Path(png), caption))

    def pre(self, text: str):
        self.blocks.append(("pre", text))

    # markdown ---------------------------------------------------------------------------------
    def markdown(self) -> str:
        out = []
        for block in self.blocks:
            kind = block[0]
            if kind == "h":
                out.append("#" * block[1] + " " + _md(block[2], one_line=True))
            elif kind == "p":
                out.append(_md(block[1]))
            elif kind == "banner":
                out.append(f"> **{_md(block[1], one_line=True)}**")
            elif kind in ("ul", "box"):
                out.append("\n".join(f"- {_md(item, one_line=True)}" for item in block[1]))
            elif kind == "table":
                frame, caption, csv = block[1], _md(block[2], one_line=True), block[3]
                cells = lambda row: "| " + " | ".join(_md(c, one_line=True).replace("|", "\\|") for c in row) + " |"  # noqa: E731
                lines = [cells(frame.columns), "|" + "|".join("---" for _ in frame.columns) + "|"]
                lines += [cells(row) for row in frame.itertuples(index=False)]
                if csv:  # GitHub renders <details> in markdown too
                    out.append(
                        f"<details><summary>{html.escape(block[2])} ({len(frame)} rows; data: {html.escape(csv)})</summary>"
                        "\n\n" + "\n".join(lines) + "\n\n</details>"
                    )
                else:
                    out.append((f"*{caption}*\n\n" if caption else "") + "\n".join(lines))
            elif kind == "img":
                png, caption = block[1], _md(block[2], one_line=True)
                out.append(f"![{caption}]({png.name})\n\n*{caption}* (data: `{png.with_suffix('.csv').name}`)")
            elif kind == "pre":  # a fence longer than any run of backticks in the text: it cannot end early
                fence = "`" * max(3, 1 + max((len(run) for run in re.findall(r"`+", block[1])), default=0))
                out.append(f"{fence}\n{block[1]}\n{fence}")
        return "\n\n".join(out) + "\n"

    # html -------------------------------------------------------------------------------------
    @staticmethod
    def _inline(text: str) -> str:
        text = html.escape(text)
        text = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", text)
        text = _EMPHASIS.sub(r"<em>\1</em>", text)
        return re.sub(r"`(.+?)`", r"<code>\1</code>", text)

    def html(self, title: str) -> str:
        body = []
        for block in self.blocks:
            kind = block[0]
            if kind == "h":  # an id to link to (report.html#ranking)
                body.append(f'<h{block[1]} id="{_slug(block[2], 8)}">{self._inline(block[2])}</h{block[1]}>')
            elif kind == "p":
                body.append(f"<p>{self._inline(block[1])}</p>")
            elif kind == "banner":
                body.append(f'<div class="banner">{self._inline(block[1])}</div>')
            elif kind == "ul":
                body.append("<ul>" + "".join(f"<li>{self._inline(i)}</li>" for i in block[1]) + "</ul>")
            elif kind == "box":
                body.append(
                    '<div class="answer"><ul>'
                    + "".join(f"<li>{self._inline(i)}</li>" for i in block[1])
                    + "</ul></div>"
                )
            elif kind == "table":
                frame, caption, csv = block[1], block[2], block[3]
                # text columns left, number columns right (decided per column, so a column reads as one)
                # a column of long texts (backend options) wraps, so the table fits the page
                align = (
                    [
                        ""
                        if all(_NUMBER.match(str(c)) for c in frame[col])
                        else ' class="text long"'
                        if max(len(str(c)) for c in frame[col]) > 40
                        else ' class="text"'
                        for col in frame.columns
                    ]
                    if len(frame)
                    else [""] * len(frame.columns)
                )
                head = "".join(f"<th{a}>{self._inline(str(c))}</th>" for a, c in zip(align, frame.columns))
                rows = "".join(
                    "<tr>" + "".join(f"<td{a}>{self._inline(str(c))}</td>" for a, c in zip(align, row)) + "</tr>"
                    for row in frame.itertuples(index=False)
                )
                # the caption outside the scrolling box: it wraps to the page, not to the table's width
                cap = f'<p class="caption">{self._inline(caption)}</p>' if caption and not csv else ""
                table = (
                    f'{cap}<div class="scroll"><table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table></div>'
                )
                if csv:
                    link = f'<a href="{html.escape(csv)}">{html.escape(csv)}</a>'
                    table = (
                        f"<details><summary>{self._inline(caption)} ({len(frame)} rows; data: {link})</summary>"
                        f"{table}</details>"
                    )
                body.append(table)
            elif kind == "img":
                png, caption = block[1], block[2]
                data = base64.b64encode(png.read_bytes()).decode("ascii")
                csv_name = html.escape(png.with_suffix(".csv").name)
                body.append(
                    f'<figure><div class="figure"><a href="{html.escape(png.name)}" title="full size">'
                    f'<img alt="{html.escape(caption)}" src="data:image/png;base64,{data}"></a></div>'
                    f"<figcaption>{self._inline(caption)} (data: <code>{csv_name}</code>)</figcaption>"
                    "</figure>"
                )
            elif kind == "pre":
                body.append(f"<pre>{html.escape(block[1])}</pre>")
        head = (
            f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n</head>\n"
        )
        return head + "<body>\n" + "\n".join(body) + "\n</body>\n</html>\n"


def _md(text, one_line: bool = False) -> str:
    """Text for report.md with the markup data could carry made inert: a file name, a manifest field or
    a column name like ``<img src=x onerror=...>`` would otherwise be raw HTML that a Markdown viewer
    renders (and runs). Only what starts a tag, a comment or an autolink (``<`` before a letter, ``/``,
    ``!`` or ``?``) is escaped, so "p < 0.05" reads as written; ``](`` is broken so data cannot become a
    link; ``one_line``: a line break (which would end a table row or a list item) becomes a space."""
    text = _TAG_START.sub("&lt;", str(text)).replace("](", "]\\(")
    return " ".join(text.splitlines()) if one_line else text


_TAG_START = re.compile(r"<(?=[A-Za-z/!?])")


def _slug(text: str, words: int = 6) -> str:
    return "-".join(re.findall(r"[a-z0-9.]+", text.lower())[:words]).strip(".-") or "data"


# *emphasis*: a star after a space or an opening bracket, a word character next to it inside; not the
# significance star of "1.87×*" nor the star of a footnote.
_EMPHASIS = re.compile(r"(?:(?<=^)|(?<=[\s(\[]))\*(?=[^\s*])([^*\n]+?)(?<=[^\s*])\*(?![\w*])")

# A cell that reads as a number: 4,100 / -0.0103 / 4.9e-04 / 75% / 1.1* / ∞ / – (missing) / 10.2 … 9.54
_NUMBER = re.compile(r"^\s*(([-+−≤<>~]?\s*[\d.,]+(e[-+]?\d+)?\s*%?\*?)(\s*…\s*[-+−]?[\d.,]+(e[-+]?\d+)?)?|∞|–|)\s*$")

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; max-width: 1300px;
       margin: 1.5em auto; padding: 0 1em; color: #222; line-height: 1.45; }
h1 { border-bottom: 2px solid #444; padding-bottom: .2em; font-size: 1.7em; }
h2 { border-bottom: 1px solid #bbb; padding-bottom: .15em; margin-top: 2em; }
.banner { background: #fff3cd; border: 2px solid #d39e00; padding: .6em 1em; font-weight: bold; margin: 1em 0; }
.answer { background: #eef6ee; border: 2px solid #2e7d32; border-radius: 6px; padding: .3em 1em .3em 0;
          margin: 1em 0 1.5em; font-size: 1.05em; }
.answer li { margin: .35em 0; }
table { border-collapse: separate; border-spacing: 0; margin: 0 0 1.2em; font-size: .88em; }
.caption { font-style: italic; font-size: .9em; margin: 1em 0 .3em; }
th, td { border: 1px solid #ccc; border-width: 0 1px 1px 0; padding: .25em .5em; text-align: right;
         white-space: nowrap; background: #fff; }
tr > :first-child { border-left-width: 1px; }
thead tr:first-child > * { border-top-width: 1px; }
th { background: #f0f0f0; white-space: normal; vertical-align: bottom; }
th.text, td.text { text-align: left; }
td.long { white-space: normal; min-width: 16em; }
tbody tr:nth-child(even) td { background: #fafafa; }
/* wide tables scroll in their own box; the label column stays in view */
.scroll { overflow-x: auto; max-width: 100%; }
tr > :first-child { position: sticky; left: 0; z-index: 1; box-shadow: 1px 0 0 #bbb; }
details { margin: .6em 0 1.2em; }
summary { cursor: pointer; font-style: italic; }
figure { margin: 1em 0 2em; }
.figure { overflow-x: auto; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; display: block; }
figcaption { font-size: .9em; color: #444; }
code, pre { font-family: ui-monospace, "DejaVu Sans Mono", monospace; font-size: .9em; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; }
/* a phone: figures keep a readable size and scroll sideways in their box (tap one for full size) */
@media (max-width: 700px) {
  body { padding: 0 .6em; margin: .8em auto; }
  h1 { font-size: 1.35em; }
  figure img { max-width: none; width: 760px; }
  table { font-size: .82em; }
}
@media print {
  body { max-width: none; }
  .scroll, .figure { overflow: visible; }
  figure { break-inside: avoid; }
  tr > :first-child { position: static; box-shadow: none; }
}
"""
