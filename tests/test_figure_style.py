"""Every figure type in the house style (issue 52): each axes with labelled x and y
axes, each colour bar labelled with a unit, no text over other text or outside the
figure, fonts of 7-9 pt at a journal's column or page width, and a vector PDF and SVG
beside the PNG with the text kept as text."""

import re

import matplotlib
import numpy as np
import pytest

from oftimg.output import figures, style
from test_figures import cohort_results, figure_cases, fixed_map

pytestmark = pytest.mark.long  # make test-long (accuracy, rendering, whole runs)

UNIT = re.compile(r"\(([^()]+)\)")  # "quantity (unit)"


def _axes_drawn(ax) -> bool:
    """Whether ``ax`` draws its axes (a 3-D axes draws its own, with ``axison`` off)."""
    return ax.axison or getattr(ax, "_axis3don", False)


def _undrawn_tick_labels(fig) -> set:
    """Tick labels matplotlib keeps but does not draw (their ticks lie outside the view),
    and a 3-D axes' tick labels, whose boxes after drawing are not where they were
    drawn (each is moved and drawn in turn): those are looked at in the PNG instead."""
    undrawn = set()
    for ax in fig.axes:
        if ax.name == "3d":
            undrawn |= {
                id(lab)
                for axis in ax._axis_map.values()
                for tick in axis.get_major_ticks() + axis.get_minor_ticks()
                for lab in (tick.label1, tick.label2)
            }
            continue
        for axis in ax._axis_map.values():
            drawn = {
                id(lab)
                for tick in axis._update_ticks()
                for lab in (tick.label1, tick.label2)
                if _axes_drawn(ax)
            }
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                undrawn |= {id(lab) for lab in (tick.label1, tick.label2) if id(lab) not in drawn}
    return undrawn


def _texts(fig):
    """Every text ``fig`` draws, with its box in pixels."""
    renderer = fig.canvas.get_renderer()
    undrawn = _undrawn_tick_labels(fig)
    found = []
    for text in fig.findobj(matplotlib.text.Text):
        if not text.get_visible() or not text.get_text().strip() or id(text) in undrawn:
            continue
        if text.axes is not None and not text.axes.get_visible():
            continue
        found.append((text, text.get_window_extent(renderer)))
    return found


ASCII_UNIT = re.compile(r"\bum\b|\+-|\+/-|\^\d|\bR\^")  # µm, ±, mm², R² as typed
UNIT_ONE = re.compile(r"\(1\)\s*$")  # a dimensionless unit written as SI's "1"
RAW_EXPONENT = re.compile(r"\d[eE][+\-\u2212]?\d")  # 5.68e-04, 1e−5


def _drawn_colours(handle) -> list:
    """The RGB colours a legend handle draws with (line, marker face and edge, patch)."""
    from matplotlib.colors import to_rgb

    colours = []
    if isinstance(handle, matplotlib.lines.Line2D):
        if handle.get_linestyle() not in ("None", "none", "", " ") and handle.get_linewidth():
            colours.append(handle.get_color())
        if handle.get_marker() not in (None, "None", "none", "", " "):
            colours.append(handle.get_markerfacecolor())
            if handle.get_markeredgewidth():
                colours.append(handle.get_markeredgecolor())
    elif isinstance(handle, matplotlib.patches.Patch):
        colours.append(handle.get_facecolor())
        if handle.get_linewidth():
            colours.append(handle.get_edgecolor())
    elif isinstance(handle, matplotlib.collections.Collection):
        colours += list(handle.get_facecolors()) + list(handle.get_edgecolors())
    return [
        to_rgb(c)
        for c in colours
        if not (isinstance(c, str) and c.lower() == "none")
        and not (len(np.atleast_1d(c)) == 4 and np.atleast_1d(c)[3] == 0)
    ]


def _invisible_legend_entries(fig) -> list[str]:
    """Legend entries whose handle draws only in the legend's own background colour."""
    from matplotlib.colors import to_rgb

    problems = []
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
    for legend in legends:
        frame = legend.get_frame()
        background = to_rgb(
            frame.get_facecolor()
            if legend.get_frame_on() and frame.get_alpha() != 0
            else fig.get_facecolor()
        )
        for handle, text in zip(legend.legend_handles, legend.get_texts()):
            colours = _drawn_colours(handle)
            if colours and all(np.abs(np.subtract(c, background)).max() < 0.1 for c in colours):
                problems.append(
                    f"legend entry {text.get_text()!r} is drawn in its background colour"
                )
    return problems


