"""The house style of every figure: a journal's column (85 mm) or page (180 mm) width,
7-9 pt type at that size, colour-blind-safe line colours (Okabe and Ito), perceptually
uniform colour maps (sequential for one-signed quantities, diverging and centred on 0
for signed ones), and each figure saved as PNG (300 dpi) with a vector PDF beside it
(text kept as text; and an SVG inside :func:`vector_formats`), so that a journal takes
it as it is.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from cycler import cycler  # noqa: E402

MM = 1 / 25.4  # inches per mm
COLUMN_MM = 85.0  # one journal column
PAGE_MM = 180.0  # the page's text width
PNG_DPI = 300
# written beside each PNG: a PDF; the SVG too inside vector_formats (it costs another
# 0.2 s a figure, a tenth of an embryo's run)
_VECTOR_FORMATS = contextvars.ContextVar("vector_formats", default=(".pdf",))

# Okabe & Ito (2008): told apart with every common colour-vision deficiency
LINE_COLOURS = (
    "#0072B2",
    "#D55E00",
    "#009E73",
    "#CC79A7",
    "#E69F00",
    "#56B4E9",
    "#000000",
    "#F0E442",
)
SEQUENTIAL = "viridis"  # one-signed quantities: area, thickness, strain energy
DIVERGING = "RdBu_r"  # signed quantities, centred on 0: blue below, red above
CYCLIC = "twilight"  # times and phases in the cycle: its end meets its start
# the grey (0-255) a node fades two thirds of the way towards in a field's figures and
# videos where its 95 % band is wider than BAND_WIDE_SHARE of its value
UNCERTAIN_GREY = 200

RC = {
    "font.size": 8,
    "axes.titlesize": 8,
    "axes.labelsize": 8,
    "xtick.labelsize": 7,
    "ytick.labelsize": 7,
    "legend.fontsize": 7,
    "figure.titlesize": 9,
    "axes.linewidth": 0.6,
    "lines.linewidth": 1.2,
    "lines.markersize": 3,
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    "legend.frameon": False,
    "axes.prop_cycle": cycler(color=LINE_COLOURS),
    "pdf.fonttype": 42,
    "ps.fonttype": 42,  # TrueType text in the PDF: editable, searchable
    "svg.fonttype": "none",  # text as text in the SVG
    "savefig.dpi": PNG_DPI,
    "figure.dpi": 100,
    "image.cmap": SEQUENTIAL,
}


def house_style(draw):
    """Decorator: ``draw`` makes its figure under :data:`RC`, without touching the
    caller's own matplotlib settings."""

    @functools.wraps(draw)
    def drawn(*args, **kwargs):
        with matplotlib.rc_context(RC):
            return draw(*args, **kwargs)

    return drawn


def new_figure(width_mm: float = COLUMN_MM, height_mm: float = 65.0, **subplots):
    """``plt.subplots`` of a figure ``width_mm`` x ``height_mm`` at print size, laid out
    by matplotlib's constrained layout (nothing overlaps, nothing is cut off)."""
    return plt.subplots(figsize=(width_mm * MM, height_mm * MM), layout="constrained", **subplots)


@contextlib.contextmanager
def vector_formats(suffixes=(".pdf", ".svg")):
    """Within it, :func:`save` writes these vector formats beside each PNG."""
    token = _VECTOR_FORMATS.set(tuple(suffixes))
    try:
        yield
    finally:
        _VECTOR_FORMATS.reset(token)


def vector_suffixes() -> tuple[str, ...]:
    """The vector formats :func:`save` writes here and now (``(".pdf",)`` outside any
    :func:`vector_formats`): for work sent to other processes, which do not share it."""
    return _VECTOR_FORMATS.get()


def save(fig, path: Path) -> Path:
    """``fig`` as ``path`` (PNG, 300 dpi) and as PDF beside it (and SVG, see
    :func:`vector_formats`); closed. Returns the PNG's path."""
    path = Path(path)
    fig.savefig(path, dpi=PNG_DPI)
    for suffix in _VECTOR_FORMATS.get():  # no date inside: the same figure, the same bytes
        fig.savefig(
            path.with_suffix(suffix),
            metadata={".pdf": {"CreationDate": None}, ".svg": {"Date": None}}[suffix],
        )
    plt.close(fig)
    return path


def colour_scale(
    values: np.ndarray, *, signed: bool | None = None, percentile: float = 99.0
) -> dict:
    """``imshow`` keywords (cmap, vmin, vmax) for ``values``: diverging and symmetric
    about 0 when they take both signs (or ``signed``), else sequential from their
    low to their high ``percentile``; NaN ignored."""
    finite = np.asarray(values, float)[np.isfinite(values)]
    if finite.size == 0:
        return {"cmap": SEQUENTIAL}
    if signed is None:
        signed = finite.min() < 0 < finite.max()
    if signed:
        bound = float(np.percentile(np.abs(finite), percentile)) or 1.0
        return {"cmap": DIVERGING, "vmin": -bound, "vmax": bound}
    lo, hi = np.percentile(finite, [100 - percentile, percentile])
    return {"cmap": SEQUENTIAL, "vmin": float(lo), "vmax": float(hi if hi > lo else lo + 1e-12)}


def colour_bar(fig, image, ax, label: str, *, signed: bool = False):
    """A colour bar of ``image`` beside ``ax``, labelled with the quantity and its unit,
    and for a diverging scale where 0 is."""
    bar = fig.colorbar(image, ax=ax, shrink=0.9)
    bar.set_label(bar_label(fig, ax, label + ("; 0 white" if signed else "")))
    bar.outline.set_linewidth(0.5)
    return bar


def bar_label(fig, ax, label: str) -> str:
    """A colour bar's ``label`` broken into lines no longer than the bar beside ``ax``
    (the axes' height, give or take the layout still to come)."""
    from matplotlib.transforms import Bbox

    beside = Bbox.union([a.get_position() for a in np.ravel(ax)])  # one axes or several
    bar_mm = 0.8 * 0.9 * beside.height * fig.get_size_inches()[1] / MM
    size = matplotlib.rcParams["axes.labelsize"]
    size = size if isinstance(size, (int, float)) else 8.0
    return wrapped(label, bar_mm, size, shortest=10)


def nothing_to_show(ax, why: str, width_mm: float = COLUMN_MM) -> None:
    """Say on ``ax`` why it is empty (``why``: what the data lack, in words), in place
    of a plot: a figure of a valid dataset with nothing to show is made, not failed."""
    ax.set_xticks([])
    ax.set_yticks([])
    ax.text(
        0.5,
        0.5,
        wrapped(why, 0.7 * width_mm, 8),
        ha="center",
        va="center",
        transform=ax.transAxes,
        fontsize=8,
        color="0.3",
    )


def wrapped(text: str, width_mm: float, size_pt: float = 8.0, shortest: int = 20) -> str:
    """``text`` broken into lines that fit ``width_mm`` at ``size_pt`` (a character
    about 0.21 mm a point on average; lines of at least ``shortest`` characters), for
    titles that would leave the figure and colour-bar labels longer than their bar."""
    import textwrap

    return "\n".join(textwrap.wrap(text, max(shortest, int(width_mm / (0.21 * size_pt))))) or text
