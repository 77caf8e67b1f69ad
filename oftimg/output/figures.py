"""Figures of one dataset's results and of a cohort (matplotlib, no display needed).

Each function takes the arrays it draws and a path, and writes one figure in the
house style (:mod:`oftimg.output.style`): a PNG at that path, a PDF and an SVG beside it.
"""

from __future__ import annotations

import warnings

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from ..analysis.group_maps import groups_in_order  # noqa: E402
from . import numbers, units  # noqa: E402
from .style import (
    COLUMN_MM,
    CYCLIC,
    DIVERGING,
    LINE_COLOURS,
    MM,
    PAGE_MM,  # noqa: E402
    SEQUENTIAL,
    bar_label,
    colour_bar,
    house_style,
    new_figure,
    nothing_to_show,
    save,
    wrapped,
)

# Okabe-Ito colours (style.LINE_COLOURS), one per wall and layer
WALL_COLOURS = {
    "outer": "#D55E00",
    "inner": "#E69F00",
    "lumen": "#0072B2",
    "myocardium": "#CC79A7",
    "jelly": "#009E73",
}
LAYERS = {"myocardium": "myocardium (outer - inner)", "jelly": "cardiac jelly (inner - lumen)"}


def plain_text(text: str) -> str:
    """``text`` drawn as it is: a dataset's or group's name with "$" in it would be
    read as matplotlib mathtext (and an unbalanced "$a^{" stops the run)."""
    return str(text).replace("$", r"\$")


@house_style
def volume_over_cycle(
    t_ms: np.ndarray, volumes_mm3: dict[str, np.ndarray], path: Path, *, title: str = ""
) -> Path:
    """Volumes of each wall, and of the layers between them (``myocardium``: outer -
    inner, ``jelly``: inner - lumen), over the aligned cycle."""
    fig, axes = new_figure(PAGE_MM, 62, ncols=2)
    for name, v in volumes_mm3.items():
        ax = axes[1] if name in LAYERS else axes[0]
        ax.plot(t_ms, v, color=WALL_COLOURS.get(name, "k"), label=LAYERS.get(name, name), lw=1.6)
    for ax, what in zip(axes, ("volume inside each wall", "volume between the walls")):
        ax.set_xlabel("time since minimum volume (ms)")
        ax.set_ylabel("volume (mm$^3$)")
        ax.set_title(what, fontsize=9)
        ax.ticklabel_format(axis="y", useOffset=False)  # no "+1.25e2" above the axis
        if ax.get_legend_handles_labels()[0]:  # below the axes: never on a curve
            ax.legend(
                fontsize=8,
                loc="upper center",
                bbox_to_anchor=(0.5, -0.25),
                ncol=3,
                frameon=False,
                handlelength=1.5,
                columnspacing=1.2,
            )
        ax.grid(alpha=0.3)
    if not any(name in LAYERS for name in volumes_mm3):
        nothing_to_show(
            axes[1],
            "one wall only: no layer between walls (the dataset has no inner wall or lumen)",
            PAGE_MM / 2,
        )
    fig.suptitle(wrapped(plain_text(title), PAGE_MM, 9))
    return save(fig, path)


@house_style
def trim_over_cycle(
    t_ms: np.ndarray,
    trim_percent: np.ndarray,
    myocardial_mm3: np.ndarray,
    path: Path,
    *,
    title: str = "",
) -> Path:
    """The paper's volume-normalisation figure: myocardial volume and trim distance."""
    fig, axes = new_figure(PAGE_MM, 62, ncols=2)
    axes[0].plot(t_ms, myocardial_mm3, color=WALL_COLOURS["myocardium"])
    axes[0].set_ylabel("myocardial volume (mm$^3$)")
    axes[0].set_title("between outer and inner myocardium", fontsize=9)
    axes[1].plot(t_ms, trim_percent, color="k")
    axes[1].set_ylabel("trim distance (% of length)")
    axes[1].set_title("clipping for constant myocardial volume", fontsize=9)
    for ax in axes:
        ax.set_xlabel("time since minimum volume (ms)")
        ax.grid(alpha=0.3)
    fig.suptitle(wrapped(plain_text(title), PAGE_MM, 9))
    return save(fig, path)


def fit_axes(fig, ax, *, below, margin_px: float = 6.0, rounds: int = 6) -> None:
    """Move and scale ``ax`` so that what it draws (box, ticks, labels: its ink in the
    rendered figure) fills the figure below the artist ``below`` (a legend or title),
    centred: a 3-D axes' box is a small part of its axes, and where in them depends on
    the tube's proportions."""
    for _ in range(rounds):
        fig.canvas.draw()
        top = below.get_window_extent(fig.canvas.get_renderer()).y0 - margin_px
        pixels = np.asarray(fig.canvas.buffer_rgba())
        height_px = pixels.shape[0]
        ink = (pixels[..., :3] < 245).any(axis=-1)
        ink[: int(np.ceil(height_px - top))] = False  # the legend and title above
        rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
        if not len(rows):
            return
        # the ink's box in display pixels (y up)
        x0, x1, y0, y1 = cols[0], cols[-1] + 1, height_px - rows[-1] - 1, height_px - rows[0]
        width, height = fig.bbox.width - 2 * margin_px, top - margin_px
        factor = min(width / (x1 - x0), height / (y1 - y0))
        pos = ax.get_position().transformed(fig.transFigure)  # pixels
        # scaled about the axes' corner, then moved so that the ink is centred
        ink_x0 = pos.x0 + factor * (x0 - pos.x0)
        ink_y0 = pos.y0 + factor * (y0 - pos.y0)
        shift_x = margin_px + (width - factor * (x1 - x0)) / 2 - ink_x0
        shift_y = margin_px + (height - factor * (y1 - y0)) / 2 - ink_y0
        ax.set_position(
            [
                (pos.x0 + shift_x) / fig.bbox.width,
                (pos.y0 + shift_y) / fig.bbox.height,
                pos.width * factor / fig.bbox.width,
                pos.height * factor / fig.bbox.height,
            ]
        )


def attempt(failed: list, draw, *args, **kwargs):
    """``draw(*args, **kwargs)`` (a figure's path), or None with the failure recorded in
    ``failed`` (``{"figure", "error"}``): a figure that cannot be drawn is data, as a
    degenerate section is, and never stops a run whose numbers are made (a warning
    inside matplotlib once ended whole runs)."""
    try:
        return draw(*args, **kwargs)
    except Exception as exc:  # noqa: BLE001 -- any drawing's failure, recorded
        plt.close("all")
        path = next((a for a in args if isinstance(a, Path)), None)
        failed.append(
            {
                "figure": path.name if path else draw.__name__,
                "error": f"{type(exc).__name__}: {exc}"[:300],
            }
        )
        return None


ZOOM_3D = 0.9  # the 3-D box's share of its axes: a thin tube's box is flat


@house_style
def frame_with_contours(
    grid_mm: np.ndarray,
    contours_mm: dict[str, np.ndarray],
    path: Path,
    *,
    rows=(0.1, 0.5, 0.9),
    title: str = "",
) -> Path:
    """3-D view of one frame's outer grid with a few section contours of each wall.

    ``grid_mm (n_u, n_v, 3)``, ``contours_mm[wall] (n_c, n_v, 3)``.
    """
    fig = plt.figure(figsize=(COLUMN_MM * MM, 62 * MM))
    ax = fig.add_axes((0.2, 0.15, 0.6, 0.5), projection="3d")  # all inside: fit_axes sees it
    n_u, n_v, _ = grid_mm.shape
    for i in range(0, n_u, 4):
        ax.plot(*grid_mm[i].T, color="#bbb", lw=0.5)
    ax.plot(*grid_mm[0].T, color="#1f4e9c", lw=2, label="seam (u = 0)")
    for frac in rows:
        j = int(round(frac * (n_v - 1)))
        for wall, C in contours_mm.items():
            ring = np.concatenate([C[:, j], C[:1, j]])
            ax.plot(
                *ring.T, color=WALL_COLOURS[wall], lw=1.5, label=wall if frac == rows[0] else None
            )
    ax.set_box_aspect(np.ptp(grid_mm.reshape(-1, 3), axis=0), zoom=ZOOM_3D)  # true proportions
    from matplotlib.ticker import MaxNLocator

    # few ticks, at the ends of the axis (its label sits in the middle): one, the middle
    # one, on an axis under a quarter of the longest (a flat tube's); x's last and y's
    # first meet at the near corner: each leaves that one out
    extent = np.ptp(grid_mm.reshape(-1, 3), axis=0)
    for axis, name, k in ((ax.xaxis, "x", 0), (ax.yaxis, "y", 1), (ax.zaxis, "z", 2)):
        axis.set_label_text(f"{name} (mm)")
        lo, hi = sorted(axis.get_view_interval())
        ticks = [x for x in MaxNLocator(4).tick_values(lo, hi) if lo <= x <= hi]
        if not ticks:
            continue
        if extent[k] < 0.25 * extent.max() or len(ticks) == 1:
            ticks = [min(ticks, key=lambda x: abs(x - (lo + hi) / 2))]
        else:
            ticks = {"x": [ticks[0]], "y": [ticks[-1]]}.get(name, [ticks[0], ticks[-1]])
        axis.set_ticks(ticks)
    ax.tick_params(pad=0)
    ax.xaxis.labelpad, ax.yaxis.labelpad, ax.zaxis.labelpad = 4, 8, 2
    ax.view_init(elev=18, azim=-40)  # the x and y tick labels apart at the near corner
    legend = fig.legend(
        fontsize=7,
        loc="upper center",
        bbox_to_anchor=(0.5, 0.9),
        ncol=4,
        handlelength=1.5,
        columnspacing=1.0,
        frameon=False,
    )
    fig.suptitle(wrapped(plain_text(title), COLUMN_MM, 9))
    fit_axes(fig, ax, below=legend)
    return save(fig, path)