def _hidden_legend_entries(fig) -> list[str]:
    """Legend entries whose own marks change no pixel when they are hidden: drawn
    under others (a dashed line beneath a solid one), so the legend names what a
    reader cannot find. Entries without data of their own (legend proxies) are
    skipped."""
    labelled = [
        artist
        for ax in fig.axes
        for artist in ax.get_lines() + ax.collections
        if not artist.get_label().startswith("_") and artist.get_visible() and _has_data(artist)
    ]
    if not labelled:
        return []
    fig.canvas.draw()  # constrained layout settles on its second draw
    before = np.asarray(fig.canvas.buffer_rgba()).astype(int)
    problems = []
    for artist in labelled:
        artist.set_visible(False)
        fig.canvas.draw()
        changed = np.abs(np.asarray(fig.canvas.buffer_rgba()).astype(int) - before).max(axis=-1)
        if (changed > 60).sum() < 20:  # antialiased edges aside: nothing shows
            problems.append(f"legend entry {artist.get_label()!r} is hidden under other marks")
        artist.set_visible(True)
    fig.canvas.draw()
    return problems


def _has_data(artist) -> bool:
    if hasattr(artist, "get_xdata"):
        return len(artist.get_xdata()) > 0
    return len(artist.get_offsets()) > 0 or len(artist.get_paths()) > 0


def _arrows_outside_panels(fig) -> list[str]:
    """Quiver arrows reaching past their panel's frame (cut there by the clipping)."""
    from matplotlib.quiver import Quiver

    problems = []
    for ax in fig.axes:
        box = ax.bbox.padded(1)
        for quiver in (c for c in ax.collections if isinstance(c, Quiver)):
            shape = quiver.get_transform()
            offsets = quiver.get_offset_transform().transform(quiver.get_offsets())
            out = sum(
                not np.all(
                    (box.x0 <= xy[:, 0])
                    & (xy[:, 0] <= box.x1)
                    & (box.y0 <= xy[:, 1])
                    & (xy[:, 1] <= box.y1)
                )
                for xy in (
                    shape.transform(path.vertices) + offset
                    for path, offset in zip(quiver.get_paths(), offsets)
                )
            )
            if out:
                problems.append(f"axes {ax.get_title()!r}: {out} arrows leave the panel")
    return problems


def _empty_bands(fig, share: float = 0.2) -> list[str]:
    """A band of the canvas, across its whole width or height, wider than ``share`` of
    it, with nothing drawn in it."""
    pixels = np.asarray(fig.canvas.buffer_rgba())[..., :3]
    ink = (pixels < 245).any(axis=-1)
    problems = []
    for axis, name in ((1, "rows"), (0, "columns")):
        line = ink.any(axis=axis)
        longest = run = 0
        for inked in line:
            run = 0 if inked else run + 1
            longest = max(longest, run)
        if longest > share * len(line):
            problems.append(
                f"{100 * longest / len(line):.0f} % of the canvas's {name} empty in one band"
            )
    return problems


