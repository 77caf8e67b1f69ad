"""MP4 videos of (u, v, t) fields and (v, t) maps (H.264, yuv420p: plays in browsers).

Frames are drawn with NumPy and OpenCV (colour map with an explicit range,
nearest-neighbour upscaling, a colour bar and the frame time in a corner) and
encoded by imageio-ffmpeg's bundled ffmpeg. This is the one place where arrays
in (u, v, t) order become video order (frames, rows, cols, 3): v runs up the
picture (inlet at the bottom), u to the right.
"""

from __future__ import annotations

from dataclasses import dataclass

from functools import lru_cache
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np
from matplotlib import colormaps, font_manager
from PIL import Image, ImageDraw, ImageFont

from . import numbers, units
from .image_order import in_image_order
from .style import CYCLIC, UNCERTAIN_GREY


@lru_cache(maxsize=None)
def _lut(cmap: str) -> np.ndarray:
    """The colour map sampled at 256 even steps from its start to its end, uint8 RGB
    ``(256, 3)``. (By floats: integers index a map's own table, and twilight's has 510
    entries: 0-255 were its first half, the phase video's -pi..pi drawn white to black.)"""
    return np.round(colormaps[cmap](np.linspace(0.0, 1.0, 256))[:, :3] * 255).astype(np.uint8)


def to_rgb(values: np.ndarray, vmin: float, vmax: float, cmap: str = "jet") -> np.ndarray:
    """Colour-map ``values`` with the explicit range [vmin, vmax] to uint8 RGB
    (NaN: grey), by table look-up (matplotlib's 256 colours)."""
    span = vmax - vmin if vmax > vmin else 1.0
    x = np.clip((np.nan_to_num(values, nan=vmin) - vmin) / span, 0.0, 1.0)
    rgb = _lut(cmap)[np.minimum((x * 256).astype(np.int64), 255)]
    rgb[~np.isfinite(values)] = 128
    return rgb


# the frame around a (u, v) field: margins for the axes, a banner above, the colour bar
MARGIN_LEFT, MARGIN_BOTTOM, BANNER, BAR_PANEL = 96, 64, 74, 170
TEXT_PX_PER_SCALE = 30  # a text scale of 1: a 30-pixel font (OpenCV's Hershey scale)
BEAT_SECONDS = 4.0  # a beat plays in this long at the default frame rate
FIELD_SCALE = 6  # pixels a (u, v) node: 80 x 50 nodes, a 480 x 300 picture


def beat_fps(n_frames: int) -> float:
    """Frames per second that play one beat of ``n_frames`` in :data:`BEAT_SECONDS`
    (at least 2, at most 60)."""
    return float(np.clip(n_frames / BEAT_SECONDS, 2.0, 60.0))


def _stack(n: int, draw) -> np.ndarray:
    """Frames ``draw(t)`` for t < n in one preallocated ``(n, rows, cols, 3)`` array."""
    first = draw(0)
    out = np.empty((n,) + first.shape, np.uint8)
    out[0] = first
    for t in range(1, n):
        out[t] = draw(t)
    return out


def _even(img: np.ndarray, multiple: int = 16) -> np.ndarray:
    """Pad to a multiple of ``multiple`` pixels (H.264 macro blocks, even sizes)."""
    h, w = img.shape[:2]
    H, W = -(-h // multiple) * multiple, -(-w // multiple) * multiple
    out = np.full((H, W, 3), 255, np.uint8)
    out[:h, :w] = img
    return out


@lru_cache(maxsize=None)
def _font(size_px: int) -> ImageFont.FreeTypeFont:
    """DejaVu Sans (matplotlib's own font, so the figures' and the videos' type match)
    at ``size_px`` pixels."""
    return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size_px)


def _font_px(scale: float) -> int:
    return max(8, int(round(scale * TEXT_PX_PER_SCALE)))


def text_width(text: str, scale: float = 0.5) -> int:
    """The width in pixels of ``text`` as :func:`_text` writes it at ``scale``."""
    return int(np.ceil(_font(_font_px(scale)).getlength(text)))


def _text(
    img,
    text: str,
    org,
    *,
    scale: float = 0.5,
    colour=(0, 0, 0),
    align: str = "left",
    max_width: int | None = None,
) -> None:
    """``text`` on ``img`` at ``org`` (its baseline's left, centre or right end),
    anti-aliased, any Unicode (mm², µm, ±); smaller, down to 0.7 of ``scale``, where
    it would be wider than ``max_width`` pixels."""
    px = _font_px(scale)
    if max_width is not None:
        smallest = int(0.7 * px)
        while px > smallest and _font(px).getlength(text) > max_width:
            px -= 1
    coverage, (left, top) = _glyphs(text, px, align)
    x, y = int(org[0]) + left, int(org[1]) + top
    x0, y0 = max(x, 0), max(y, 0)
    x1, y1 = min(x + coverage.shape[1], img.shape[1]), min(y + coverage.shape[0], img.shape[0])
    if x1 <= x0 or y1 <= y0:
        return
    alpha = coverage[y0 - y : y1 - y, x0 - x : x1 - x, None]
    patch = img[y0:y1, x0:x1].astype(np.float32)
    patch += alpha * (np.asarray(colour, np.float32) - patch)
    img[y0:y1, x0:x1] = np.rint(patch).astype(np.uint8)