def field_grid_note(summary: dict) -> str:
    """Which grid a dataset's per-pixel fields are on, for titles and captions:
    "tracked grid" (each node the same tissue all cycle) or "per-frame grid"."""
    return f"{(summary.get('tracking') or {}).get('grid', 'per-frame')} grid"


def dataset_figures(
    folder: Path,
    summary: dict,
    arrays: dict,
    grids: dict,
    pullbacks: dict | None = None,
    failed: list | None = None,
) -> list[Path]:
    """All per-dataset figures into ``folder`` (``figures/``); ``pullbacks``: the
    intensity pullbacks, when the dataset had intensity volumes. A figure that cannot
    be drawn is left out and recorded in ``failed`` (:func:`attempt`): a drawing never
    stops a run whose numbers are made."""
    failed = [] if failed is None else failed
    name = summary["name"]
    t_ms = arrays["t_ms"]
    written = []
    volumes = {
        w: arrays[f"volume_{w}_mm3"]
        for w in ("outer", "inner", "lumen")
        if f"volume_{w}_mm3" in arrays
    }
    volumes.update(
        {
            layer: arrays[f"volume_{layer}_mm3"]
            for layer in LAYERS
            if f"volume_{layer}_mm3" in arrays
        }
    )
    written.append(
        attempt(
            failed, volume_over_cycle, t_ms, volumes, folder / "volume_over_cycle.png", title=name
        )
    )
    if "trim_percent" in arrays:
        written.append(
            attempt(
                failed,
                trim_over_cycle,
                t_ms,
                arrays["trim_percent"],
                arrays["volume_myocardium_mm3"],
                folder / "trim_over_cycle.png",
                title=name,
            )
        )
    contours = {
        w: arrays[f"contour_{w}_mm"][:, :, 0]
        for w in ("outer", "inner", "lumen")
        if f"contour_{w}_mm" in arrays
    }
    written.append(
        attempt(
            failed,
            frame_with_contours,
            grids["outer"][:, :, 0],
            contours,
            folder / "frame_t0_contours.png",
            title=f"{name}: t = 0 (minimum volume)",
        )
    )
    if "ridge_t_ms" in arrays:
        written += map_figures(folder, name, arrays, summary, summary["period_ms"], failed)
    for wall, found in (summary.get("wave_fronts") or {}).items():
        if isinstance(found, dict) and f"activation_time_{wall}_ms" in arrays:
            how = (
                f"{found['speed_mm_s']:.1f} mm/s on the wall, helix angle "
                f"{round(found['helix_angle_deg']):d}°"
                if found["propagates"]
                else "no propagation: the wall moves at once"
            )
            written.append(
                attempt(
                    failed,
                    activation_figure,
                    arrays[f"activation_time_{wall}_ms"],
                    arrays[f"wave_velocity_{wall}_mm_s"],
                    grids[wall].mean(axis=2),
                    summary["period_ms"],
                    folder / f"activation_{wall}.png",
                    s_mm=arrays["s_mm"],
                    title=f"{name}: the wave's fronts on the {wall} wall ({how})",
                )
            )
            if found["propagates"]:
                written.append(
                    attempt(
                        failed,
                        wave_speed_figure,
                        arrays[f"wave_velocity_{wall}_mm_s"],
                        arrays["s_mm"],
                        folder / f"wave_speed_{wall}.png",
                        title=f"{name}: the wave's speed on the {wall} wall (median "
                        f"{found['speed_mm_s']:.1f} mm/s)",
                    )
                )
    if pullbacks:
        written.append(
            attempt(
                failed,
                pullback_figure,
                pullbacks["pullback_outer_mean"],
                arrays.get("pathlines_uv"),
                t_ms,
                folder / "pullback_outer.png",
                title=f"{name}: the myocardium's intensity on the grid",
                support=arrays.get("texture_support"),
                fallback=arrays.get("texture_fallback"),
            )
        )
    if "lumen_aspect_ratio" in arrays:
        share = summary.get("cushions", {}).get("closed_share_max", 0.0)
        how = f"closed up to {100 * share:.0f} % of the cycle" if share else "never closed"
        written.append(
            attempt(
                failed,
                cushion_map,
                arrays["lumen_aspect_ratio"],
                arrays["lumen_closed"],
                arrays["lumen_close_ms"],
                arrays["lumen_open_ms"],
                arrays["s_mm"],
                t_ms,
                folder / "lumen_cushions.png",
                title=f"{name}: the lumen's ellipticity and closure ({how})",
            )
        )
    for layer, what in (("wall", "myocardial wall"), ("jelly", "cardiac jelly")):
        if f"{layer}_thickness_mm" in arrays:
            from ..analysis.fields import mean_around_tube

            rows = units.THICKNESS.scale * mean_around_tube(
                arrays[f"{layer}_thickness_mm"]
            )  # (n_v, n_t)
            written.append(
                attempt(
                    failed,
                    area_map,
                    rows,
                    arrays["s_mm"],
                    t_ms,
                    folder / f"{layer}_thickness_map.png",
                    ridge_t_ms=arrays.get("ridge_t_ms"),
                    cmap="viridis",
                    label=units.label(f"{layer} thickness, mean around the tube", "thickness"),
                    blank="no value: tissue out of view",
                    title=f"{name}: {what} thickness, "
                    f"{field_grid_note(summary)} (dots: maximum "
                    "outer area)",
                )
            )
    return [path for path in written if path is not None]


# ------------------------------------------------------------------ wave fronts
ARROW_EVERY = (8, 5)  # a velocity arrow every 8 nodes around, 5 along


def _isochrone_field(time_ms: np.ndarray, period_ms: float) -> np.ndarray:
    """Activation times ``(n_u, n_v)`` unwrapped about their circular mean, with NaN
    where two neighbours lie more than a third of the cycle apart (where a helical
    front's times go round the cycle): contours do not bunch along that line."""
    from ..image.activation import unwrapped

    t = unwrapped(time_ms, period_ms)
    jump = np.zeros(t.shape, bool)
    for axis in (0, 1):
        big = np.abs(np.diff(t, axis=axis)) > period_ms / 3
        pad = [(0, 0), (0, 0)]
        pad[axis] = (0, 1)
        jump |= np.pad(big, pad)
        pad[axis] = (1, 0)
        jump |= np.pad(big, pad)
    return np.where(jump, np.nan, t)


def _time_colours(time_ms: np.ndarray, period_ms: float) -> tuple[np.ndarray, dict, str]:
    """The activation times to colour by, their ``imshow`` keywords and their colour
    bar's label: after the wall's earliest node in viridis when they span under half
    the cycle (a wave along the tube), else the times in the cycle in a cyclic map (a
    helical front's go once round the cycle); all NaN (a wall too still to time) as
    they are, on the cycle's scale."""
    from ..image.activation import unwrapped

    if not np.isfinite(time_ms).any():
        return (
            time_ms,
            {"cmap": SEQUENTIAL, "vmin": 0.0, "vmax": float(period_ms)},
            "activation time (ms)",
        )
    t = unwrapped(time_ms, period_ms)
    t = t - np.nanmin(t)
    if np.nanpercentile(t, 99) < period_ms / 2:
        return (
            t,
            {"cmap": SEQUENTIAL, "vmin": 0.0, "vmax": float(np.nanpercentile(t, 99))},
            "activation time (ms after the earliest node)",
        )
    return (
        time_ms,
        {"cmap": CYCLIC, "vmin": 0.0, "vmax": float(period_ms)},
        "activation time (ms after minimum volume; cyclic)",
    )


def _nice_step(span: float, count: int = 8) -> float:
    """A round step (1, 2 or 5 times a power of ten) giving about ``count`` steps over
    ``span``."""
    raw = max(span / count, 1e-9)
    power = 10 ** np.floor(np.log10(raw))
    return float(min((m * power for m in (1, 2, 5, 10)), key=lambda x: abs(x - raw)))