def layout_problems(fig) -> list[str]:
    """What a reader would call a layout fault: text overlapping text, text leaving the
    figure, an axis without its label, a colour bar without a unit or with a label
    longer than the bar, type outside 7-9 pt, units typed in ASCII (um, mm^2, +-), a
    legend entry drawn in its background's colour or hidden under other marks, a band
    of empty canvas, a unit given as "(1)", arrows leaving their panel."""
    fig.canvas.draw()
    problems = (
        _invisible_legend_entries(fig)
        + _empty_bands(fig)
        + _hidden_legend_entries(fig)
        + _arrows_outside_panels(fig)
    )
    texts = _texts(fig)
    for text, _ in texts:
        plain = re.sub(r"\$[^$]*\$", "", text.get_text())  # mathtext ($^2$) is typeset
        if ASCII_UNIT.search(plain):
            problems.append(f"text {text.get_text()!r} types a unit or sign in ASCII")
        if UNIT_ONE.search(plain.replace("\n", " ")):
            problems.append(f"text {text.get_text()!r} gives its unit as (1)")
        if RAW_EXPONENT.search(plain):
            problems.append(f"text {text.get_text()!r} shows a raw exponent")
    width, height = fig.bbox.width, fig.bbox.height
    for text, box in texts:
        if box.x0 < -1 or box.y0 < -1 or box.x1 > width + 1 or box.y1 > height + 1:
            problems.append(f"text {text.get_text()!r} leaves the figure")
        if not 7 <= text.get_fontsize() <= 9:
            problems.append(f"text {text.get_text()!r} at {text.get_fontsize()} pt")
    for i, (a, box_a) in enumerate(texts):
        for b, box_b in texts[i + 1 :]:
            shrunk = box_a.padded(-1)  # touching edges are not an overlap
            if shrunk.width > 0 and shrunk.height > 0 and shrunk.overlaps(box_b.padded(-1)):
                problems.append(f"{a.get_text()!r} overlaps {b.get_text()!r}")
    for ax in fig.axes:
        bar = getattr(ax, "_colorbar", None)
        if bar is not None:
            label = ax.get_ylabel() or ax.get_xlabel()
            if not UNIT.search(label.replace("\n", " ")):
                problems.append(f"colour bar {label!r} has no unit")
            along = ax.yaxis.label if ax.get_ylabel() else ax.xaxis.label
            extent = along.get_window_extent(fig.canvas.get_renderer())
            long_side = extent.height if ax.get_ylabel() else extent.width
            if long_side > 1.05 * (ax.bbox.height if ax.get_ylabel() else ax.bbox.width):
                problems.append(f"colour bar label {label!r} is longer than its bar")
            continue
        if not _axes_drawn(ax):
            continue
        for axis, shared, get in (
            ("x", ax.get_shared_x_axes(), "get_xlabel"),
            ("y", ax.get_shared_y_axes(), "get_ylabel"),
        ):
            ticks = getattr(ax, f"get_{axis}ticklabels")()
            if not any(t.get_text() for t in ticks) and not getattr(ax, get)():
                continue  # no ticks shown: a picture, not an axis
            if not any(getattr(sib, get)() for sib in shared.get_siblings(ax)):
                problems.append(f"axes {ax.get_title()!r}: no {axis} label")
    return problems


def _checked_save(seen):
    real_save = style.save

    def save(fig, path):
        seen.append((path, layout_problems(fig), fig.get_size_inches() / style.MM))
        return real_save(fig, path)

    return save


def _group_maps():
    rng = np.random.default_rng(0)
    groups = np.array(["normal"] * 3 + ["banded"] * 3)
    area = rng.random((6, 20, 30))
    p = np.full((1, 20, 30), 0.5)
    p[0, 5:9, 10:15] = 0.01
    return {
        "groups": groups,
        "comparisons": np.array(["banded - normal"]),
        "area_outer_normalized": area,
        "area_outer_normalized_difference": area[3:].mean(0, keepdims=True)
        - area[:3].mean(0, keepdims=True),
        "area_outer_normalized_p_fwer": p,
        "area_outer_normalized_p_cluster": p,
    }


def _pca():
    from oftimg.image.pca import contour_pca

    u = np.linspace(0, 2 * np.pi, 40, endpoint=False)[:, None, None]
    v = np.linspace(0, 1, 12)[None, :, None]
    t = np.arange(16)[None, None, :]
    r = (
        0.2
        * (1 + 0.2 * np.sin(np.pi * t / 15))
        * (1 + 0.1 * np.cos(2 * u) * np.sin(np.pi * t / 15))
    )
    grid = np.stack(np.broadcast_arrays(r * np.cos(u), r * np.sin(u), v + 0 * u * t), axis=-1)
    return contour_pca(grid, 8), grid


@pytest.fixture(scope="module")
def drawn(tmp_path_factory) -> tuple:
    """Every figure type drawn once (with the SVG too): its folder, and (path,
    problems, size in mm) of each."""
    tmp_path = tmp_path_factory.mktemp("figures")
    seen = []
    with pytest.MonkeyPatch.context() as patch, style.vector_formats((".pdf", ".svg")):
        patch.setattr(figures, "save", _checked_save(seen))
        _draw_every_figure(tmp_path)
    return tmp_path, seen


