"""The look every study figure shares: one style per backend, the theme, the legend, saving.

A backend keeps one colour and marker in every figure of every report, fixed by its name
(``BACKEND_LOOK``): cmaes is blue with circles in the quick study, the paper study and the benchmark
alike, whatever its rank. The colours are Okabe–Ito's colour-blind-safe seven, then four of Paul
Tol's; black is kept for the measured data, the truth and the noise floor, random search is always
dark grey. A backend not in the table (a plug-in) gets the first free colour and marker of
``EXTRA_LOOKS`` in name order. When a study compares formulations side by side (labels
``"cmaes [paper]"``, ``"cmaes [identifiable]"``), both formulations of a backend share its colour and
marker: solid line and filled marker for the identifiable formulation, dashed line and open marker
for the paper's. Other variants (models compared side by side) get a line style each, in name order.

Figures are sized for a 1,200 px HTML column: at most ``MAX_WIDTH_IN`` inches wide at ``DPI``,
no text below ``MIN_FONT_PT``.
"""

from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
import pandas as pd
from cycler import cycler  # matplotlib's own dependency
from matplotlib import patheffects
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from bwbench.render.labels import split_label

DPI = 110
MAX_WIDTH_IN = 11.0  # 1,210 px at DPI: a report's column, shown at 100 %
MIN_FONT_PT = 9.0
SYNTHETIC_LABEL = "SYNTHETIC DATA (generated from the paper's Tables 6–8)"
MEASURED_LABEL = "MEASURED DATA (files not marked synthetic)"  # what a figure of data without a manifest shows

# Okabe & Ito (2008), without black: the seven most distinct first, yellow (weak on white) last.
OKABE_ITO = ("#0072B2", "#E69F00", "#009E73", "#D55E00", "#CC79A7", "#56B4E9", "#F0E442")
LIGHT = {"#F0E442"}  # drawn with a dark edge
RANDOM_COLOUR = "#404040"  # the baseline: dark grey, so it reads as the reference
RANDOM_MARKER = "X"
# Each built-in backend's colour and marker, by name: the same in every report.
BACKEND_LOOK = {
    "cmaes": ("#0072B2", "o"),
    "lsq-trf": ("#E69F00", "s"),
    "de": ("#009E73", "^"),
    "paper-ga": ("#D55E00", "D"),
    "pso": ("#CC79A7", "v"),
    "nlopt-bobyqa": ("#56B4E9", "P"),
    "firefly": ("#F0E442", ">"),
    "nlopt-sbplx": ("#882255", "<"),
    "nlopt-neldermead": ("#999933", "p"),
    "anneal": ("#661100", "h"),
    "emcee": ("#117733", "*"),
}
# Plug-in backends: Paul Tol's other colours, then the built-ins' again with other markers.
EXTRA_LOOKS = tuple(zip(("#332288", "#88CCEE", "#AA4499", "#44AA99", "#DDCC77"), ("d", "8", "H", "X", "p"))) + tuple(
    (colour, marker) for colour in OKABE_ITO for marker in ("d", "8")
)
# Formulations compared side by side: solid/filled for the identifiable one, dashed/open for the paper's.
VARIANT_LOOK = {"identifiable": ("-", True), "paper": ("--", False)}
# Other variants (models compared side by side), in name order: a line style and fill each.
OTHER_VARIANT_LOOK = (("-", True), ("--", False), (":", True), ("-.", False), ("-.", True), (":", False))
TRUTH: dict = {"color": "black", "marker": "x", "ls": "", "ms": 8, "mew": 2.0}


@dataclass(frozen=True)
class Style:
    """How one backend (run label) is drawn."""

    label: str
    colour: str
    linestyle: str
    marker: str
    filled: bool

    def line(self, lw: float = 1.6, markers: bool = False, **extra) -> dict:
        """``ax.plot`` keyword arguments for a line (with its marker when ``markers``)."""
        kw = {"color": self.colour, "ls": self.linestyle, "lw": lw, "path_effects": self.outline(lw)}
        if markers:
            kw.update(self.point(), ls=self.linestyle)
        return {**kw, **extra}

    def outline(self, lw: float) -> list:
        """A thin dark edge around a light colour (Okabe–Ito's yellow is faint on white)."""
        if self.colour not in LIGHT:
            return []
        return [patheffects.Stroke(linewidth=lw + 1.0, foreground="0.35"), patheffects.Normal()]

    def point(self, ms: float = 6.0, **extra) -> dict:
        """``ax.plot`` keyword arguments for markers only; open markers keep a white fill so they
        stay open on top of other data."""
        edge = "0.35" if self.colour in LIGHT else self.colour
        return {
            "color": self.colour,
            "ls": "",
            "marker": self.marker,
            "ms": ms,
            "mec": edge,
            "mfc": self.colour if self.filled else "white",
            "mew": 1.2,
            **extra,
        }

    def handle(self, text: str | None = None, line: bool = True, marker: bool = True) -> Line2D:
        """A legend entry: line and marker, the marker alone (``line=False``) or the line alone
        (``marker=False``), as the figure draws it."""
        kw = self.point(ms=6.5) if marker else {"color": self.colour}
        if line:
            kw.update(ls=self.linestyle, lw=1.6, path_effects=self.outline(1.6))
        return Line2D([], [], label=self.label if text is None else text, **kw)