@lru_cache(maxsize=4096)
def _glyphs(text: str, px: int, align: str) -> tuple[np.ndarray, tuple[int, int]]:
    """``text``'s anti-aliased coverage ``(h, w)`` float32 in [0, 1] at ``px`` pixels,
    and its top left corner from the anchor (the baseline's left, centre or right end):
    rendered once per text and size (a video writes the same labels on every frame)."""
    font = _font(px)
    anchor = {"left": "ls", "centre": "ms", "right": "rs"}[align]
    left, top, right, bottom = font.getbbox(text, anchor=anchor)
    mask = Image.new("L", (right - left + 3, bottom - top + 3), 0)
    ImageDraw.Draw(mask).text((1 - left, 1 - top), text, font=font, fill=255, anchor=anchor)
    return np.asarray(mask, np.float32) / 255.0, (left - 1, top - 1)


def nice_ticks(lo: float, hi: float, n: int = 6) -> tuple[list[float], list[str]]:
    """Up to about ``n`` round values within [lo, hi] (1, 2, 2.5 or 5 times a power of
    ten apart) and their labels, all to the same decimal: a colour bar's ticks."""
    from matplotlib.ticker import MaxNLocator

    if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
        return [lo], [numbers.number(lo)]
    values = [
        float(v)
        for v in MaxNLocator(n, steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
        if lo - 1e-9 * (hi - lo) <= v <= hi + 1e-9 * (hi - lo)
    ]
    step = values[1] - values[0] if len(values) > 1 else hi - lo
    decimals = max(0, -int(np.floor(np.log10(step) + 1e-9)))
    in_units = step * 10.0**decimals
    if abs(in_units - round(in_units)) > 1e-6:  # 2.5 steps: one more decimal
        decimals += 1
    return values, [numbers.with_decimals(v, decimals) for v in values]


def _colour_bar_panel(height: int, vmin: float, vmax: float, cmap: str, label: str) -> np.ndarray:
    """A white panel ``(height, BAR_PANEL, 3)``: the colour bar with five ticks and
    their values, its label (quantity and unit) written above it in up to two lines."""
    panel = np.full((height, BAR_PANEL, 3), 255, np.uint8)
    top, bottom = 40, height - 8
    bar = to_rgb(
        np.linspace(vmax, vmin, bottom - top)[:, None] * np.ones((1, 18)), vmin, vmax, cmap
    )
    panel[top:bottom, 12:30] = bar
    words, lines = label.split(), ["", ""]
    for word in words:  # two lines of about 22 characters
        k = 0 if len(lines[0]) + len(word) < 22 or not lines[0] else 1
        lines[k] = (lines[k] + " " + word).strip()
    for k, line in enumerate(lines):
        _text(panel, line, (8, 13 + 15 * k), scale=0.42)
    for value, text in zip(*nice_ticks(vmin, vmax)):
        y = int(round(bottom - 1 - (value - vmin) / ((vmax - vmin) or 1.0) * (bottom - top - 1)))
        panel[y, 30:36] = 0
        _text(panel, text, (40, y + 5), scale=0.42)
    return panel


def field_canvas(
    n_u: int,
    n_v: int,
    scale: int,
    *,
    vmin: float,
    vmax: float,
    cmap: str,
    label: str,
    title: str,
    length_mm: float | None = None,
) -> np.ndarray:
    """The still part of every frame of a (u, v) field video, white, the field's
    place ``(n_v * scale, n_u * scale)`` at rows ``BANNER:``, columns
    ``MARGIN_LEFT:`` left for it: the title, the v axis (inlet at the bottom,
    outlet at the top), the u axis (around the tube from the seam, the seam
    marked at both edges), the tube's length as the scale along v, and the
    labelled colour bar."""
    h, w = n_v * scale, n_u * scale
    img = np.full((BANNER + h + MARGIN_BOTTOM, MARGIN_LEFT + w + BAR_PANEL, 3), 255, np.uint8)
    _text(img, title, (8, 20), scale=0.55, max_width=img.shape[1] - 16)
    x0, y0 = MARGIN_LEFT, BANNER
    cv2.rectangle(img, (x0 - 1, y0 - 1), (x0 + w, y0 + h), (0, 0, 0), 1)
    for v in (0.0, 0.25, 0.5, 0.75, 1.0):  # v up: inlet at the bottom
        y = int(round(y0 + h - 1 - v * (h - 1)))
        img[y, x0 - 6 : x0 - 1] = 0
        _text(img, f"{v:g}", (x0 - 9, y + 5), scale=0.42, align="right")
    _text(img, "outlet", (x0 - 9, y0 + 22), scale=0.4, align="right")
    _text(img, "inlet", (x0 - 9, y0 + h - 14), scale=0.4, align="right")
    _text(img, "v along", (4, y0 + 3 * h // 8 - 4), scale=0.42)  # between two ticks
    if length_mm is not None:
        _text(
            img, f"(0-1: {numbers.number(length_mm, 2)} mm)", (4, y0 + 3 * h // 8 + 12), scale=0.36
        )
    for u in (0.0, 0.25, 0.5, 0.75, 1.0):
        x = int(round(x0 + u * (w - 1)))
        img[y0 + h : y0 + h + 6, x] = 0
        _text(img, f"{u:g}", (x, y0 + h + 20), scale=0.42, align="centre")
    for x in (x0, x0 + w - 1):  # the seam: u = 0 and u = 1
        _text(img, "seam", (x, y0 + h + 36), scale=0.38, colour=(180, 0, 0), align="centre")
    _text(
        img,
        "u around the tube, from the seam",
        (x0 + w // 2, y0 + h + 54),
        scale=0.45,
        align="centre",
    )
    img[y0 - 40 : y0 + h, x0 + w + 4 : x0 + w + BAR_PANEL] = _colour_bar_panel(
        h + 40, vmin, vmax, cmap, label
    )[:, : BAR_PANEL - 4]
    return img


def _stamp(img: np.ndarray, t_ms: float, phase: float, right: int, note: str = "") -> None:
    """The time, a phase bar (where in the beat this frame is) and ``note`` in the
    banner of ``img``, above the picture: black on white, readable on any frame."""
    _text(img, f"t = {t_ms:.0f} ms ({100 * phase:.0f} % of the beat)", (8, 44), scale=0.5)
    x0, x1, y = 300, max(320, right), 38
    cv2.rectangle(img, (x0, y - 5), (x1, y + 5), (0, 0, 0), 1)
    cv2.rectangle(img, (x0, y - 5), (int(x0 + phase * (x1 - x0)), y + 5), (0, 0, 0), -1)
    if note:
        _text(img, note, (8, 64), scale=0.45, colour=(0, 0, 160))


def field_frames(
    field: np.ndarray,
    t_ms: np.ndarray,
    *,
    vmin=None,
    vmax=None,
    cmap=None,
    label="",
    scale: int = FIELD_SCALE,
    grid_note: str = "",
    title: str = "",
    period_ms: float | None = None,
    length_mm: float | None = None,
    reference_frame: int | None = None,
    annotate: bool = True,
    stream: bool = False,
    uncertain: np.ndarray | None = None,
    uncertain_note: str = "",
):
    """Video frames ``(n_t, rows, cols, 3)`` uint8 of a ``(n_u, n_v, n_t)`` field (with
    ``stream``, the frames one at a time: an encoder needs no more, and a 195-frame
    field video holds ~200 MB).

    One colour range for the whole cycle (``vmin``/``vmax``, default
    :func:`oftimg.output.style.colour_scale`'s: symmetric about 0 on a diverging
    map for a signed field, the 1st to 99th percentile on a sequential one): the
    house has one fixed scale over a video's frames. Around the field (``annotate``): the
    ``title`` with ``grid_note`` (which grid the field is on), the u and v axes,
    the seam and the ends, the tube's length ``length_mm``, the colour bar with
    ``label`` (quantity and unit), and on each frame its time, its phase in the
    beat (``period_ms``) and, at ``reference_frame``, that the field is 0 there
    by definition (strain against t = 0). ``uncertain (n_u, n_v, n_t)`` bool: nodes drawn
    greyed (their colour faded two thirds of the way to grey), said by ``uncertain_note``
    under the title.
    """
    from .style import colour_scale

    scale_ = colour_scale(field)
    cmap = cmap or scale_["cmap"]
    lo = scale_.get("vmin", 0.0) if vmin is None else vmin
    hi = scale_.get("vmax", 1.0) if vmax is None else vmax
    n_u, n_v, n_t = field.shape
    period = period_ms or (t_ms[-1] + (t_ms[1] - t_ms[0]) if len(t_ms) > 1 else 1.0)
    heading = ", ".join(x for x in (title or label, grid_note) if x)
    if uncertain is not None and uncertain_note:
        heading = f"{heading}; {uncertain_note}"
    canvas = (
        None
        if not annotate
        else field_canvas(
            n_u,
            n_v,
            scale,
            vmin=lo,
            vmax=hi,
            cmap=cmap,
            label=label,
            title=heading,
            length_mm=length_mm,
        )
    )

    def draw(t):
        img, _ = in_image_order(field[:, :, t], ["u", "v"])  # rows: v, inlet at the bottom
        colours = to_rgb(img, lo, hi, cmap)
        if uncertain is not None:
            marked, _ = in_image_order(uncertain[:, :, t], ["u", "v"])
            colours[marked] = (colours[marked] / 3 + 2 / 3 * UNCERTAIN_GREY).astype(np.uint8)
        rgb = cv2.resize(colours, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
        if not annotate:
            return _even(rgb)
        frame = canvas.copy()
        frame[BANNER : BANNER + rgb.shape[0], MARGIN_LEFT : MARGIN_LEFT + rgb.shape[1]] = rgb
        note = (
            "reference frame: 0 by definition (strain against t = 0)"
            if t == reference_frame
            else ""
        )
        _stamp(frame, t_ms[t], (t_ms[t] % period) / period, MARGIN_LEFT + rgb.shape[1], note)
        return _even(frame)

    return (draw(t) for t in range(n_t)) if stream else _stack(n_t, draw)


def map_cursor_frames(
    area: np.ndarray,
    t_ms: np.ndarray,
    *,
    s_mm: np.ndarray | None = None,
    width: int = 720,
    height: int = 420,
    cmap=None,
    label: str = "cross-sectional area (mm²)",
    stream: bool = False,
):
    """Frames of a ``(n_v, n_t)`` map (about ``width`` x ``height`` pixels) with a
    moving time cursor, its axes (time in ms, position along the tube in mm, inlet
    at the bottom), its colour bar and the time in the banner (``stream``: one at a
    time, as :func:`field_frames`)."""
    from .style import SEQUENTIAL

    cmap = cmap or SEQUENTIAL
    n_v, n_t = area.shape
    sx, sy = max(1, round(width / n_t)), max(1, round(height / n_v))
    image, _ = in_image_order(area, ["v", "t"])
    lo, hi = float(np.nanmin(area)), float(np.nanmax(area))
    picture = cv2.resize(
        to_rgb(image, lo, hi, cmap), None, fx=sx, fy=sy, interpolation=cv2.INTER_NEAREST
    )
    h, w = picture.shape[:2]
    base = np.full((BANNER + h + MARGIN_BOTTOM, MARGIN_LEFT + w + BAR_PANEL, 3), 255, np.uint8)
    x0, y0 = MARGIN_LEFT, BANNER
    base[y0 : y0 + h, x0 : x0 + w] = picture
    _text(base, "the outer area map; cursor: this frame", (8, 20), scale=0.55)
    s_end = float(s_mm[-1]) if s_mm is not None else None
    for value, text in zip(*nice_ticks(0.0, s_end or 1.0, 4)):
        y = int(round(y0 + h - 1 - value / (s_end or 1.0) * (h - 1)))
        base[y, x0 - 6 : x0 - 1] = 0
        _text(base, text, (x0 - 9, y + 5), scale=0.42, align="right")
    _text(base, "s (mm)" if s_end else "v", (4, y0 + h // 2), scale=0.42)
    _text(base, "inlet", (x0 - 9, y0 + h - 14), scale=0.4, align="right")
    period = t_ms[-1] + (t_ms[1] - t_ms[0]) if n_t > 1 else 1.0
    # each frame's column is centred on its time, as the cursor is (a tick at a
    # column's left edge put the cursor half a frame after the title's time)
    for tick, text in zip(*nice_ticks(0.0, period, 5)):
        x = int(round(x0 + (tick / period * n_t + 0.5) * sx))
        if x > x0 + w - 1:
            continue
        base[y0 + h : y0 + h + 6, x] = 0
        _text(base, text, (x, y0 + h + 20), scale=0.42, align="centre")
    _text(
        base,
        "time since minimum volume (ms)",
        (x0 + w // 2, y0 + h + 44),
        scale=0.45,
        align="centre",
    )
    base[y0 - 40 : y0 + h, x0 + w + 4 : x0 + w + BAR_PANEL] = _colour_bar_panel(
        h + 40, lo, hi, cmap, label
    )[:, : BAR_PANEL - 4]

    def draw(t):
        img = base.copy()
        x = x0 + int((t + 0.5) * sx)
        img[y0 : y0 + h, max(x0, x - 1) : x + 2] = 255
        img[y0 : y0 + h, x : x + 1] = 0
        _stamp(img, t_ms[t], (t_ms[t] % period) / period, x0 + w)
        return _even(img)

    return (draw(t) for t in range(n_t)) if stream else _stack(n_t, draw)


def write_mp4(path: Path, frames, *, fps: float) -> Path:
    """Encode ``frames`` (``(n, rows, cols, 3)`` uint8, or an iterable of
    ``(rows, cols, 3)`` frames) as H.264/yuv420p MP4.

    x264's "veryfast" preset tuned for animation (flat colours, sharp edges) at
    ``quality=7`` (CRF 15): measured on the bench embryo's 12 videos (195 frames),
    4.6 MB in all with a mean error of 0.77 of 255 (the worst video 0.93), against
    19.2 MB and 0.65 with "ultrafast" (which leaves out CABAC and most motion search),
    for about 25 % more encoding time; the arrays themselves are in ``arrays.npz``. One
    encoder thread: the workers already fill the cores, and each thread holds frames
    (an encoder 0.13-0.15 GB with x264's own threads, 0.09-0.11 GB with one).
    """
    # format named: if imageio cannot load its ffmpeg plugin, it says so instead of
    # handing the .mp4 to another plugin (tifffile, whose error names an "fps" argument)
    writer = imageio.get_writer(
        str(path),
        format="FFMPEG",
        fps=fps,
        codec="libx264",
        pixelformat="yuv420p",
        macro_block_size=16,
        quality=7,
        ffmpeg_log_level="error",  # one thread: the workers fill the cores
        ffmpeg_params=["-preset", "veryfast", "-tune", "animation", "-threads", "1"],
    )
    try:
        for frame in frames:
            writer.append_data(frame)
    finally:
        writer.close()
    return path


# (file, array, per-pixel normalized?, field_frames options): the (u, v) field videos;
# signed fields get a diverging colour map centred on 0, one-signed ones a sequential one
_STRAIN = dict(cmap="viridis", reference_frame=0)  # as the figures: one-signed, viridis
FIELD_VIDEOS = [
    (
        "radial_curvature_outer",
        "radial_curvature_outer_per_mm",
        False,
        dict(label="radial curvature (1/mm)", title="outer wall: radial curvature"),
    ),
    (
        "radial_curvature_outer_normalized",
        "radial_curvature_outer_per_mm",
        True,
        dict(
            vmin=0,
            vmax=1,
            cmap="gray",
            label="normalised (0-1)",
            title="outer wall: radial curvature, PER-PIXEL NORMALISED (each pixel's min 0, max 1)",
        ),
    ),
    (
        "strain_energy_outer",
        "strain_energy_outer",
        False,
        dict(
            _STRAIN,
            label="strain energy (dimensionless)",
            title="outer wall: strain energy against t = 0",
        ),
    ),
    (
        "radial_curvature_inner",
        "radial_curvature_inner_per_mm",
        False,
        dict(label="radial curvature (1/mm)", title="inner wall: radial curvature"),
    ),
    (
        "strain_energy_inner",
        "strain_energy_inner",
        False,
        dict(
            _STRAIN,
            label="strain energy (dimensionless)",
            title="inner wall: strain energy against t = 0",
        ),
    ),
    (
        "wall_thickness",
        "wall_thickness_mm",
        False,  # as every figure gives it
        dict(
            cmap="viridis",
            label=units.label("wall thickness", "thickness"),
            title="myocardial wall thickness",
            times=units.THICKNESS.scale,
        ),
    ),
    (
        "jelly_thickness",
        "jelly_thickness_mm",
        False,
        dict(
            cmap="viridis",
            label=units.label("jelly thickness", "thickness"),
            title="cardiac jelly thickness",
            times=units.THICKNESS.scale,
        ),
    ),
    (
        "mean_curvature_lumen",
        "mean_curvature_lumen_per_mm",
        False,
        dict(label="mean curvature (1/mm)", title="lumen: mean curvature"),
    ),
    (
        "surface_speed_outer",
        "surface_speed_outer_mm_s",
        False,
        dict(
            cmap="viridis",
            label="tissue speed (mm/s)",
            title="outer wall: the tissue's speed along its surface",
        ),
    ),
    (
        "surface_divergence_outer",
        "surface_divergence_outer_per_s",
        False,
        dict(label="area change (1/s)", title="outer wall: the tissue's rate of area change"),
    ),
    (
        "pullback_outer",
        "pullback_outer_mean",
        False,
        dict(
            cmap="gray",
            label="intensity (mean across the wall)",
            scale=2,
            grid_note="",
            title="myocardium: intensity pulled back onto each frame's own grid",
        ),
    ),
]


# the tasks that need only the aligned area maps, grids and lumen mean curvature
# (:func:`oftimg.analysis.pipeline.analyse_dataset`'s ``on_aligned``): the slow 3-D renders;
# the others need the shape fields
EARLY_VIDEOS = ("area", "lumen_3d")
LATER_VIDEOS = ("field", "phase_3d")


def uncertain_nodes(arrays: dict, key: str) -> dict:
    """:func:`field_frames`' ``uncertain`` and ``uncertain_note`` for the field ``key`` of
    ``arrays``: its nodes whose 95 % band (``<field>_band95_<unit>``) is wider than
    :data:`~oftimg.analysis.uncertainty.BAND_WIDE_SHARE` of the value's size; {} for a
    field without bands."""
    from ..analysis.uncertainty import BAND_WIDE_SHARE

    stem, _, unit = key.rpartition("_per_")
    band = arrays.get(f"{stem}_band95_per_{unit}" if stem else f"{key}_band95")
    if band is None:
        return {}
    with np.errstate(invalid="ignore"):
        marked = np.asarray(band) > BAND_WIDE_SHARE * np.abs(np.asarray(arrays[key]))
    return {
        "uncertain": marked,
        "uncertain_note": f"grey: 95 % band over {100 * BAND_WIDE_SHARE:.0f} % of the value",
    }


def video_tasks(
    arrays: dict, grids: dict | None = None, kinds=None, *, grid_note: str = ""
) -> list[tuple]:
    """The videos of one dataset as independent ``(kind, inputs)`` tasks for
    :func:`render_videos`, each holding only the arrays it needs; only those of
    ``kinds`` (default: all). ``grid_note``: which grid the (u, v) fields are on,
    written on their frames."""
    if kinds is not None:
        return [t for t in video_tasks(arrays, grids, grid_note=grid_note) if t[0] in kinds]
    t_ms = arrays["t_ms"]
    # the slow 3-D renders first, so that workers finish together;
    # the area-map cursor frames are drawn once for both videos that show them
    length_mm = float(arrays["s_mm"][-1]) if "s_mm" in arrays else None
    tasks = [
        (
            "area",
            dict(
                area=arrays["area_outer_mm2"],
                t_ms=t_ms,
                s_mm=arrays.get("s_mm"),
                grid=None if grids is None else grids["outer"],
            ),
        )
    ]
    h = arrays.get("mean_curvature_lumen_per_mm")
    if grids is not None and h is not None and "lumen" in grids:
        tasks.append(("lumen_3d", dict(grid=grids["lumen"], h=h, t_ms=t_ms, length_mm=length_mm)))
    if grids is not None and "phase_outer" in arrays:
        tasks.append(
            (
                "phase_3d",
                dict(
                    grid=grids["outer"], phase=timed_phase(arrays), t_ms=t_ms, length_mm=length_mm
                ),
            )
        )
    tasks += [
        (
            "field",
            dict(
                name=name,
                field=arrays[key],
                normalize=normalize,
                t_ms=t_ms,
                options={
                    "grid_note": grid_note,
                    "length_mm": length_mm,
                    **opts,
                    **({} if normalize else uncertain_nodes(arrays, key)),
                },
            ),
        )
        for name, key, normalize, opts in FIELD_VIDEOS
        if key in arrays
    ]
    return tasks


def render_videos(kind: str, inputs: dict, fps: float | None = None) -> list[tuple[str, bytes]]:
    """Encode one task's videos at ``fps`` (default :func:`beat_fps`: a beat in
    :data:`BEAT_SECONDS`); returns ``(file name, MP4 bytes)`` pairs (so that a
    worker on another machine need not see the output folder)."""
    import tempfile

    from ..image.normalize import per_pixel_normalize
    from ..memory import release_freed

    release_freed()  # a worker's heap from its frames' work, before the frames here
    t_ms = inputs["t_ms"]
    fps = fps or beat_fps(len(t_ms))
    if kind == "field":
        options = dict(inputs["options"])
        field = inputs["field"] * options.pop("times", 1.0)
        field = per_pixel_normalize(field) if inputs["normalize"] else field
        movies = {inputs["name"]: field_frames(field, t_ms, stream=True, **options)}
    elif kind == "area":

        def cursor():  # drawn twice, one frame at a time: cheaper than held
            return map_cursor_frames(inputs["area"], t_ms, s_mm=inputs.get("s_mm"), stream=True)

        movies = {"area_map_cursor": cursor()}
        G = inputs["grid"]
        if G is not None:
            area_field = np.broadcast_to(inputs["area"][None], G.shape[:3])
            movies["outer_wall_3d_area_map"] = surface_and_map_frames(
                G,
                area_field,
                t_ms,
                cmap="viridis",
                flat=cursor(),
                title="the outer wall coloured by its cross-sectional area (mm²)",
            )
    elif kind == "phase_3d":
        movies = {
            "phase_outer_3d": surface_and_map_frames(
                inputs["grid"],
                inputs["phase"],
                t_ms,
                cmap=CYCLIC,
                limits=(-np.pi, np.pi),
                label="phase (rad; 0 at activation)",
                title="the outer wall coloured by the phase of its motion (0: activation; "
                "grey: too still to time)",
                length_mm=inputs.get("length_mm"),
            )
        }
    elif kind == "lumen_3d":
        movies = {
            "lumen_mean_curvature_3d": surface_and_map_frames(
                inputs["grid"],
                inputs["h"],
                t_ms,
                label="mean curvature (1/mm)",
                title="the lumen coloured by its mean curvature (1/mm)",
                length_mm=inputs.get("length_mm"),
            )
        }
    else:
        raise ValueError(f"unknown video task {kind!r}")
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, frames in movies.items():
            path = write_mp4(Path(tmp) / f"{name}.mp4", frames, fps=fps)
            out.append((path.name, path.read_bytes()))
    return out


def timed_phase(arrays: dict) -> np.ndarray:
    """The outer wall's phase ``(n_u, n_v, n_t)`` (rad) where it moves enough to time the
    wave (its velocity finite), NaN (grey) elsewhere: as the activation figure greys
    them, not the speckle of a still node's random phase."""
    phase = arrays["phase_outer"]
    velocity = arrays.get("wave_velocity_outer_mm_s")
    if velocity is None:
        return phase
    return np.where(np.isfinite(velocity[..., 0])[..., None], phase, np.nan)


def start_videos(
    arrays: dict,
    grids: dict | None = None,
    *,
    fps: float | None = None,
    executor=None,
    kinds=None,
    grid_note: str = "",
):
    """Submit a dataset's video tasks (those of ``kinds``, default all) to
    ``executor`` (without one, render them now); pass the result to
    :func:`save_videos`. In between the caller is free to do other work (the
    figures) while the workers render. ``grid_note``: see :func:`video_tasks`."""
    tasks = [
        (kind, inputs, fps)
        for kind, inputs in video_tasks(arrays, grids, kinds, grid_note=grid_note)
    ]
    if executor is None:
        return [_rendered(*args) for args in tasks]
    return [executor.submit(_rendered, *args) for args in tasks]


def _rendered(kind: str, inputs, fps):
    """:func:`render_videos`, or its failure (:class:`RenderFailed`), for
    :func:`save_videos` to record."""
    try:
        return render_videos(kind, inputs, fps)
    except Exception as exc:  # noqa: BLE001 -- recorded by save_videos
        return RenderFailed(kind, f"{type(exc).__name__}: {exc}")


def save_videos(folder: Path, pending: list, failed: list | None = None) -> list[Path]:
    """Write the videos of :func:`start_videos` into ``folder``; returns their paths.
    A video that could not be rendered is left out and recorded in ``failed``
    (``{"video", "error"}``) when given (else its error is raised): a drawing never
    stops a run whose numbers are made. A lost worker is raised all the same."""
    from concurrent.futures import BrokenExecutor

    out = []
    for task in pending:
        if isinstance(task, RenderFailed):
            rendered = task
        else:
            try:
                rendered = task.result() if hasattr(task, "result") else task
            except BrokenExecutor:
                raise
            except Exception as exc:  # noqa: BLE001 -- any rendering's failure
                rendered = RenderFailed("a video", f"{type(exc).__name__}: {exc}")
        if isinstance(rendered, RenderFailed):
            if failed is None:
                raise RuntimeError(f"{rendered.kind}: {rendered.error}")
            failed.append({"video": rendered.kind, "error": rendered.error[:300]})
            continue
        for name, data in rendered:
            (folder / name).write_bytes(data)
            out.append(folder / name)
    return out


@dataclass(frozen=True)
class RenderFailed:
    """A video task whose rendering failed in this process: its kind and the error."""

    kind: str
    error: str


def dataset_videos(
    folder: Path,
    arrays: dict,
    grids: dict | None = None,
    *,
    fps: float | None = None,
    executor=None,
    grid_note: str = "",
) -> list[Path]:
    """All per-dataset videos into ``folder`` (``videos/``), rendered in
    ``executor``'s workers when one is given."""
    return save_videos(
        folder, start_videos(arrays, grids, fps=fps, executor=executor, grid_note=grid_note)
    )


# ------------------------------------------------------------------ 3-D renders
class SurfaceCamera:
    """A fixed pinhole camera looking at a deforming grid along its thinnest axis.

    Set up once from all frames ``G (n_u, n_v, n_t, 3)`` so every frame is
    seen from the same place; renders headless with open3d's ray casting (no
    display, no GPU). With ``crop``, rays are cast only in the window that any
    frame projects into (the same pictures, fewer rays).
    """

    def __init__(self, G: np.ndarray, *, size: int = 320, fov_deg: float = 40.0, crop: bool = True):
        pts = G.reshape(-1, 3)
        pts = pts[np.isfinite(pts).all(axis=1)]
        center = pts.mean(axis=0)
        _, _, axes = np.linalg.svd(pts - center, full_matrices=False)
        view = axes[2]  # normal of the plane the tube bends in
        radius = np.linalg.norm(pts - center, axis=1).max()
        dist = 1.15 * radius / np.sin(np.radians(fov_deg) / 2)
        self.distance = dist  # mm from the eye to the centre
        self.eye = center + dist * view
        self.center, self.up, self.size, self.fov = center, axes[0], size, fov_deg
        self.light = view
        import open3d as o3d

        from ..mesh.strain import grid_triangles

        rays = self._all_rays()
        self._window = self.window(pts, rays) if crop else (slice(0, size), slice(0, size))
        # made once for all frames: the rays of the pixels any frame can cover, the triangles
        self._rays = o3d.core.Tensor(np.ascontiguousarray(rays[self._window]))
        self._F = grid_triangles(*G.shape[:2])
        self._F_tensor = o3d.core.Tensor(self._F.astype(np.uint32))

    def _all_rays(self) -> np.ndarray:
        """Ray origins and directions ``(size, size, 6)`` of every pixel."""
        import open3d as o3d

        return o3d.t.geometry.RaycastingScene.create_rays_pinhole(
            self.fov,
            self.center.tolist(),
            self.eye.tolist(),
            self.up.tolist(),
            self.size,
            self.size,
        ).numpy()

    def window(self, pts: np.ndarray, rays: np.ndarray, margin: int = 2) -> tuple[slice, slice]:
        """Rows and columns of the pixels onto which the points ``pts (n, 3)`` project
        (plus ``margin``), for the camera's ``rays`` (:meth:`_all_rays`)."""
        row, col = self.project(pts, rays)
        lo = np.floor([row.min(), col.min()]).astype(int) - margin
        hi = np.ceil([row.max(), col.max()]).astype(int) + margin + 1
        lo, hi = np.clip(lo, 0, self.size), np.clip(hi, 0, self.size)
        return slice(lo[0], hi[0]), slice(lo[1], hi[1])

    def project(
        self, pts: np.ndarray, rays: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The (row, column) pixel positions ``(n,)`` of the points ``pts (n, 3)``:
        the pinhole's ray directions are affine in the pixel indices on the plane of
        their tips, so two steps of it invert the projection."""
        rays = self._all_rays()[:2, :2] if rays is None else rays
        d00, d01, d10 = rays[0, 0, 3:], rays[0, 1, 3:], rays[1, 0, 3:]
        col_step, row_step = d01 - d00, d10 - d00
        ahead = np.cross(col_step, row_step)  # normal of the tips' plane
        rel = np.atleast_2d(pts) - self.eye
        tips = rel * ((d00 @ ahead) / (rel @ ahead))[:, None] - d00
        return tips @ row_step / (row_step @ row_step), tips @ col_step / (col_step @ col_step)

    def render(
        self,
        X: np.ndarray,
        values: np.ndarray,
        *,
        vmin: float,
        vmax: float,
        cmap: str = "coolwarm",
        cyclic: bool = False,
    ) -> np.ndarray:
        """RGB uint8 ``(size, size, 3)`` of the grid surface ``X (n_u, n_v, 3)`` (a frame of
        the camera's ``G``) coloured by ``values (n_u, n_v)`` with simple Lambert shading
        on a white background. ``cyclic``: [vmin, vmax) wraps (a phase), and a pixel's
        value is its triangle's corners' circular mean (their plain mean runs through
        the middle of the scale where a front wraps: a black seam in twilight)."""
        import open3d as o3d

        F = self._F
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(X.reshape(-1, 3).astype(np.float32)), self._F_tensor)
        hit = scene.cast_rays(self._rays)
        prim = hit["primitive_ids"].numpy().astype(np.int64)
        ok = prim != np.iinfo(np.uint32).max
        img = np.full((self.size, self.size, 3), 255, np.uint8)
        if not ok.any():
            return img
        view = img[self._window]  # only its pixels can show the tube
        tri = F[prim[ok]]
        b = hit["primitive_uvs"].numpy()[ok].astype(float)
        w = np.column_stack([1 - b.sum(axis=1), b])
        corners = values.reshape(-1)[tri]
        if cyclic:
            turn = 2 * np.pi / (vmax - vmin)
            mean = np.einsum("ij,ij->i", w, np.exp(1j * turn * (corners - vmin)))
            val = vmin + np.mod(np.angle(mean), 2 * np.pi) / turn
        else:
            val = np.einsum("ij,ij->i", w, corners)
        normals = hit["primitive_normals"].numpy()[ok]
        shade = 0.35 + 0.65 * np.abs(normals @ self.light)
        rgb = to_rgb(val, vmin, vmax, cmap).astype(float) * shade[:, None]
        view[ok] = np.clip(rgb, 0, 255).astype(np.uint8)
        return img


def _fit_height(img: np.ndarray, height: int) -> np.ndarray:
    """``img`` padded with white below to ``height`` rows, or shrunk to it (area
    averaging, so that its text stays legible) if it is taller."""
    if img.shape[0] <= height:
        out = np.full((height,) + img.shape[1:], 255, np.uint8)
        out[: img.shape[0]] = img
        return out
    scale = height / img.shape[0]
    return cv2.resize(img, (int(round(img.shape[1] * scale)), height), interpolation=cv2.INTER_AREA)


def _mark_ends(view: np.ndarray, camera: "SurfaceCamera", X: np.ndarray) -> None:
    """ "inlet" and "outlet" written on the 3-D ``view`` just beyond the grid ``X
    (n_u, n_v, 3)``'s first and last rings, along the tube's direction there."""
    ends = np.array(
        [
            np.nanmean(X[:, 0], axis=0),
            np.nanmean(X[:, 1], axis=0),
            np.nanmean(X[:, -2], axis=0),
            np.nanmean(X[:, -1], axis=0),
        ]
    )
    if not np.isfinite(ends).all():
        return
    row, col = camera.project(ends)
    for (r0, c0), (r1, c1), name in (
        ((row[1], col[1]), (row[0], col[0]), "inlet"),
        ((row[2], col[2]), (row[3], col[3]), "outlet"),
    ):
        step = np.array([c1 - c0, r1 - r0])
        step = step / (np.linalg.norm(step) or 1.0)
        x, y = np.array([c1, r1]) + 28 * step  # beyond the end, off the tube
        _text(
            view,
            name,
            (int(np.clip(x, 30, view.shape[1] - 30)), int(np.clip(y + 5, 16, view.shape[0] - 40))),
            scale=0.45,
            align="centre",
            colour=(120, 0, 0),
        )


def surface_and_map_frames(
    G: np.ndarray,
    values: np.ndarray,
    t_ms: np.ndarray,
    *,
    flat: np.ndarray | None = None,
    cmap: str | None = None,
    limits: tuple[float, float] | None = None,
    label: str = "",
    title: str = "",
    size: int = 480,
    length_mm: float | None = None,
):
    """Frames ``(rows, cols, 3)`` uint8, one at a time (a 195-frame video would hold
    ~190 MB), at least 1280 pixels wide: the 3-D grid surface coloured by ``values
    (n_u, n_v, n_t)``, with a scale bar, next to a flat picture (``flat``: frames in
    order, an array or one at a time; default the unfolded (u, v) map of the same
    values with its axes and colour bar), under a banner with ``title``, the time and
    the phase in the beat; ``limits``: the colour scale's (default the house's for the
    values). Drawn in order: each frame is taken when it is drawn."""
    from .style import colour_scale

    scale_ = colour_scale(values)
    cmap = cmap or scale_["cmap"]
    lo, hi = limits or (scale_.get("vmin", 0.0), scale_.get("vmax", 1.0))
    camera = SurfaceCamera(G, size=size)
    if flat is None:  # as tall as the 3-D view, so that its text is not resized
        flat = field_frames(
            values,
            t_ms,
            vmin=lo,
            vmax=hi,
            cmap=cmap,
            label=label,
            scale=max(2, (size - BANNER - MARGIN_BOTTOM) // values.shape[1]),
            title=label,
            length_mm=length_mm,
            stream=True,
        )
    flat = iter(flat)  # an array's frames, or frames drawn one at a time
    period = t_ms[-1] + (t_ms[1] - t_ms[0]) if len(t_ms) > 1 else 1.0
    px_per_mm = size / (2 * camera.distance * np.tan(np.radians(camera.fov) / 2))  # at its centre
    # the longest round length whose bar fits in a third of the picture
    bar_mm = next((x for x in (2.0, 1.0, 0.5, 0.2, 0.1, 0.05) if x * px_per_mm < size / 3), 0.05)
    bar_text = f"{bar_mm:g} mm"

    def draw(t):
        view = camera.render(
            G[:, :, t], values[:, :, t], vmin=lo, vmax=hi, cmap=cmap, cyclic=cmap == CYCLIC
        )
        cv2.line(
            view, (16, size - 20), (16 + int(round(bar_mm * px_per_mm)), size - 20), (0, 0, 0), 3
        )
        _text(view, f"{bar_text} (at the tube's centre)", (16, size - 30), scale=0.45)
        _mark_ends(view, camera, G[:, :, t])
        side = np.concatenate([view, _fit_height(next(flat), size)], axis=1)
        frame = np.full((BANNER + size, max(side.shape[1], 1280), 3), 255, np.uint8)
        frame[BANNER:, : side.shape[1]] = side
        _text(frame, title or label, (8, 20), scale=0.55, max_width=frame.shape[1] - 16)
        _stamp(frame, t_ms[t], (t_ms[t] % period) / period, size - 16)
        return _even(frame)

    return (draw(t) for t in range(G.shape[2]))