@house_style
def activation_figure(
    time_ms: np.ndarray,
    velocity_mm_s: np.ndarray,
    grid_mm: np.ndarray,
    period_ms: float,
    path: Path,
    *,
    s_mm: np.ndarray | None = None,
    title: str = "",
) -> Path:
    """One wall's activation: left the (u, s) plane (u across from the seam, s up from
    the inlet in mm, ``s_mm (n_v,)``; v as a share of the length without it) coloured
    by the activation time ``(n_u, n_v)`` (:func:`_time_colours`), its isochrones at a
    round step (about 8 over the times' span; :func:`isochrones`) and arrows along the
    wave's direction on the wall (``velocity_mm_s`` ``(n_u, n_v, 2)``, along and
    around, each arrow the same length); right the wall's mean shape ``grid_mm``
    ``(n_u, n_v, 3)`` in 3-D, coloured the same, the isochrones drawn on it, its inlet
    and outlet named and a scale bar. Nodes without a velocity (moving too little to
    time the wave) are grey."""
    n_u, n_v = time_ms.shape
    timed = np.isfinite(velocity_mm_s[..., 0])
    time_ms = np.where(timed, time_ms, np.nan)
    shown, scale, label = _time_colours(time_ms, period_ms)
    cyclic = scale["cmap"] == CYCLIC
    scale["cmap"] = plt.get_cmap(scale["cmap"]).with_extremes(bad=BLANK_GREY)
    along_tube = np.asarray(s_mm, float) if s_mm is not None else np.arange(n_v) / (n_v - 1)
    fig = plt.figure(figsize=(PAGE_MM * MM, 80 * MM))
    ax = fig.add_axes((0.08, 0.16, 0.4, 0.68))
    half = 0.5 * (along_tube[1] - along_tube[0])
    extent = [-0.5 / n_u, 1 - 0.5 / n_u, along_tube[0] - half, along_tube[-1] + half]
    image = ax.imshow(
        shown.T, origin="lower", aspect="auto", extent=extent, interpolation="nearest", **scale
    )
    u = np.arange(n_u) / n_u
    lines, step = [], None
    if timed.sum() > 3:
        iso = _isochrone_field(time_ms, period_ms)
        step = _nice_step(np.nanpercentile(iso, 99) - np.nanpercentile(iso, 1))
        lines = isochrones(iso, step)
        for line in lines:  # (u, v) in [0, 1): v to the plot's axis
            ax.plot(
                line[:, 0],
                np.interp(line[:, 1] * (n_v - 1), np.arange(n_v), along_tube),
                color="k",
                lw=0.5,
            )
    along, around = velocity_mm_s[..., 0], velocity_mm_s[..., 1]
    norm = np.hypot(along, around)
    with np.errstate(invalid="ignore", divide="ignore"):
        du, dv = around / norm, along / norm
    k, j = ARROW_EVERY
    picked = (slice(k // 2, None, k), slice(j // 2, None, j))  # off the panel's edges
    U, V = np.meshgrid(u[picked[0]], along_tube[picked[1]], indexing="ij")
    drawn = np.isfinite(du[picked]) & np.isfinite(dv[picked])  # none where too still
    if drawn.any():
        ax.quiver(
            U[drawn],
            V[drawn],
            du[picked][drawn],
            dv[picked][drawn],
            color="w",
            scale=28,
            width=0.004,
            headwidth=4,
            pivot="mid",
        )
    ax.set_xlim(extent[:2])
    ax.set_ylim(extent[2:])
    ax.set_xlabel("u, around the tube from the seam")
    ax.set_ylabel(
        "distance along the tube from the inlet (mm)"
        if s_mm is not None
        else "v, along the tube (inlet 0)"
    )
    ax.set_title(
        "grey: the wall too still to time anywhere"
        if step is None
        else f"isochrones every {step:g} ms; arrows: the wave's direction"
        if timed.all()
        else f"isochrones every {step:g} ms; arrows: direction; grey: too still"
    )
    ax3 = fig.add_axes((0.5, 0.06, 0.3, 0.84), projection="3d")
    ring = np.concatenate([grid_mm, grid_mm[:1]], axis=0)
    values = np.concatenate([shown, shown[:1]], axis=0)
    quads, colours = _surface_quads(ring, values, scale, cyclic=cyclic)
    surface = Poly3DCollection(
        quads, facecolors=colours, edgecolors=colours, linewidths=0, antialiased=False
    )
    surface.set_rasterized(True)  # a picture in the PDF: 2000 quads drawn once
    ax3.add_collection3d(surface)
    ax3.auto_scale_xyz(*ring[np.isfinite(ring).all(axis=-1)].T)
    elev, azim = np.radians(25.0), np.radians(-60.0)
    ax3.view_init(elev=25, azim=-60)
    towards_eye = np.array([np.cos(elev) * np.cos(azim), np.cos(elev) * np.sin(azim), np.sin(elev)])
    centre = grid_mm.mean(axis=0, keepdims=True)
    outside = centre + 1.04 * (grid_mm - centre)  # the lines just off the wall
    for line in lines:
        points = _on_grid(outside, line[:, 0], line[:, 1])
        facing = (
            points - _on_grid(centre.repeat(n_u, axis=0), line[:, 0], line[:, 1])
        ) @ towards_eye > 0  # the wall's far side: hidden
        points[~facing] = np.nan
        ax3.plot(*points.T, color="k", lw=0.6, zorder=5)
    ax3.set_box_aspect(np.ptp(grid_mm.reshape(-1, 3), axis=0), zoom=1.3)
    ax3.set_axis_off()
    _orientation_3d(ax3, grid_mm, elev, azim)
    bar = fig.colorbar(image, cax=fig.add_axes((0.8, 0.2, 0.015, 0.6)))
    bar.set_label(bar_label(fig, ax, label))
    bar.outline.set_linewidth(0.5)
    fig.suptitle(wrapped(plain_text(title), PAGE_MM, 9))
    return save(fig, path)


# isochrone pieces shorter than this many grid nodes are left out: a front's fragment
# at a band's edge or where the times scatter, not a front
ISOCHRONE_MIN_NODES = 6.0


def isochrones(field: np.ndarray, step: float) -> list[np.ndarray]:
    """The isochrones of activation times ``field (n_u, n_v)`` (ms, NaN where not
    timed) at multiples of ``step`` ms: polylines ``(k, 2)`` in (u, v), u in [0, 1) from
    the seam (periodic: traced on the field repeated a quarter turn either side, kept
    where they start in the turn itself), v in [0, 1] from the inlet; the field lightly
    smoothed first where timed (a node's Gaussian), pieces under
    :data:`ISOCHRONE_MIN_NODES` long left out. scikit-image's marching squares."""
    from scipy import ndimage
    from skimage.measure import find_contours

    n_u, n_v = field.shape
    known = np.isfinite(field)
    mode = ("wrap", "nearest")
    weight = ndimage.gaussian_filter(known.astype(float), 1.0, mode=mode)
    with np.errstate(invalid="ignore", divide="ignore"):
        smooth = ndimage.gaussian_filter(np.where(known, field, 0.0), 1.0, mode=mode) / weight
    pad = n_u // 4
    wrapped_field = np.pad(np.where(known, smooth, np.nan), ((pad, pad), (0, 0)), mode="wrap")
    mask = np.isfinite(wrapped_field)
    filled = np.where(mask, wrapped_field, np.nanmean(field))
    out = []
    for level in (
        np.arange(np.floor(np.nanmin(field) / step), np.ceil(np.nanmax(field) / step) + 1) * step
    ):
        for line in find_contours(filled, level, mask=mask):
            if np.linalg.norm(np.diff(line, axis=0), axis=1).sum() < ISOCHRONE_MIN_NODES:
                continue
            inside = (line[:, 0] >= pad) & (line[:, 0] <= pad + n_u)  # the turn itself
            runs = np.split(np.arange(len(line)), np.flatnonzero(np.diff(inside)) + 1)
            out += [
                np.column_stack([(line[r, 0] - pad) / n_u, line[r, 1] / (n_v - 1)])
                for r in runs
                if inside[r[0]] and len(r) > 1
            ]
    return out


def _orientation_3d(ax3, grid_mm: np.ndarray, elev: float, azim: float) -> None:
    """The 3-D view's inlet and outlet named just beyond the wall's ends as drawn, and a
    scale bar of a round length (about a third of the tube's) in the panel's lower left
    corner, as long as that length across the view at the tube's middle. In the view's
    own 2-D coordinates (its projection), so that they stay in the panel however the
    tube lies."""
    from matplotlib import patheffects
    from matplotlib.lines import Line2D
    from mpl_toolkits.mplot3d import proj3d

    fig = ax3.figure
    projection = ax3.get_proj()

    def in_panel(points: np.ndarray) -> np.ndarray:  # (n, 3) mm -> (n, 2) axes fraction
        x, y, _ = proj3d.proj_transform(*points.T, projection)
        return ax3.transAxes.inverted().transform(ax3.transData.transform(np.c_[x, y]))

    inlet, outlet = grid_mm[:, 0].mean(axis=0), grid_mm[:, -1].mean(axis=0)
    middle = grid_mm.reshape(-1, 3).mean(axis=0)
    flat = in_panel(np.stack([inlet, outlet, middle]))
    for k, name in enumerate(("inlet", "outlet")):
        away = flat[k] - flat[2]
        away /= np.linalg.norm(away) + 1e-12
        ax3.annotate(
            name,
            xy=tuple(np.clip(flat[k], 0.05, 0.95)),
            xycoords="axes fraction",
            xytext=tuple(12 * away),
            textcoords="offset points",
            fontsize=7,
            ha="center",
            va="center",  # readable on the wall's colours
            path_effects=[patheffects.withStroke(linewidth=2, foreground="w")],
        )
    bar_mm = _nice_step(0.35 * np.linalg.norm(outlet - inlet), count=1)
    across = np.array([-np.sin(azim), np.cos(azim), 0.0])  # the view's horizontal
    ends = in_panel(np.stack([middle, middle + bar_mm * across]))
    span = float(np.linalg.norm(ends[1] - ends[0]))
    fig.add_artist(
        Line2D([0.05, 0.05 + span], [0.04, 0.04], transform=ax3.transAxes, color="k", lw=1.2)
    )
    fig.text(
        0.05 + span / 2,
        0.06,
        f"{bar_mm:g} mm",
        transform=ax3.transAxes,
        fontsize=7,
        ha="center",
        va="bottom",
    )


@house_style
def wave_speed_figure(
    velocity_mm_s: np.ndarray, s_mm: np.ndarray, path: Path, *, title: str = ""
) -> Path:
    """The wave's speed on one wall (``velocity_mm_s`` ``(n_u, n_v, 2)``, along and
    around, mm/s) over (u, s): how fast the front crosses the wall at each node, grey
    where the wall moves too little to time it; the colours on a log scale (a distal
    segment several times faster than the proximal one, both seen) from the 2nd to the
    98th percentile (a node where the front barely turns, whose speed grows without
    bound, does not take the scale)."""
    n_u, n_v = velocity_mm_s.shape[:2]
    speed = np.hypot(velocity_mm_s[..., 0], velocity_mm_s[..., 1])
    fig, ax = new_figure(COLUMN_MM, 70)
    half = 0.5 * (s_mm[1] - s_mm[0])
    extent = [-0.5 / n_u, 1 - 0.5 / n_u, s_mm[0] - half, s_mm[-1] + half]
    if not np.isfinite(speed).any():
        nothing_to_show(ax, "the wall moves too little to time its wave anywhere")
    else:
        from matplotlib.colors import LogNorm

        lo, hi = np.nanpercentile(speed, [2, 98])
        cmap = plt.get_cmap("viridis").with_extremes(bad=BLANK_GREY)
        image = ax.imshow(
            speed.T,
            origin="lower",
            aspect="auto",
            extent=extent,
            cmap=cmap,
            norm=LogNorm(max(lo, 1e-3), max(hi, 2e-3)),
            interpolation="nearest",
        )
        ax.set_xlabel("u, around the tube from the seam")
        ax.set_ylabel("distance along the tube from the inlet (mm)")
        bar = colour_bar(fig, image, ax, "the wave's speed on the wall (mm/s, log scale)")
        low, high = image.norm.vmin, image.norm.vmax
        ticks = [
            m * 10.0**k
            for k in range(int(np.floor(np.log10(low))), int(np.ceil(np.log10(high))) + 1)
            for m in (1, 2, 5)
            if low <= m * 10.0**k <= high
        ]
        bar.ax.minorticks_off()
        bar.set_ticks(ticks, labels=[f"{t:g}" for t in ticks])
    fig.suptitle(wrapped(plain_text(title), COLUMN_MM, 9))
    return save(fig, path)


def _surface_quads(
    ring_mm: np.ndarray, values: np.ndarray, scale: dict, every: int = 2, *, cyclic: bool = False
):
    """A surface's quads over every ``every``-th node of ``ring_mm`` ``(n_u + 1, n_v, 3)``
    (its first row repeated at the end), the last row and column always among them, as
    one array ``(n_quads, 4, 3)``, each coloured by its corner nodes' mean value
    (``values`` ``(n_u + 1, n_v)`` through ``scale``: cmap, vmin, vmax; ``cyclic``: the
    mean on the circle from vmin round to vmax, where a helical wave's times wrap: a
    plain mean of 355 and 5 ms is 180, a strip of the cycle's far colour along the
    wrap), quads with a corner out of view left out. Every quad has 4 corners:
    matplotlib's plot_surface strides its last row into shorter polygons, and pads a
    ragged list with uninitialised memory that it then projects (matplotlib issue
    32272: an overflow warning, one draw in about twelve, that stopped runs)."""
    rows = np.unique(np.r_[np.arange(0, len(ring_mm), every), len(ring_mm) - 1])
    cols = np.unique(np.r_[np.arange(0, ring_mm.shape[1], every), ring_mm.shape[1] - 1])
    P, W = ring_mm[np.ix_(rows, cols)], values[np.ix_(rows, cols)]
    quads = np.stack([P[:-1, :-1], P[1:, :-1], P[1:, 1:], P[:-1, 1:]], axis=2).reshape(-1, 4, 3)
    corners = np.stack([W[:-1, :-1], W[1:, :-1], W[1:, 1:], W[:-1, 1:]], axis=-1).reshape(-1, 4)
    low, span = scale["vmin"], scale["vmax"] - scale["vmin"]
    if cyclic:
        turn = np.exp(2j * np.pi * (corners - low) / span).mean(axis=1)
        share = np.mod(np.angle(turn) / (2 * np.pi), 1.0)
    else:
        share = (corners.mean(axis=1) - low) / span
    colours = plt.get_cmap(scale["cmap"])(share)
    whole = np.isfinite(quads).all(axis=(1, 2))
    return quads[whole], colours[whole]


def _on_grid(grid_mm: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Points ``(n, 3)`` of the surface ``grid_mm`` ``(n_u, n_v, 3)`` at (u, v) in
    [0, 1) x [0, 1] (bilinear, periodic in u)."""
    n_u, n_v, _ = grid_mm.shape
    x, y = np.mod(u, 1.0) * n_u, np.clip(v, 0, 1) * (n_v - 1)
    i0, j0 = np.floor(x).astype(int), np.minimum(np.floor(y).astype(int), n_v - 2)
    fx, fy = (x - i0)[:, None], (y - j0)[:, None]
    i1 = (i0 + 1) % n_u
    i0 %= n_u
    return (
        (1 - fx) * (1 - fy) * grid_mm[i0, j0]
        + fx * (1 - fy) * grid_mm[i1, j0]
        + (1 - fx) * fy * grid_mm[i0, j0 + 1]
        + fx * fy * grid_mm[i1, j0 + 1]
    )


# ------------------------------------------------------------------ (v, t) maps
BLANK_GREY = "0.82"  # a map's cells without a value: grey, named in the legend


def _map_extent(s_mm, t_ms):
    dt = t_ms[1] - t_ms[0] if len(t_ms) > 1 else 1.0
    return [t_ms[0] - dt / 2, t_ms[-1] + dt / 2, s_mm[0], s_mm[-1]]


def _saved_map(fig, ax, s_mm, t_ms, title: str, path: Path) -> Path:
    """A (v, t) map's axes labelled (time across, position up), its title and legend
    below it, saved to ``path``."""
    ax.set_xlabel("time since minimum volume (ms)")
    ax.set_ylabel("position along the tube s (mm)")
    ax.set_xlim(_map_extent(s_mm, t_ms)[:2])
    ax.set_title(wrapped(plain_text(title), COLUMN_MM))
    if ax.get_legend_handles_labels()[0]:
        fig.legend(loc="outside lower center", ncol=2, fontsize=7, columnspacing=1.0)
    return save(fig, path)


@house_style
def area_map(
    area_mm2: np.ndarray,
    s_mm: np.ndarray,
    t_ms: np.ndarray,
    path: Path,
    *,
    ridge_t_ms=None,
    crossings_75_ms=None,
    sigma_ms=None,
    title: str = "",
    label: str = "cross-sectional area (mm$^2$)",
    cmap: str = SEQUENTIAL,
    blank: str = "no value",
) -> Path:
    """The paper's Fig. 'area to line' A: area (or another (v, t) map, ``label``) as
    colour, v up (inlet at the bottom), t to the right, with the ridge (line), 75 %
    crossings (x) and one-sigma times (*); a sequential colour map (``cmap``) with its
    bar labelled ``label`` (quantity and unit). Cells without a value (NaN) grey, in
    the legend as ``blank``."""
    period = t_ms[-1] + (t_ms[1] - t_ms[0])
    fig, ax = new_figure(COLUMN_MM, 78)
    im = ax.imshow(
        area_mm2,
        origin="lower",
        aspect="auto",
        cmap=matplotlib.colormaps[cmap].with_extremes(bad=BLANK_GREY),
        extent=_map_extent(s_mm, t_ms),
        interpolation="nearest",
    )
    if np.isnan(area_mm2).any():
        ax.fill_between([], [], color=BLANK_GREY, label=blank)  # the legend's swatch
    colour_bar(fig, im, ax, label)
    if ridge_t_ms is not None:
        ax.plot(np.mod(ridge_t_ms, period), s_mm, "k.", ms=3, label="maximum area")
    if crossings_75_ms is not None:
        for row in crossings_75_ms:
            ax.plot(np.mod(row, period), s_mm, "kx", ms=3, zorder=3)
        ax.plot([], [], "kx", label="75 % of maximum")
    if sigma_ms is not None and ridge_t_ms is not None:
        star = dict(marker="*", ls="none", color="w", mec="k", mew=0.3, ms=4.5)  # seen on white
        for sign in (-1, 1):  # beneath the crosses it meets
            ax.plot(np.mod(ridge_t_ms + sign * sigma_ms, period), s_mm, zorder=2, **star)
        ax.plot([], [], label="maximum ± σ (Gaussian fit)", **star)
    return _saved_map(fig, ax, s_mm, t_ms, title, path)


@house_style
def cushion_map(
    aspect: np.ndarray,
    closed: np.ndarray,
    close_ms: np.ndarray,
    open_ms: np.ndarray,
    s_mm: np.ndarray,
    t_ms: np.ndarray,
    path: Path,
    *,
    title: str = "",
) -> Path:
    """Where and when the cushions close the lumen: the lumen's aspect ratio ``(n_v,
    n_t)`` (minor over major axis) as colour, v up, t to the right, its closed cells
    ``(n_v, n_t)`` bool in black, and each row's closing and opening times ``(n_v,)`` ms
    (the apposition's own, between frames) as markers."""
    period = t_ms[-1] + (t_ms[1] - t_ms[0])
    fig, ax = new_figure(COLUMN_MM, 78)
    shown = np.where(closed, np.nan, aspect)
    im = ax.imshow(
        shown,
        origin="lower",
        aspect="auto",
        vmin=0.0,
        vmax=1.0,
        cmap=matplotlib.colormaps[SEQUENTIAL].with_extremes(bad=BLANK_GREY),
        extent=_map_extent(s_mm, t_ms),
        interpolation="nearest",
    )
    if closed.any():
        ax.imshow(
            np.where(closed, 1.0, np.nan),
            origin="lower",
            aspect="auto",
            cmap=matplotlib.colors.ListedColormap(["black"]),
            extent=_map_extent(s_mm, t_ms),
            interpolation="nearest",
        )
        ax.fill_between([], [], color="black", label="closed (the cushions apposed)")
    if (np.isnan(shown) & ~closed).any():
        ax.fill_between([], [], color=BLANK_GREY, label="no value")
    colour_bar(fig, im, ax, "lumen aspect ratio (minor / major axis)")
    for times, marker, what in ((close_ms, "v", "closes"), (open_ms, "^", "opens")):
        if np.isfinite(times).any():
            ax.plot(
                np.mod(times, period),
                s_mm,
                ls="none",
                marker=marker,
                ms=3.5,
                color="w",
                mec="k",
                mew=0.4,
                label=f"lumen {what}",
            )
    return _saved_map(fig, ax, s_mm, t_ms, title, path)


@house_style
def max_area_profile(
    s_mm, max_area: dict, path: Path, *, sigma_area: dict | None = None, title: str = ""
) -> Path:
    """Fig. B: maximum area vs position, with the 75 % and one-sigma areas."""
    fig, ax = new_figure(COLUMN_MM, 75)
    for wall, a in max_area.items():
        c = WALL_COLOURS[wall]
        ax.plot(s_mm, a, color=c, lw=1.5)
        ax.plot(s_mm, 0.75 * a, color=c, lw=0.9, ls="--")
        if sigma_area and wall in sigma_area:
            ax.plot(s_mm, sigma_area[wall], color=c, lw=0.9, ls=":")
    # the key: a colour per wall, a line style per level
    for wall in max_area:
        ax.plot([], [], color=WALL_COLOURS[wall], lw=1.5, label=wall)
    for style_, what in (("-", "maximum"), ("--", "75 %"), (":", "one sigma")):
        if style_ != ":" or sigma_area:
            ax.plot([], [], color="0.3", ls=style_, lw=1, label=what)
    ax.set_xlabel("position along the tube s (mm)")
    ax.set_ylabel("cross-sectional area (mm$^2$)")
    fig.legend(loc="outside lower center", ncol=3, fontsize=7)
    ax.grid(alpha=0.3)
    ax.set_title(wrapped(plain_text(title), COLUMN_MM))
    return save(fig, path)


@house_style
def time_expanded(s_mm, shares: dict[str, np.ndarray], path: Path, *, title: str = "") -> Path:
    """Fig. C: % of the cycle each section is expanded."""
    fig, ax = new_figure(COLUMN_MM, 75)
    if not any(np.isfinite(share).any() for share in shares.values()):
        nothing_to_show(
            ax,
            "no row expands and contracts over the cycle (its area does not "
            "change beyond the frames' noise): no share of the cycle expanded",
        )
        ax.set_title(wrapped(plain_text(title), COLUMN_MM))
        return save(fig, path)
    for label, share in shares.items():
        ax.plot(s_mm, 100 * share, lw=1.6, label=label)
    ax.set_xlabel("position along the tube s (mm)")
    ax.set_ylabel("time expanded (% of cycle)")
    fig.legend(loc="outside lower center", ncol=2, fontsize=7)
    ax.grid(alpha=0.3)
    ax.set_title(wrapped(plain_text(title), COLUMN_MM))
    return save(fig, path)


@house_style
def derivative_image(
    rgb: np.ndarray, s_mm, t_ms, path: Path, *, rates=None, title: str = ""
) -> Path:
    """Fig. D: gradient angle as hue, magnitude as intensity, with the colour wheel."""
    from ..image.gradient import colour_wheel

    fig, (ax, wax) = new_figure(PAGE_MM, 80, ncols=2, width_ratios=(3.2, 1))
    ax.imshow(
        rgb, origin="lower", aspect="auto", extent=_map_extent(s_mm, t_ms), interpolation="nearest"
    )
    ax.set_xlabel("time since minimum volume (ms)")
    ax.set_ylabel("position along the tube s (mm)")
    ax.set_title(wrapped(plain_text(title), PAGE_MM * 0.7))
    wax.imshow(colour_wheel(), origin="upper")
    wax.set_axis_off()
    wax.set_title("key: hue = direction\n(d/dt right, d/ds up),\nbrightness = size", fontsize=7)
    if rates is not None:
        rate = units.AREA_RATE
        expand, contract = (numbers.number(rate.scale * r) for r in rates)
        wax.text(
            0.5,
            -0.08,
            f"max expansion\n{expand} {numbers.unit(rate.unit)}\nmax "
            f"contraction\n{contract} {numbers.unit(rate.unit)}",
            fontsize=7,
            ha="center",
            va="top",
            transform=wax.transAxes,
        )
    return save(fig, path)


@house_style
def ridge_plot(
    s_mm,
    ridge_t_ms,
    path: Path,
    *,
    knee=None,
    speed=None,
    ridge_sd_ms=None,
    speed_sd=None,
    bridged=None,
    title: str = "",
) -> Path:
    """Time of maximum expansion vs position, with the two-segment fit and local speed;
    ``ridge_sd_ms`` / ``speed_sd`` (``(n_v,)``, optional) as ± 1 SD bars / band;
    ``bridged`` (``(n_v,)`` bool, optional): rows that barely move, ringed, the line the
    speeds took across them dashed."""
    fig, axes = new_figure(PAGE_MM, 65, ncols=2)
    if not np.isfinite(ridge_t_ms).any():
        for ax in axes:
            nothing_to_show(
                ax,
                "no ridge: no row of the area map has a time of maximum area "
                "(the tube does not change over the cycle, or not as a wave)",
                PAGE_MM / 2,
            )
        bridged = None
    elif (
        bridged is not None
        and np.any(bridged)
        and np.any(~np.asarray(bridged, bool) & np.isfinite(ridge_t_ms))
    ):
        bridged = np.asarray(bridged, bool)
        moving = np.flatnonzero(~bridged & np.isfinite(ridge_t_ms))
        for k, (a, b) in enumerate(_bridges(bridged, moving)):  # over the fit, to be seen
            axes[0].plot(
                s_mm[[a, b]],
                ridge_t_ms[[a, b]],
                color="0.25",
                ls="--",
                lw=1.2,
                zorder=3,
                label="the line the speeds take across them" if k == 0 else None,
            )
        axes[0].plot(
            s_mm[bridged],
            ridge_t_ms[bridged],
            "o",
            mfc="none",
            mec="0.5",
            ms=7,
            label="rows that barely move",
        )
    if ridge_sd_ms is not None:
        axes[0].errorbar(
            s_mm,
            ridge_t_ms,
            yerr=ridge_sd_ms,
            fmt="k.",
            ms=4,
            elinewidth=0.6,
            label="ridge ± 1 SD (frame noise)",
        )
    else:
        axes[0].plot(s_mm, ridge_t_ms, "k.", label="ridge")
    if knee is not None and np.isfinite(knee["knee_mm"]):
        knee_mm = knee["knee_mm"]
        t_k = knee.get("knee_t_ms", np.interp(knee_mm, s_mm, ridge_t_ms))  # older: none
        speeds_mm_s = (knee["speed_proximal_mm_s"], knee["speed_distal_mm_s"])
        for s_end, c in zip((s_mm[0], s_mm[-1]), speeds_mm_s):
            axes[0].plot([s_end, knee_mm], [t_k + 1e3 * (s_end - knee_mm) / c, t_k], "r-", lw=1.2)
        axes[0].plot(
            [],
            [],
            "r-",
            lw=1.2,
            label="two-segment fit: "
            + ", ".join(f"{numbers.number(speed_mm_s)} mm/s" for speed_mm_s in speeds_mm_s),
        )
        axes[0].axvline(
            knee_mm, color="r", ls=":", lw=0.8, label=f"knee at {numbers.number(knee_mm)} mm"
        )
    axes[0].set_xlabel("position along the tube s (mm)")
    axes[0].set_ylabel("time of maximum area (ms)")
    if speed is None or not np.isfinite(speed).any():
        if np.isfinite(ridge_t_ms).any():
            nothing_to_show(
                axes[1],
                "no local wave speed: the rows reach their maximum area "
                "together within the noise (the tube moves all at once)",
                PAGE_MM / 2,
            )
    else:
        axes[1].plot(s_mm, speed, "b.-", lw=0.8)
        if speed_sd is not None:
            axes[1].fill_between(
                s_mm,
                speed - speed_sd,
                speed + speed_sd,
                color="b",
                alpha=0.2,
                lw=0,
                label="local speed ± 1 SD (frame noise)",
            )
            finite = np.isfinite(speed) & np.isfinite(speed_sd) & (speed_sd < np.abs(speed))
            if finite.any():  # unresolved rows (spread as large as the speed) off the scale
                lo = np.min((speed - speed_sd)[finite])
                hi = np.max((speed + speed_sd)[finite])
                pad = 0.1 * (hi - lo) + 1e-9
                axes[1].set_ylim(min(lo, 0) - pad, hi + pad)
                off = int((np.isfinite(speed) & ((speed < lo) | (speed > hi))).sum())
                if off:
                    axes[1].set_title(
                        f"{off} rows not resolved (spread ≥ speed) off the scale", fontsize=7
                    )
        axes[1].axhline(0, color="k", lw=0.5)
    axes[1].set_xlabel("position along the tube s (mm)")
    axes[1].set_ylabel("local wave speed (mm/s)")
    # one legend below both panels: off the ridge, which may rise or fall
    handles, labels = [sum(x, []) for x in zip(*(ax.get_legend_handles_labels() for ax in axes))]
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=7)
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle(wrapped(plain_text(title), PAGE_MM, 9))
    return save(fig, path)


def _bridges(bridged: np.ndarray, moving: np.ndarray) -> list[tuple[int, int]]:
    """Each run of ``bridged`` rows ``(n_v,)`` between two ``moving`` rows (indices,
    ascending): the moving rows on either side, which the speeds join by a line."""
    spans = []
    for a, b in zip(moving[:-1], moving[1:]):
        if b > a + 1 and bridged[a + 1 : b].any():
            spans.append((int(a), int(b)))
    return spans


def map_figures(
    folder: Path,
    name: str,
    arrays: dict,
    summary: dict,
    period_ms: float,
    failed: list | None = None,
) -> list[Path]:
    """The (v, t) map figures of one dataset (those that cannot be drawn recorded in
    ``failed``: :func:`attempt`)."""
    from ..image.gradient import gradient_hsv

    failed = [] if failed is None else failed
    s_mm, t_ms = arrays["s_mm"], arrays["t_ms"]
    area = arrays["area_outer_mm2"]
    written = [
        attempt(
            failed,
            area_map,
            area,
            s_mm,
            t_ms,
            folder / "area_map_outer.png",
            ridge_t_ms=arrays["ridge_t_ms"],
            crossings_75_ms=arrays["crossing_75_outer_ms"],
            sigma_ms=arrays["gaussian_sigma_outer_ms"],
            title=f"{name}: outer cross-sectional area",
        )
    ]
    walls = [w for w in ("outer", "inner", "lumen") if f"max_area_{w}_mm2" in arrays]
    written.append(
        attempt(
            failed,
            max_area_profile,
            s_mm,
            {w: arrays[f"max_area_{w}_mm2"] for w in walls},
            folder / "max_area_profile.png",
            title=name,
        )
    )
    shares = {}
    for w in walls:
        shares[f"{w}, >= 75 % of max"] = arrays[f"expanded_fraction_75_{w}"]
        shares[f"{w}, within one sigma"] = arrays[f"expanded_fraction_sigma_{w}"]
    written.append(
        attempt(failed, time_expanded, s_mm, shares, folder / "time_expanded.png", title=name)
    )
    rates = (summary["max_expansion_rate_mm2_ms"], summary["max_contraction_rate_mm2_ms"])
    written.append(
        attempt(
            failed,
            derivative_image,
            gradient_hsv(area),
            s_mm,
            t_ms,
            folder / "area_derivative_outer.png",
            rates=rates,
            title=f"{name}: derivative of the outer area map",
        )
    )
    written.append(
        attempt(
            failed,
            ridge_plot,
            s_mm,
            arrays["ridge_t_ms"],
            folder / "ridge_speed.png",
            knee=summary["wave_two_segment"],
            speed=arrays["local_speed_mm_s"],
            ridge_sd_ms=arrays.get("ridge_t_noise_sd_ms"),
            speed_sd=arrays.get("local_speed_noise_sd_mm_s"),
            bridged=arrays.get("ridge_bridged"),
            title=name,
        )
    )
    return [path for path in written if path is not None]


@house_style
def field_pair(
    field: np.ndarray,
    area_mm2: np.ndarray,
    path: Path,
    *,
    label: str,
    title: str = "",
    uncertain: np.ndarray | None = None,
    uncertain_note: str = "",
    against_t0: bool = False,
) -> Path:
    """Two (u, v) frames of a field ``(n_u, n_v, n_t)``, at maximum contraction (t = 0)
    and at the frame of largest total area ``area_mm2 (n_v, n_t)`` (the paper's
    Figs. 5, 6 and 13): a diverging colour map centred on 0 for a signed field,
    sequential for a one-signed one, one shared bar labelled ``label`` (quantity
    and unit); u across from the seam, v up from the inlet. ``against_t0``: a field
    measured against t = 0 (strain), 0 there by definition: half-way to maximum
    expansion instead of an empty t = 0. ``uncertain (n_u, n_v, n_t)``
    bool: nodes faded towards grey, as the videos fade them
    (:func:`~oftimg.output.video.uncertain_nodes`), ``uncertain_note`` saying why."""
    from .style import UNCERTAIN_GREY, colour_scale

    t_exp = int(np.argmax(np.nansum(area_mm2, axis=0)))
    scale = colour_scale(field)
    signed = scale["cmap"] == DIVERGING
    first = (
        (t_exp // 2, "half-way to maximum expansion") if against_t0 else (0, "maximum contraction")
    )
    fig, axes = new_figure(PAGE_MM, 70, ncols=2, sharey=True)
    for ax, t, when in zip(axes, (first[0], t_exp), (first[1], "maximum expansion")):
        image = ax.imshow(
            field[:, :, t].T,
            origin="lower",
            aspect="auto",
            extent=[0, 1, 0, 1],
            interpolation="nearest",
            **scale,
        )
        if uncertain is not None:  # two thirds of the way to grey, as in the videos
            grey = np.zeros((*field.shape[1::-1], 4))
            grey[..., :3] = UNCERTAIN_GREY / 255
            grey[..., 3] = np.where(uncertain[:, :, t].T, 2 / 3, 0.0)
            ax.imshow(
                grey, origin="lower", aspect="auto", extent=[0, 1, 0, 1], interpolation="nearest"
            )
        ax.set_xlabel("u, around the tube from the seam")
        ax.set_title(f"{when} (frame {t})")
    axes[0].set_ylabel("v, along the tube (inlet 0)")
    colour_bar(fig, image, list(axes), label, signed=signed)
    if uncertain is not None and uncertain_note:
        title = f"{title} ({uncertain_note})" if title else uncertain_note
    fig.suptitle(wrapped(plain_text(title), PAGE_MM, 9))
    return save(fig, path)


PATHLINE_EVERY = (10, 7)  # the nodes (around, along) whose pathlines the figure draws


@house_style
def pullback_figure(
    pullback: np.ndarray,
    pathlines: np.ndarray | None,
    t_ms: np.ndarray,
    path: Path,
    *,
    title: str = "",
    support: np.ndarray | None = None,
    fallback: np.ndarray | None = None,
) -> Path:
    """The myocardium's intensity ``(u_fine, v_fine, n_t)`` at t = 0 and at the frame
    where the tracked nodes lie farthest from where they started, each on its own
    grid (grey, 1st-99th percentile); with the tracking's ``pathlines (n_u, n_v, n_t,
    2)`` (grid steps), every :data:`PATHLINE_EVERY` node's path through the cycle drawn
    on the first, its place in that frame marked on the second: where the tissue went
    in the grid's (u, v). With texture tracking's ``support`` and ``fallback`` ``(n_u,
    n_v, n_t)``, a third panel: each node's support over the cycle (median) and the
    nodes that followed the shape alone in at least a quarter of the frames outlined:
    where to trust the grid."""
    lo, hi = np.nanpercentile(pullback, [1, 99])
    n_u, n_v = pathlines.shape[:2] if pathlines is not None else (1, 2)
    if pathlines is not None:
        moved = np.linalg.norm(pathlines - pathlines[:, :, :1], axis=-1)
        t_far = int(np.argmax(np.median(moved, axis=(0, 1))))
    else:
        t_far = pullback.shape[2] // 2
    confidence = support is not None and fallback is not None
    fig, axes = new_figure(PAGE_MM, 80, ncols=3 if confidence else 2, sharey=True)
    if confidence:
        axes, trust_ax = axes[:2], axes[2]
    notes = ("paths over the cycle", "the same nodes") if pathlines is not None else ("", "")
    for ax, t, note in zip(axes, (0, t_far), notes):
        image = ax.imshow(
            pullback[:, :, t].T,
            origin="lower",
            aspect="auto",
            cmap="gray",
            extent=[0, 1, 0, 1],
            vmin=lo,
            vmax=hi,
            interpolation="nearest",
        )
        if not confidence or ax is axes[1]:
            ax.set_xlabel("u, around the tube from the seam")
        ax.set_title(f"t = {t_ms[t]:.0f} ms" + (f": {note}" if note else ""))
    axes[0].set_ylabel("v, along the tube (inlet 0)")
    if pathlines is not None:
        every_u, every_v = PATHLINE_EVERY
        picked = pathlines[::every_u, ::every_v].reshape(-1, pathlines.shape[2], 2)
        u, v = np.mod(picked[..., 0] / n_u, 1.0), picked[..., 1] / (n_v - 1)
        for path_u, path_v in zip(u, v):
            jumps = np.flatnonzero(np.abs(np.diff(path_u)) > 0.5) + 1  # across the seam
            for pu, pv in zip(np.split(path_u, jumps), np.split(path_v, jumps)):
                axes[0].plot(pu, pv, color=LINE_COLOURS[1], lw=0.6)
        axes[0].plot(u[:, 0], v[:, 0], ".", color=LINE_COLOURS[1], ms=3)
        axes[1].plot(u[:, t_far], v[:, t_far], ".", color=LINE_COLOURS[1], ms=3)
    for ax in axes:  # tissue beyond the ends has left the imaged part
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
    colour_bar(fig, image, list(axes), "intensity, mean across the wall")
    if confidence:
        with warnings.catch_warnings():  # nodes out of view in every frame
            warnings.simplefilter("ignore", RuntimeWarning)
            typical = np.nanmedian(support, axis=2)
        viridis = plt.get_cmap("viridis").copy()
        viridis.set_bad("0.8")  # grey: the tissue left the grid
        trust = trust_ax.imshow(
            typical.T,
            origin="lower",
            aspect="auto",
            cmap=viridis,
            vmin=0,
            vmax=1,
            extent=[0, 1, 0, 1],
            interpolation="nearest",
        )
        shape_led = fallback.mean(axis=2) >= 0.25
        if shape_led.any() and not shape_led.all():
            u = (np.arange(shape_led.shape[0]) + 0.5) / shape_led.shape[0]
            v = np.linspace(0, 1, shape_led.shape[1])
            trust_ax.contour(
                u, v, shape_led.T.astype(float), levels=[0.5], colors="white", linewidths=0.8
            )
        trust_ax.set_title("support; outlined: shape alone")
        colour_bar(fig, trust, [trust_ax], "texture's correlation with the beat's template")
        title = (
            f"{title} (texture's support: median over the cycle; shape alone at "
            f"{100 * fallback.mean():.0f} % of nodes and frames)"
        )
    fig.suptitle(wrapped(plain_text(title), PAGE_MM, 9))
    return save(fig, path)


# ------------------------------------------------------------------ cohort figures
GROUP_COLOURS = LINE_COLOURS
NAMED_CURVES_MAX = 8  # a group with more embryos is drawn as thin lines with mean and SD


def _group_curves(
    ax,
    curves: list[tuple],
    colour: str,
    x: np.ndarray,
    *,
    period: float | None = None,
    label: str = "",
) -> None:
    """One group's curves ``[(name, x_k, y_k), ...]`` on ``ax``: each in its own colour
    and named in the legend when there are few; else thin lines in the group's
    colour, the mean on the common ``x`` in bold and a ± 1 SD band
    (:func:`oftimg.output.report.mean_curve`)."""
    from .report import mean_curve

    if len(curves) <= NAMED_CURVES_MAX:
        for name, xk, yk in curves:
            ax.plot(xk, yk, lw=1.4, label=plain_text(f"{label} {name}".strip()))
        return
    for _, xk, yk in curves:
        ax.plot(xk, yk, lw=0.6, color=colour, alpha=0.25)
    mean, sd, _ = mean_curve([(xk, yk) for _, xk, yk in curves], x, period=period)
    ax.fill_between(x, mean - sd, mean + sd, color=colour, alpha=0.2, lw=0)
    ax.plot(
        x,
        mean,
        color=colour,
        lw=2.2,
        label=plain_text(f"{label} mean ± SD (n = {len(curves)})".strip()),
    )


def _common_position(curves: list[tuple]) -> np.ndarray:
    """Positions (mm) for a group's mean: 0 to its longest tube, 100 steps."""
    return np.linspace(0.0, max(float(np.nanmax(xk)) for _, xk, _ in curves), 100)


# the cohort's profiles along the tube: (key of _group_profiles, y label, file)
GROUP_PROFILES = [
    ("max_area_outer_mm2", "maximum outer area (mm$^2$)", "group_max_area.png"),
    ("ridge_t_ms", "time of maximum area (ms)", "group_ridge_time.png"),
    ("time_expanded_percent", "time expanded, one sigma (% of cycle)", "group_time_expanded.png"),
    (
        "wall_thickness",
        units.label("wall thickness, mean over the cycle", "thickness"),
        "group_wall_thickness.png",
    ),
    ("wall_thickening_percent", "wall thickening over the beat (%)", "group_wall_thickening.png"),
    (
        "jelly_thickness",
        units.label("cardiac jelly thickness, mean over the cycle", "thickness"),
        "group_jelly_thickness.png",
    ),
    (
        "jelly_thickening_percent",
        "cardiac jelly thickening over the beat (%)",
        "group_jelly_thickening.png",
    ),
]


def _group_profiles(path: Path) -> dict:
    """One embryo's curves for the cohort figures from its ``arrays.npz``: ``s_mm``,
    ``t_ms``, ``volume_outer_mm3`` and each :data:`GROUP_PROFILES` key along the
    tube (the wall's and the jelly's only with the walls they lie between). Read and
    closed: hundreds of open files would hit the OS limit."""
    from ..analysis.fields import thickness_by_row

    with np.load(path) as arrays:
        out = {
            key: arrays[key]
            for key in ("s_mm", "t_ms", "volume_outer_mm3", "max_area_outer_mm2", "ridge_t_ms")
        }
        out["time_expanded_percent"] = 100 * arrays["expanded_fraction_sigma_outer"]
        for layer in ("wall", "jelly"):
            if f"{layer}_thickness_mm" in arrays.files:
                mean, thickening = thickness_by_row(arrays[f"{layer}_thickness_mm"])
                out[f"{layer}_thickness"] = units.THICKNESS.scale * mean
                out[f"{layer}_thickening_percent"] = units.THICKENING.scale * thickening
    return out


# the cohort maps drawn per group: key of cohort_maps.npz, title, file, range of the means,
# the colour bar's quantity and unit, and the factor from the map's unit to that one
GROUP_MAPS = [
    (
        "area_outer_normalized",
        "outer area, each row over its maximum",
        "group_area_maps.png",
        (0.0, 1.0),
        "area / row maximum (0-1)",
        1.0,
    ),
    (
        "wall_thickness_mm",
        "myocardial wall thickness, mean around the tube",
        "group_wall_thickness_maps.png",
        None,
        units.label("wall thickness", "thickness"),
        units.THICKNESS.scale,
    ),
    (
        "jelly_thickness_mm",
        "cardiac jelly thickness, mean around the tube",
        "group_jelly_thickness_maps.png",
        None,
        units.label("jelly thickness", "thickness"),
        units.THICKNESS.scale,
    ),
    (
        "strain_energy_outer",
        "outer wall's strain energy against t = 0, mean around the tube",
        "group_strain_energy_maps.png",
        None,
        "strain energy (dimensionless)",
        1.0,
    ),
]


@house_style
def group_maps_figure(
    maps: dict,
    path: Path,
    *,
    key: str = "area_outer_normalized",
    title: str = "outer area, each row over its maximum",
    value_range=None,
    alpha: float = 0.05,
    unit_label: str = "area / row maximum (0-1)",
    times: float = 1.0,
) -> Path:
    """Each group's mean of map ``key`` on the cohort's common grid (``maps``:
    :func:`oftimg.output.export.cohort_maps`; ``value_range`` its colour range, default the
    means' own), and each other group's difference from the first (normals first),
    with the clusters (solid) and the single pixels (dashed) where it is significant
    over the whole map (``*_p_cluster``, ``*_p_fwer`` below ``alpha``) outlined;
    ``unit_label`` names the colour bars' quantity and unit, ``times`` takes the map
    into it (:mod:`oftimg.output.units`: as the quantity is given everywhere else).
    Embryos without the map (all NaN) are left out."""
    from ..analysis.group_maps import group_mean_maps

    present = ~np.all(np.isnan(maps[key]), axis=(1, 2))
    order = groups_in_order(maps["groups"][present])
    means = group_mean_maps(times * maps[key][present], maps["groups"][present])
    lo, hi = value_range or (
        np.nanmin([means[g][0] for g in order]),
        np.nanmax([means[g][0] for g in order]),
    )
    extent = [0, 1, 0, 1]
    panels = [
        (f"{g} mean (n = {means[g][2]})", means[g][0], SEQUENTIAL, lo, hi, None) for g in order
    ]
    differences = times * maps[f"{key}_difference"]
    lim = float(np.nanmax(np.abs(differences))) if np.isfinite(differences).any() else 1.0
    for name, difference, p_fwer, p_cluster in zip(
        maps["comparisons"], differences, maps[f"{key}_p_fwer"], maps[f"{key}_p_cluster"]
    ):
        if np.all(np.isnan(difference)):
            continue  # a group without this map
        panels.append(
            (
                f"{name}\n{_significance_note(p_cluster, p_fwer, alpha)}",
                difference,
                DIVERGING,
                -lim,
                lim,
                (p_cluster, p_fwer),
            )
        )
    fig, axes = new_figure(PAGE_MM, 72, ncols=len(panels), sharey=True, squeeze=False)
    for ax, (panel_title, image, cmap, vmin, vmax, p) in zip(axes[0], panels):
        im = ax.imshow(
            image,
            origin="lower",
            aspect="auto",
            cmap=cmap,
            vmin=vmin,
            vmax=vmax,
            extent=extent,
            interpolation="nearest",
        )
        for p_map, style in zip(p or (), ("solid", "dashed")):
            if np.nanmin(p_map, initial=np.inf) < alpha:
                rows, cols = p_map.shape
                ax.contour(
                    (np.arange(cols) + 0.5) / cols,
                    (np.arange(rows) + 0.5) / rows,
                    np.nan_to_num(p_map, nan=1.0) < alpha,
                    levels=[0.5],
                    colors="k",
                    linewidths=1.0,
                    linestyles=style,
                )
        colour_bar(
            fig,
            im,
            ax,
            unit_label if p is None else f"difference, {unit_label}",
            signed=p is not None,
        )
        ax.set_title(plain_text(panel_title), fontsize=7)
        ax.set_xlabel("cycle since minimum volume")
    axes[0][0].set_ylabel("position, fraction of the tube")
    fig.suptitle(title)
    return save(fig, path)


def _significance_note(p_cluster: np.ndarray, p_fwer: np.ndarray, alpha: float) -> str:
    """What a difference panel outlines: clusters (solid) and single pixels (dashed)
    significant over the whole map."""
    if np.all(np.isnan(p_cluster)):
        return "too few embryos to test"
    least = float(np.nanmin(p_cluster))
    note = (
        f"clusters p < {alpha:g} outlined"
        if least < alpha
        else f"no cluster p < {alpha:g} (least {least:.2g})"
    )
    if np.nanmin(p_fwer) < alpha:
        note += f", pixels p < {alpha:g} dashed"
    return note


@house_style
def group_figures(
    results: Path, summaries: list[dict], folder: Path, *, maps: dict | None = None
) -> list[Path]:
    """Groups side by side (normals left, banded right, as the paper): maximum area,
    ridge time, % time expanded, and the myocardial wall's thickness and thickening
    vs position, and volume over the aligned cycle (groups overlaid). Up to
    :data:`NAMED_CURVES_MAX` embryos of a group are named lines; a larger group shows
    its mean ± SD over thin lines. With ``maps`` (:func:`oftimg.output.export.cohort_maps`),
    the groups' mean maps too (:data:`GROUP_MAPS`, :func:`group_maps_figure`).
    Reads each dataset's ``arrays.npz`` from ``results``."""
    groups = groups_in_order([s["group"] for s in summaries])
    colours = dict(zip(groups, GROUP_COLOURS * len(groups)))
    members = {g: [s for s in summaries if s["group"] == g] for g in groups}
    data = {s["name"]: _group_profiles(Path(results) / s["name"] / "arrays.npz") for s in summaries}
    written = []
    for key, ylabel, fname in GROUP_PROFILES:
        if not any(key in d for d in data.values()):  # no embryo with an inner wall
            continue
        fig, axes = new_figure(PAGE_MM, 70, ncols=len(groups), sharey=True, squeeze=False)
        for ax, g in zip(axes[0], groups):
            curves = [
                (s["name"], data[s["name"]]["s_mm"], data[s["name"]][key])
                for s in members[g]
                if key in data[s["name"]]
            ]
            if curves:
                _group_curves(ax, curves, colours[g], _common_position(curves))
                ax.legend(fontsize=7)
            ax.set_title(plain_text(g), fontsize=9)
            ax.set_xlabel("position along the tube s (mm)")
            ax.grid(alpha=0.3)
        axes[0][0].set_ylabel(wrapped(ylabel, 50))  # the panel's height, not more
        written.append(save(fig, folder / fname))
    fig, ax = new_figure(COLUMN_MM, 65)
    cycle = np.linspace(0.0, 1.0, 101)
    for g in groups:
        curves = []
        for s in members[g]:
            v = data[s["name"]]["volume_outer_mm3"]
            curves.append((s["name"], data[s["name"]]["t_ms"] / s["period_ms"], v / v.mean()))
        if len(curves) <= NAMED_CURVES_MAX:  # few: every embryo, coloured by its group
            for k, (_, xk, yk) in enumerate(curves):
                ax.plot(xk, yk, color=colours[g], lw=1.2, label=plain_text(g) if k == 0 else None)
        else:
            _group_curves(ax, curves, colours[g], cycle, period=1.0, label=g)
    ax.legend(fontsize=8)
    ax.set_xlabel("fraction of the cycle since minimum volume")
    ax.set_ylabel("outer volume / its mean")
    ax.grid(alpha=0.3)
    written.append(save(fig, folder / "group_volume.png"))
    for key, title, fname, value_range, unit_label, times in GROUP_MAPS if maps is not None else []:
        if np.isfinite(maps[key]).any():
            written.append(
                group_maps_figure(
                    maps,
                    folder / fname,
                    key=key,
                    title=title,
                    value_range=value_range,
                    unit_label=unit_label,
                    times=times,
                )
            )
    for phase in ("expansion", "contraction"):
        p = pca_groups_figure(results, summaries, folder / f"group_pca_{phase}.png", phase=phase)
        if p is not None:
            written.append(p)
    return written


# ------------------------------------------------------------------ shape PCA
def _mode_arrows(ax, mean, disp, title):
    closed = np.vstack([mean, mean[:1]])
    ax.plot(closed[:, 0], closed[:, 1], "k-", lw=1)
    step = max(1, len(mean) // 40)
    size = np.ptp(mean, axis=0).max()
    longest = np.linalg.norm(disp, axis=1).max()
    if longest > 0:  # a still tube's sections have no modes to draw
        ax.quiver(
            mean[::step, 0],
            mean[::step, 1],
            disp[::step, 0],
            disp[::step, 1],
            color=LINE_COLOURS[0],
            angles="xy",
            scale_units="xy",
            scale=longest / (0.15 * size),
            width=0.012,
        )
    pad = 0.18 * size  # the longest arrow is 0.15 size: inside the axes
    ax.set_xlim(mean[:, 0].min() - pad, mean[:, 0].max() + pad)
    ax.set_ylim(mean[:, 1].min() - pad, mean[:, 1].max() + pad)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(plain_text(title), fontsize=7)


@house_style
def pca_groups_figure(
    results: Path, summaries: list[dict], path: Path, *, phase: str = "expansion"
) -> Path | None:
    """Paper Fig. 14: modes 1 and 2 at the three rows, one embryo per group side by side."""
    firsts = {}
    for s in summaries:
        if (Path(results) / s["name"] / "pca.npz").exists():
            firsts.setdefault(s["group"], s)
    if len(firsts) < 2:
        return None
    groups = groups_in_order(list(firsts))
    n_rows = len(firsts[groups[0]]["pca"]["rows"])
    n_cols = n_rows * len(groups)
    # square panels (equal aspect) under two-line titles: the height they fill, no more
    fig, axes = new_figure(
        PAGE_MM, 2 * (PAGE_MM / n_cols + 12) + 12, nrows=2, ncols=n_cols, squeeze=False
    )
    for gi, g in enumerate(groups):
        summ = firsts[g]
        pca = np.load(Path(results) / summ["name"] / "pca.npz")
        for k, row in enumerate(summ["pca"]["rows"]):
            key = f"pca_row{k}_{phase}"
            for m in (0, 1):
                _mode_arrows(
                    axes[m][gi * n_rows + k],
                    pca[f"{key}_mean_mm"],
                    pca[f"{key}_displacement_mm"][m],
                    f"{g} ({summ['name']})\nv {row['v']:.1f}, mode {m + 1}: "
                    f"{100 * pca[f'{key}_explained'][m]:.0f} %",
                )
    fig.suptitle(
        wrapped(
            f"cross-section shape modes, {phase} phase (arrows: each mode's "
            "shape change, the longest 15 % of the contour's size)",
            PAGE_MM,
            9,
        )
    )
    return save(fig, path)


@house_style
def pca_figure(pca: dict, pca_summary: dict, path: Path, *, title: str = "", modes=(0, 1)) -> Path:
    """Arrows of modes 1 and 2 on each row's mean contour, expansion and contraction,
    and the displacement magnitude along the contour (paper Figs. 7 and 14)."""
    rows = pca_summary["rows"]
    phases = ("expansion", "contraction")
    fig, axes = new_figure(
        PAGE_MM, 40 * (len(modes) + 1), nrows=len(modes) + 1, ncols=len(rows) * 2, squeeze=False
    )
    for k, row in enumerate(rows):
        for p, phase in enumerate(phases):
            col = 2 * k + p
            key = f"pca_row{k}_{phase}"
            mean = pca[f"{key}_mean_mm"]
            disp = pca[f"{key}_displacement_mm"]
            expl = pca[f"{key}_explained"]
            for m_i, m in enumerate(modes):
                # longest arrow: 15 % of the contour's size (each mode scaled on its own)
                _mode_arrows(
                    axes[m_i][col],
                    mean,
                    disp[m],
                    f"v {row['v']:.1f}, {phase}\nmode {m + 1}: {100 * expl[m]:.0f} %",
                )
            ax = axes[-1][col]
            for m in modes:
                ax.plot(
                    np.linalg.norm(disp[m], axis=1) * units.DISPLACEMENT.scale,
                    label=f"mode {m + 1}" if col == 0 else None,
                )
            ax.set_xlabel("point")
            if col:
                ax.sharey(axes[-1][0])
                ax.tick_params(labelleft=False)
    axes[-1][0].set_ylabel(units.label("|displacement|", "displacement"))
    fig.legend(loc="outside lower center", ncol=len(modes), fontsize=7)
    fig.suptitle(
        wrapped(
            plain_text(title) + " (arrows: each mode's shape change, the "
            "longest 15 % of the contour's size; points counted around the "
            "contour from the seam)",
            PAGE_MM,
            9,
        )
    )
    return save(fig, path)