def median_order(runs: pd.DataFrame) -> list[str]:
    """Labels of the ranking runs in ``runs``, lowest median final loss first (failed runs count as
    infinitely bad; ties by name)."""
    ranking = runs[runs["kind"] == "ranking"] if "kind" in runs else runs
    mse = ranking["mse"].astype(float).where(ranking["status"] == "ok", np.inf)
    medians = mse.where(np.isfinite(mse), np.inf).groupby(ranking["optimizer"]).median()
    return sorted(medians.index, key=lambda name: (medians[name], name))


def ranking_order(study, order=None) -> list[str]:
    """Every run label of ``study``: those of ``order`` first (the report's ranking), then the other
    ranking labels by median final loss, then labels found only in other runs (e.g. posterior)."""
    known = list(dict.fromkeys(study.runs["optimizer"]))
    first = [o for o in (order or []) if o in known]
    rest = [o for o in median_order(study.runs) if o not in first]
    return list(dict.fromkeys(first + rest + known))


def styles(study, order=None) -> dict[str, Style]:
    """Label → ``Style`` for every run label of ``study``, in ranking order (see ``ranking_order``).
    The same ``order`` gives the same styles in every figure."""
    return styles_for(ranking_order(study, order))


def styles_for(labels) -> dict[str, Style]:
    """Label → ``Style`` for ``labels`` (in the given order, which is the legend's): colour and
    marker by backend name (see the module docstring), line style and fill by formulation."""
    labels = list(dict.fromkeys(labels))
    split = {label: split_label(label) for label in labels}
    variants = sorted({v for _, v in split.values() if v is not None and v not in VARIANT_LOOK})
    looks = backend_looks(base for base, _ in split.values())
    out = {}
    for label, (base, variant) in split.items():
        colour, marker = looks[base]
        linestyle, filled = "-", True
        if variant is not None:  # the formulation, not the backend, sets line style and fill
            linestyle, filled = (
                VARIANT_LOOK.get(variant) or OTHER_VARIANT_LOOK[variants.index(variant) % len(OTHER_VARIANT_LOOK)]
            )
        out[label] = Style(label, colour, linestyle, marker, filled)
    return out


def backend_looks(backends) -> dict[str, tuple[str, str]]:
    """Backend name → (colour, marker): random search dark grey, the built-ins from ``BACKEND_LOOK``,
    any other in name order the first look of ``EXTRA_LOOKS`` no backend here uses."""
    backends = sorted(set(backends))
    looks = {
        b: (RANDOM_COLOUR, RANDOM_MARKER) if b == "random" else BACKEND_LOOK[b]
        for b in backends
        if b == "random" or b in BACKEND_LOOK
    }
    free = [look for look in EXTRA_LOOKS if look not in looks.values()]
    for b in (b for b in backends if b not in looks):
        looks[b] = free.pop(0) if free else EXTRA_LOOKS[len(looks) % len(EXTRA_LOOKS)]
    return looks


def palette(study, order=None) -> dict:
    """Label → colour (hex), the colours of ``styles``."""
    return {label: s.colour for label, s in styles(study, order).items()}