def _draw_every_figure(tmp_path) -> None:
    for name, draw in figure_cases(tmp_path).items():
        draw(tmp_path / f"{name}.png")
    arrays, summary, _ = fixed_map()
    still = np.zeros(len(arrays["s_mm"]), bool)
    still[len(still) // 3 : len(still) // 3 + 4] = True  # a band that barely moves
    figures.ridge_plot(
        arrays["s_mm"],
        arrays["ridge_t_ms"],
        tmp_path / "ridge_bridged.png",
        knee=summary["wave_two_segment"],
        speed=arrays["local_speed_mm_s"],
        bridged=still,
        title="an embryo: a band bridged",
    )
    pca, grid = _pca()
    figures.pca_figure(
        pca["arrays"],
        pca["summary"],
        tmp_path / "shape_pca.png",
        title="an embryo: cross-section shape modes",
    )
    contours = {"outer": grid[:, :, 0]}
    figures.frame_with_contours(
        grid[:, :, 0], contours, tmp_path / "frame.png", title="an embryo: t = 0 (minimum volume)"
    )
    figures.group_maps_figure(_group_maps(), tmp_path / "group_area_maps.png")
    field = grid[..., 0] * 5  # signed: a diverging scale
    figures.field_pair(
        field,
        np.ones((12, 16)),
        tmp_path / "field_pair.png",
        label="radial curvature (1/mm)",
        title="an embryo: radial curvature",
    )
    for kind, turns in (("along", 0), ("helix", 2), ("band", 0)):  # both colour scales
        n_u, n_v = grid.shape[:2]
        u = np.arange(n_u)[:, None] / n_u
        v = np.arange(n_v)[None, :] / (n_v - 1)
        times = np.mod(60.0 * v + turns * 360.0 * u, 360.0)
        velocity = np.stack(
            np.broadcast_arrays(np.ones_like(times), turns * np.ones_like(times)), axis=-1
        )
        if kind == "band":  # rows too still to time: grey, said above
            velocity[:, n_v // 2 : n_v // 2 + 2] = np.nan
        figures.activation_figure(
            times,
            velocity,
            grid.mean(axis=2),
            360.0,
            tmp_path / f"activation_{kind}.png",
            title="an embryo: the wave's fronts on the outer wall",
        )
    (tmp_path / "cohort").mkdir()
    summaries = cohort_results(tmp_path / "cohort", {"normal": 3, "banded": 3})
    with_walls_and_shapes(tmp_path / "cohort", summaries, pca)
    figures.group_figures(tmp_path / "cohort", summaries, tmp_path)


def with_walls_and_shapes(folder, summaries, pca) -> None:
    """The cohort's embryos given wall and jelly thickness (u, v, t) and shape modes,
    so that every group figure is drawn (thickness curves, shape modes), and curves of
    their own (one embryo's line exactly over another's would hide it)."""
    rng = np.random.default_rng(1)
    for k, summary in enumerate(summaries):
        path = folder / summary["name"] / "arrays.npz"
        with np.load(path) as arrays:
            arrays = dict(arrays)
        arrays["ridge_t_ms"] = arrays["ridge_t_ms"] + 4.0 * k
        arrays["expanded_fraction_sigma_outer"] = arrays["expanded_fraction_sigma_outer"] + 0.02 * k
        arrays["volume_outer_mm3"] = arrays["volume_outer_mm3"] + 0.03 * k * np.cos(
            2 * np.pi * arrays["t_ms"] / summary["period_ms"]
        )
        shape = (16, len(arrays["s_mm"]), len(arrays["t_ms"]))
        arrays["wall_thickness_mm"] = 0.04 + 0.005 * rng.random(shape)
        arrays["jelly_thickness_mm"] = 0.03 + 0.01 * rng.random(shape)
        np.savez(path, **arrays)
        np.savez(folder / summary["name"] / "pca.npz", **pca["arrays"])
        summary["pca"] = pca["summary"]


def test_every_figure_is_laid_out_for_a_journal(drawn):
    _, seen = drawn
    assert len(seen) >= 14
    faults = {path.name: problems for path, problems, _ in seen if problems}
    assert faults == {}
    for path, _, (width_mm, _) in seen:  # a column or the page, at print size
        assert width_mm <= style.PAGE_MM + 0.5, path.name
        assert width_mm >= style.COLUMN_MM - 0.5, path.name


def test_each_figure_has_a_vector_pdf_and_svg_with_text_as_text(drawn):
    tmp_path, seen = drawn
    for path, _, _ in seen:
        pdf = path.with_suffix(".pdf").read_bytes()
        assert b"/FontFile2" in pdf, f"{path.name}: the PDF's text is not embedded as a font"
        svg = path.with_suffix(".svg").read_text()
        assert "<text" in svg, f"{path.name}: the SVG's text is drawn as paths"
    line_plot = (tmp_path / "volume_over_cycle.pdf").read_bytes()
    assert b"/Subtype /Image" not in line_plot  # lines drawn as lines


def test_the_layout_check_finds_the_faults_it_looks_for():
    """The check above fails a figure with overlapping titles, a label off the edge,
    a colour bar without a unit, and an axis without a label."""
    import matplotlib.pyplot as plt

    with matplotlib.rc_context(style.RC):
        fig, ax = style.new_figure(style.COLUMN_MM, 60)
        ax.set_xlabel("time (ms)")
        image = ax.imshow(np.zeros((3, 3)))
        fig.colorbar(image, ax=ax, label="area")
        fig.text(0.5, 0.5, "one", fontsize=8)
        fig.text(0.5, 0.5, "two", fontsize=8)
        fig.text(0.99, 0.5, "off the edge", fontsize=8)
        problems = "\n".join(layout_problems(fig))
        plt.close(fig)
    assert "'one' overlaps 'two'" in problems
    assert "'off the edge' leaves the figure" in problems
    assert "colour bar 'area' has no unit" in problems
    assert "no y label" in problems


def test_the_layout_check_finds_what_a_reader_cannot_see_or_read():
    """... and a legend marker white on white, a legend's line under another, an empty
    third of the canvas, a unit typed in ASCII or as (1), a colour-bar label longer
    than its bar, an arrow out of its panel."""
    import matplotlib.pyplot as plt

    with matplotlib.rc_context(style.RC):
        fig, ax = style.new_figure(style.COLUMN_MM, 90)
        fig.get_layout_engine().set(rect=(0, 0.4, 1, 0.6))  # the bottom 40 % left empty
        ax.plot([], [], "w*", label="one sigma")
        ax.set_xlabel("thickness (um)")
        ax.set_title("rate 5.68e-04 mm$^2$/ms")
        ax.set_ylabel("area (mm^2)")
        ax.text(0.5, 0.5, "strain energy (1)")
        ax.plot([0, 1], [0, 1], "b--", label="under the line")
        ax.plot([0, 1], [0, 1], "k-", lw=3, label="line")  # drawn over it
        ax.legend()
        image = ax.imshow(np.zeros((3, 3)))  # x from -0.5 to 2.5
        ax.quiver([2.2], [1.0], [1.0], [0], angles="xy", scale_units="xy", scale=1)
        fig.colorbar(
            image,
            ax=ax,
            shrink=0.3,
            label="a label much longer than the short colour bar beside it (1)",
        )
        problems = "\n".join(layout_problems(fig))
        plt.close(fig)
    assert "legend entry 'one sigma' is drawn in its background colour" in problems
    assert "legend entry 'line'" not in problems
    assert "rows empty in one band" in problems
    assert "'thickness (um)' types a unit or sign in ASCII" in problems
    assert "'area (mm^2)' types a unit or sign in ASCII" in problems
    assert "'strain energy (1)' gives its unit as (1)" in problems
    assert "legend entry 'under the line' is hidden under other marks" in problems
    assert "legend entry 'line' is hidden" not in problems
    assert "1 arrows leave the panel" in problems
    assert "is longer than its bar" in problems
    assert "'rate 5.68e-04 mm$^2$/ms' shows a raw exponent" in problems
