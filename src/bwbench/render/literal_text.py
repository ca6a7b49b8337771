"""Text from the data drawn as written, never as mathtext.

A specimen, column or optimiser name reaches titles, legends and labels; with a "$" in it
(``r$\\alpha$.csv``) matplotlib would parse it as mathtext and fail on what it does not know (a
ParseFatalException ending the figure, and the command). bwbench's own labels use no mathtext, so
every text of a figure is made literal, except the tick labels and the axes' offset texts, which
matplotlib's own formatters write in mathtext (10², ×10⁵) and which never carry data.
"""

from __future__ import annotations


def make_literal(fig) -> None:
    """Every text of ``fig`` (titles, labels, legends, annotations) drawn as written."""
    from matplotlib.text import Text

    generated = set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis, getattr(ax, "zaxis", None)):
            if axis is None:
                continue
            generated.add(id(axis.offsetText))
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                generated.update((id(tick.label1), id(tick.label2)))
    for text in fig.findobj(Text):
        if id(text) not in generated:
            text.set_parse_math(False)