# seaborn's ``set_theme(style="whitegrid", context="notebook")`` written out: its rcParams, its "deep"
# colour cycle, and the colour codes it maps (b g r m y c to "deep6", k to dark grey). Importing seaborn
# imports scipy.stats, which costs a command more than a fit of a rig test (docs/speed.md), and its theme
# was all bwbench took from it. ``tests/render/test_figure_look.py`` checks this against seaborn's own.
# (seaborn's default image colormap, "rocket", is left out: it is registered by importing seaborn, and no
# figure draws an image without naming its colormap.)
SEABORN_WHITEGRID_NOTEBOOK: dict[Any, Any] = {  # Any: matplotlib types rcParams keys as literals
    "figure.facecolor": "white",
    "axes.labelcolor": ".15",
    "xtick.direction": "out",
    "ytick.direction": "out",
    "xtick.color": ".15",
    "ytick.color": ".15",
    "axes.axisbelow": True,
    "grid.linestyle": "-",
    "text.color": ".15",
    "font.family": ["sans-serif"],
    "font.sans-serif": ["Arial", "DejaVu Sans", "Liberation Sans", "Bitstream Vera Sans", "sans-serif"],
    "lines.solid_capstyle": "round",
    "patch.edgecolor": "w",
    "patch.force_edgecolor": True,
    "xtick.top": False,
    "ytick.right": False,
    "axes.grid": True,
    "axes.facecolor": "white",
    "axes.edgecolor": ".8",
    "grid.color": ".8",
    "axes.spines.left": True,
    "axes.spines.bottom": True,
    "axes.spines.right": True,
    "axes.spines.top": True,
    "xtick.bottom": False,
    "ytick.left": False,
    "axes.linewidth": 1.25,
    "grid.linewidth": 1.0,
    "lines.linewidth": 1.5,
    "lines.markersize": 6.0,
    "patch.linewidth": 1.0,
    "xtick.major.width": 1.25,
    "ytick.major.width": 1.25,
    "xtick.minor.width": 1.0,
    "ytick.minor.width": 1.0,
    "xtick.major.size": 6.0,
    "ytick.major.size": 6.0,
    "xtick.minor.size": 4.0,
    "ytick.minor.size": 4.0,
    "font.size": 12.0,
    "axes.labelsize": 12.0,
    "axes.titlesize": 12.0,
    "xtick.labelsize": 11.0,
    "ytick.labelsize": 11.0,
    "legend.fontsize": 11.0,
    "legend.title_fontsize": 12.0,
}
SEABORN_DEEP = (
    "#4c72b0",
    "#dd8452",
    "#55a868",
    "#c44e52",
    "#8172b3",
    "#937860",
    "#da8bc3",
    "#8c8c8c",
    "#ccb974",
    "#64b5cd",
)
# seaborn's "deep6": "deep" without its orange, brown, pink and grey
SEABORN_COLOR_CODES: dict[str, Any] = dict(
    zip("bgrmyck", [SEABORN_DEEP[i] for i in (0, 2, 3, 4, 8, 9)] + [(0.1, 0.1, 0.1)])
)


# bwbench's sizes over seaborn's: every text at least MIN_FONT_PT, in figures sized for the page
SIZES: dict[Any, Any] = {
    "font.size": 10,
    "axes.titlesize": 10.5,
    "axes.labelsize": 10,
    "xtick.labelsize": 9.5,
    "ytick.labelsize": 9.5,
    "legend.fontsize": 9.5,
    "legend.title_fontsize": 9.5,
    "figure.titlesize": 12,
    "lines.linewidth": 1.6,
}


def theme() -> None:
    """Seaborn's white grid (``SEABORN_WHITEGRID_NOTEBOOK``) with bwbench's ``SIZES``."""
    matplotlib.rcParams.update(SEABORN_WHITEGRID_NOTEBOOK)
    deep = [matplotlib.colors.to_rgb(c) for c in SEABORN_DEEP]  # RGB tuples, as seaborn sets them
    matplotlib.rcParams["axes.prop_cycle"] = cycler(color=deep)
    named = matplotlib.colors.get_named_colors_mapping()  # "k", "b", ...: its cache is cleared on update
    for code, colour in SEABORN_COLOR_CODES.items():
        named[code] = matplotlib.colors.to_rgb(colour)
    matplotlib.rcParams.update(SIZES)


def figure(width: float, height: float, **kw):
    """(figure, axes): a constrained-layout figure, at most ``MAX_WIDTH_IN`` wide (``Figure.subplots``
    arguments in ``kw``). A ``Figure`` on its own Agg canvas, made directly, not through pyplot: no
    backend is chosen for the process and no global list of figures grows."""
    fig = canvas(width, height)
    return fig, fig.subplots(**kw)


def title(fig, text: str, **kw) -> None:
    """The figure's title, each line wrapped to the figure's width: a long title would otherwise run off
    both sides of the page."""
    width = int(fig.get_figwidth() * 9.5)  # characters per line of the title's font (12 pt) per inch
    fig.suptitle("\n".join(textwrap.fill(line, width) for line in text.split("\n")), **kw)


def canvas(width: float, height: float):
    """An empty constrained-layout figure, at most ``MAX_WIDTH_IN`` wide (for hand-made grids)."""
    fig = Figure(figsize=(min(width, MAX_WIDTH_IN), height), layout="constrained")
    FigureCanvasAgg(fig)  # files only: the canvas draws into memory, whatever backend a notebook has
    return fig


