"""Report content as blocks, rendered to markdown and to one self-contained HTML file.

The HTML has its figures as base64 data URIs, inline CSS, no scripts and no external links or
fonts: it opens from a file with no network.
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

import pandas as pd


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

    def table(self, frame: pd.DataFrame, caption: str = ""):
        self.blocks.append(("table", frame.astype(str), caption))

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
                out.append("#" * block[1] + " " + block[2])
            elif kind == "p":
                out.append(block[1])
            elif kind == "banner":
                out.append(f"> **{block[1]}**")
            elif kind == "ul":
                out.append("\n".join(f"- {item}" for item in block[1]))
            elif kind == "table":
                frame, caption = block[1], block[2]
                cells = lambda row: "| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |"  # noqa: E731
                lines = [cells(frame.columns), "|" + "|".join("---" for _ in frame.columns) + "|"]
                lines += [cells(row) for row in frame.itertuples(index=False)]
                out.append((f"*{caption}*\n\n" if caption else "") + "\n".join(lines))
            elif kind == "img":
                png, caption = block[1], block[2]
                out.append(f"![{caption}]({png.name})\n\n*{caption}* (data: `{png.with_suffix('.csv').name}`)")
            elif kind == "pre":
                out.append("```\n" + block[1] + "\n```")
        return "\n\n".join(out) + "\n"

    # html -------------------------------------------------------------------------------------
    @staticmethod
    def _inline(text: str) -> str:
        text = html.escape(text)
        text = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", text)
        return re.sub(r"`(.+?)`", r"<code>\1</code>", text)

    def html(self, title: str) -> str:
        body = []
        for block in self.blocks:
            kind = block[0]
            if kind == "h":
                body.append(f"<h{block[1]}>{self._inline(block[2])}</h{block[1]}>")
            elif kind == "p":
                body.append(f"<p>{self._inline(block[1])}</p>")
            elif kind == "banner":
                body.append(f'<div class="banner">{self._inline(block[1])}</div>')
            elif kind == "ul":
                body.append("<ul>" + "".join(f"<li>{self._inline(i)}</li>" for i in block[1]) + "</ul>")
            elif kind == "table":
                frame, caption = block[1], block[2]
                # text columns left, number columns right (decided per column, so a column reads as one)
                # a column of long texts (backend options) wraps, so the table fits the page
                align = ['' if all(_NUMBER.match(str(c)) for c in frame[col]) else
                         ' class="text long"' if max(len(str(c)) for c in frame[col]) > 40 else ' class="text"'
                         for col in frame.columns] if len(frame) else [''] * len(frame.columns)
                head = "".join(f"<th{a}>{self._inline(str(c))}</th>" for a, c in zip(align, frame.columns))
                rows = "".join("<tr>" + "".join(f"<td{a}>{self._inline(str(c))}</td>" for a, c in zip(align, row))
                               + "</tr>" for row in frame.itertuples(index=False))
                cap = f"<caption>{self._inline(caption)}</caption>" if caption else ""
                body.append(f'<div class="scroll"><table>{cap}<thead><tr>{head}</tr></thead>'
                            f"<tbody>{rows}</tbody></table></div>")
            elif kind == "img":
                png, caption = block[1], block[2]
                data = base64.b64encode(png.read_bytes()).decode("ascii")
                csv_name = html.escape(png.with_suffix(".csv").name)
                body.append(f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
                            f"<figcaption>{self._inline(caption)} (data: <code>{csv_name}</code>)</figcaption>"
                            "</figure>")
            elif kind == "pre":
                body.append(f"<pre>{html.escape(block[1])}</pre>")
        head = (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
                f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n</head>\n")
        return head + "<body>\n" + "\n".join(body) + "\n</body>\n</html>\n"


# A cell that reads as a number: 4,100 / -0.0103 / 4.9e-04 / 75% / 1.1* / ∞ / – (missing) / 10.2 … 9.54
_NUMBER = re.compile(r"^\s*(([-+−≤<>~]?\s*[\d.,]+(e[-+]?\d+)?\s*%?\*?)(\s*…\s*[-+−]?[\d.,]+(e[-+]?\d+)?)?|∞|–|)\s*$")

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; max-width: 1500px;
       margin: 1.5em auto; padding: 0 1em; color: #222; line-height: 1.45; }
h1 { border-bottom: 2px solid #444; padding-bottom: .2em; }
h2 { border-bottom: 1px solid #bbb; padding-bottom: .15em; margin-top: 2em; }
.banner { background: #fff3cd; border: 2px solid #d39e00; padding: .6em 1em; font-weight: bold; margin: 1em 0; }
table { border-collapse: collapse; margin: .6em 0 1.2em; font-size: .88em; }
caption { caption-side: top; text-align: left; font-style: italic; padding-bottom: .3em; }
th, td { border: 1px solid #ccc; padding: .25em .5em; text-align: right; white-space: nowrap; }
th { background: #f0f0f0; white-space: normal; vertical-align: bottom; }
th.text, td.text { text-align: left; }
td.long { white-space: normal; min-width: 16em; }
tbody tr:nth-child(even) { background: #fafafa; }
.scroll { overflow-x: auto; }
figure { margin: 1em 0 2em; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: .9em; color: #444; }
code, pre { font-family: ui-monospace, "DejaVu Sans Mono", monospace; font-size: .9em; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; }
"""