def legend(fig, handles, ncol: int | None = None, title: str | None = None, loc: str = "below"):
    """The figure's one legend, outside the axes: ``"below"`` them (default; ``save`` makes room
    for it above the SYNTHETIC mark) or any of matplotlib's ``"outside …"`` places."""
    ncol = max(ncol or min(len(handles), 4), 1)
    if loc != "below":
        return fig.legend(handles=handles, loc=loc, ncol=ncol, title=title, frameon=False, handlelength=2.6)
    leg = fig.legend(
        handles=handles,
        loc="lower center",
        bbox_to_anchor=(0.5, 0.0),
        ncol=ncol,
        title=title,
        frameon=False,
        columnspacing=1.4,
        handlelength=2.6,
    )
    fig._bwbench_legend_below = leg  # noqa: SLF001  (read by save)
    return leg


def backend_handles(styles_, labels, text=None, line: bool = True, marker: bool = True) -> list:
    """Legend entries for ``labels`` (those present in a figure) in the order of ``styles_`` (ranking
    order); ``text``: optional label → legend text."""
    present = set(labels)
    return [s.handle((text or {}).get(name), line, marker) for name, s in styles_.items() if name in present]


def runs_text(n: int) -> str:
    return f"{n} run" if n == 1 else f"{n} runs"


def truth_handle(text: str = "truth") -> Line2D:
    return Line2D([], [], label=text, **TRUTH)


def mark_synthetic(fig, label=True) -> None:
    """The mark every figure carries, saying what its data are: ``label`` when it is a text (e.g. a
    problem's ``is_synthetic``, which names the data's source), the paper's synthetic data when it is
    ``True``, measured data when it is false."""
    text = label if isinstance(label, str) and label else SYNTHETIC_LABEL if label else MEASURED_LABEL
    fig.text(0.995, 0.003, text, ha="right", va="bottom", fontsize=MIN_FONT_PT, color="0.35", style="italic")


def slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.]+", "-", str(text)).strip("-").lower()


def save(fig, out_dir, stem: str, frame: pd.DataFrame, synthetic_data: bool | str, rect=(0, 0.03, 1, 0.97)) -> Path:
    """Write ``stem``.png and the CSV behind it (``frame``) into ``out_dir`` (see ``write_png``);
    return the PNG's path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    png = out_dir / f"{stem}.png"
    write_png(fig, png, synthetic_data, rect)
    from bwbench.data.output_paths import write_frame

    write_frame(frame, png.with_suffix(".csv"), index=False, float_format="%.6g")
    return png


def write_png(fig, png, synthetic_data: bool | str, rect=(0, 0.03, 1, 0.97)) -> None:
    """Lay out, mark (what the data are: ``mark_synthetic``) and write ``fig`` at ``DPI`` to ``png``, then close it. ``rect``: the
    area the axes may use under a tight layout; a constrained layout gets the figure less a strip at
    the bottom for the legend below and the mark."""
    from bwbench.render.literal_text import make_literal

    make_literal(fig)  # names from the data drawn as written, never as mathtext
    engine = fig.get_layout_engine()
    mark_synthetic(fig, synthetic_data)
    if isinstance(engine, matplotlib.layout_engine.ConstrainedLayoutEngine):
        _make_room_below(fig, engine, 0.22)
    elif engine is None:
        fig.tight_layout(rect=rect)
    from bwbench.data.output_paths import replaced_whole

    with replaced_whole(png) as partial:  # Ctrl-C while saving leaves the old figure or none, not half
        fig.savefig(partial, dpi=DPI)


def _make_room_below(fig, engine, mark_in: float) -> None:
    """Constrained layout does not see a legend placed by hand: measure it, put it above the mark
    strip (``mark_in`` inches) and keep the axes above both."""
    height_in = fig.get_size_inches()[1]
    below = mark_in
    leg = getattr(fig, "_bwbench_legend_below", None)
    if leg is not None:
        # The legend is measured as it stands (matplotlib picks the figure's renderer, whatever the
        # backend: a notebook's may be pdf), not after drawing the whole figure (a draw of a long
        # record's fit figure costs far more than the legend's size is worth).
        width = fig.get_size_inches()[0] * fig.dpi
        # 6 % to spare: text grows a little more than the figure at the saving DPI (hinting)
        while leg.get_window_extent().width > 0.94 * width and leg._ncols > 1:  # noqa: SLF001
            # long labels: fewer columns rather than a legend cut off at both sides
            handles, ncols, title = leg.legend_handles, leg._ncols - 1, leg.get_title().get_text() or None  # noqa: SLF001
            leg.remove()
            leg = legend(fig, handles, ncol=ncols, title=title)
        leg_in = leg.get_window_extent().height / fig.dpi
        leg.set_bbox_to_anchor((0.5, mark_in / height_in), transform=fig.transFigure)
        below += leg_in + 0.08
    engine.set(rect=(0, below / height_in, 1, 1 - below / height_in))
