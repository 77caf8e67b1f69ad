"""Videos that orient the viewer (issue 52): axes, seam and ends, a labelled colour bar,
the time and the phase in a banner readable on any frame, a labelled reference frame
for strain, a beat in 3-5 s, and the side-by-side 3-D videos at least 1280 px wide."""

import imageio.v3 as iio
import numpy as np
import pytest

from oftimg.output import video
from oftimg.output.video import BANNER, FIELD_SCALE, MARGIN_LEFT, beat_fps, field_frames


def _field(n_u=80, n_v=50, n_t=30, level=0.0):
    u = np.linspace(0, 1, n_u, endpoint=False)[:, None, None]
    v = np.linspace(0, 1, n_v)[None, :, None]
    t = np.arange(n_t)[None, None, :]
    return level + np.sin(2 * np.pi * (2 * u + t / n_t)) * (1 + v)


def _ink(region: np.ndarray) -> float:
    """Share of a region's pixels that are not white (text, ticks, lines)."""
    return float((region.min(axis=-1) < 200).mean())


def test_the_overlay_labels_the_axes_around_the_field_and_leaves_the_field_alone():
    field, t_ms = _field(), np.arange(30) * 12.0
    bare = field_frames(field, t_ms, label="radial curvature (1/mm)", annotate=False)
    framed = field_frames(
        field,
        t_ms,
        label="radial curvature (1/mm)",
        title="outer wall",
        grid_note="tracked grid",
        length_mm=1.2,
    )
    h, w = 50 * FIELD_SCALE, 80 * FIELD_SCALE
    picture = framed[3, BANNER : BANNER + h, MARGIN_LEFT : MARGIN_LEFT + w]
    assert np.array_equal(picture, bare[3, :h, :w])  # the data untouched
    assert _ink(framed[3, BANNER : BANNER + h, :MARGIN_LEFT]) > 0.02  # v ticks and names
    assert _ink(framed[3, BANNER + h : BANNER + h + 60, MARGIN_LEFT : MARGIN_LEFT + w]) > 0.02
    bar = framed[3, BANNER - 40 : BANNER + h, MARGIN_LEFT + w :]
    assert _ink(bar) > 0.05  # the colour bar
    streamed = field_frames(
        field,
        t_ms,
        label="radial curvature (1/mm)",
        title="outer wall",
        grid_note="tracked grid",
        length_mm=1.2,
        stream=True,
    )
    assert not isinstance(streamed, np.ndarray)  # one frame at a time
    assert np.array_equal(np.stack(list(streamed)), framed)  # the same frames
    assert _ink(bar[:20]) > 0.02  # and its label above it
    # the time stamp: in the white banner, different from frame to frame
    banner = framed[:, :BANNER, : MARGIN_LEFT + w]
    assert _ink(banner[3]) > 0.01
    assert not np.array_equal(banner[3], banner[4])
    assert _ink(bare[3, :20, :200]) > 0.5  # no banner: the field


@pytest.mark.parametrize("level", [-50.0, 50.0])
def test_the_time_stamp_reads_on_dark_and_light_frames(level):
    """The stamp is black on the white banner, not on the picture: the same text
    pixels whatever the field's colours."""
    t_ms = np.arange(30) * 12.0
    frames = [
        field_frames(_field(level=lv), t_ms, vmin=-1, vmax=1, label="x (1)") for lv in (level, 0.0)
    ]
    assert np.array_equal(
        frames[0][:, 30 : BANNER - 12, :280], frames[1][:, 30 : BANNER - 12, :280]
    )
    assert _ink(frames[0][5, 30 : BANNER - 12, :280]) > 0.02


def test_a_strain_video_names_its_reference_frame():
    t_ms = np.arange(30) * 12.0
    strain = np.abs(_field()) * (np.arange(30) > 0)  # 0 at t = 0 by definition
    frames = field_frames(strain, t_ms, label="strain energy (1)", reference_frame=0)
    note = slice(BANNER - 20, BANNER - 4)
    assert _ink(frames[0, note, :400]) > 0.02
    assert _ink(frames[1, note, :400]) == 0.0


def test_a_beat_plays_in_three_to_five_seconds(tmp_path):
    for n_t in (12, 30, 40, 195):
        assert 3.0 <= n_t / beat_fps(n_t) <= 5.0
    arrays = {
        "t_ms": np.arange(30) * 12.0,
        "s_mm": np.linspace(0, 1.2, 50),
        "area_outer_mm2": 0.1 + 0.01 * _field()[0],
        "radial_curvature_outer_per_mm": _field(),
    }
    for kind, inputs in video.video_tasks(arrays):
        for name, data in video.render_videos(kind, inputs):
            path = tmp_path / name
            path.write_bytes(data)
            frames = iio.imread(path, index=None)
            assert 3.0 <= len(frames) / iio.immeta(path)["fps"] <= 5.0, name


def test_the_3d_videos_are_wide_enough_for_a_slide(tmp_path):
    n_u, n_v, n_t = 40, 20, 12
    u = np.linspace(0, 2 * np.pi, n_u, endpoint=False)[:, None, None]
    v = np.linspace(0, 1, n_v)[None, :, None]
    t = np.arange(n_t)[None, None, :]
    r = 0.2 * (1 + 0.1 * np.sin(2 * np.pi * t / n_t)) + 0 * u + 0 * v
    grid = np.stack(np.broadcast_arrays(r * np.cos(u), r * np.sin(u), v + 0 * r), axis=-1)
    arrays = {
        "t_ms": np.arange(n_t) * 30.0,
        "s_mm": np.linspace(0, 1, n_v),
        "area_outer_mm2": np.pi * r[0] ** 2 * np.ones((n_v, 1)),
        "mean_curvature_lumen_per_mm": 1 / r + 0 * r,
    }
    written = {}
    for kind, inputs in video.video_tasks(arrays, {"outer": grid, "lumen": grid}):
        if kind in ("area", "lumen_3d"):
            written.update(video.render_videos(kind, inputs))
    for name in ("outer_wall_3d_area_map.mp4", "lumen_mean_curvature_3d.mp4"):
        (tmp_path / name).write_bytes(written[name])
        frame = iio.imread(tmp_path / name, index=0)
        assert frame.shape[1] >= 1280, name
        assert _ink(frame[:BANNER, :400]) > 0.01  # title and time


def test_every_field_video_title_fits_its_frame_and_types_its_units():
    """The longest title with the longest grid note fits the frame (the normalised
    curvature's ran off it), and no title or colour-bar label types a unit in ASCII."""
    import re

    from oftimg.output.video import text_width

    for name, _, _, options in video.FIELD_VIDEOS:
        scale = options.get("scale", FIELD_SCALE)  # as many pixels as the others
        grid_note = options.get("grid_note", "per-frame grid")
        heading = ", ".join(x for x in (options.get("title"), grid_note) if x)
        field = _field(n_u=80 * FIELD_SCALE // scale, n_v=50 * FIELD_SCALE // scale, n_t=2)
        frame = field_frames(
            field,
            np.arange(2) * 10.0,
            **{**{k: v for k, v in options.items() if k != "times"}, "grid_note": grid_note},
        )
        # 0.7 of the title's size is the smallest it is written at
        assert 0.7 * text_width(heading, 0.55) <= frame.shape[2] - 16, name
        assert _ink(frame[0, 4:26, -8:]) == 0.0, f"{name}: the title runs to the frame's edge"
        for text in (options.get("title", ""), options.get("label", "")):
            assert not re.search(r"\bum\b|\^\d|\+-", text), f"{name}: {text!r}"


def test_field_videos_give_a_field_in_the_figures_unit():
    """Thickness in its video in the unit of every figure and table (oftimg.output.units:
    mm); one-signed strain in viridis, as the figures draw it."""
    from oftimg.output import units

    options = {name: opts for name, _, _, opts in video.FIELD_VIDEOS}
    for name in ("wall_thickness", "jelly_thickness"):
        assert options[name]["label"].endswith("(mm)")
        assert options[name]["times"] == units.THICKNESS.scale == 1.0
    assert {options[n]["cmap"] for n in options if n.startswith("strain")} == {"viridis"}
    arrays = {
        "t_ms": np.arange(4) * 10.0,
        "s_mm": np.linspace(0, 1.2, 50),
        "area_outer_mm2": 0.1 + 0.01 * _field(n_t=4)[0],
        "wall_thickness_mm": 0.02 + 0.001 * _field(n_t=4),
    }
    task = next(t for t in video.video_tasks(arrays) if t[1].get("name") == "wall_thickness")
    from_mm = dict(video.render_videos(*task))
    assert "wall_thickness.mp4" in from_mm


@pytest.mark.parametrize(
    "lo, hi, ticks",
    [
        (0.0274, 0.0826, ["0.03", "0.04", "0.05", "0.06", "0.07", "0.08"]),
        (-55.3, 55.3, ["-40", "-20", "0", "20", "40"]),
        (14.2, 40.1, ["15", "20", "25", "30", "35", "40"]),
        (0.0, 1.0, ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]),
    ],
)
def test_colour_bar_ticks_are_round_values_to_one_decimal(lo, hi, ticks):
    values, labels = video.nice_ticks(lo, hi)
    assert labels == ticks
    assert all(lo <= v <= hi for v in values)


def _straight_tube(n_u: int, n_v: int) -> np.ndarray:
    """A straight tube's grid ``(n_u, n_v, 3)``: radius 0.15, from y = -1 to 1."""
    u = np.linspace(0, 2 * np.pi, n_u, endpoint=False)[:, None]
    v = np.linspace(0, 1, n_v)[None, :]
    r = 0.15 + 0 * u * v
    return np.stack(np.broadcast_arrays(r * np.cos(u), 2 * v - 1, r * np.sin(u)), axis=-1)


def test_the_3d_view_marks_the_inlet_and_the_outlet():
    """'inlet' and 'outlet' written beyond the first and the last ring of the 3-D view,
    where the camera projects them."""
    n_u, n_v = 40, 20
    grid = _straight_tube(n_u, n_v)
    camera = video.SurfaceCamera(grid[:, :, None], size=320)
    row, col = camera.project(np.array([grid[:, 0].mean(0), grid[:, -1].mean(0)]))
    view = np.full((320, 320, 3), 255, np.uint8)
    video._mark_ends(view, camera, grid)
    written = np.argwhere(view.min(axis=-1) < 200)
    assert len(written) > 20
    near = [np.min(np.hypot(written[:, 0] - r_, written[:, 1] - c_)) for r_, c_ in zip(row, col)]
    assert max(near) < 45  # each name next to its own end
    inlet_side = np.hypot(written[:, 0] - row[0], written[:, 1] - col[0]) < np.hypot(
        written[:, 0] - row[1], written[:, 1] - col[1]
    )
    assert 0.3 < inlet_side.mean() < 0.7  # two words, one at each end


def test_the_map_cursor_sits_at_the_time_its_axis_gives():
    """At 100 ms the cursor lies on the axis's 100 ms tick (it sat half a frame later:
    the ticks marked each column's left edge, the cursor its centre)."""
    n_v, n_t, dt = 30, 20, 20.0  # ticks at 0, 100, 200, 300 ms
    area = np.tile(np.linspace(1, 2, n_t), (n_v, 1))
    t_ms = dt * np.arange(n_t)
    frames = video.map_cursor_frames(area, t_ms)
    h = n_v * max(1, round(420 / n_v))
    tick_row = frames[0, BANNER + h + 3, MARGIN_LEFT:]  # below the map
    ticks = MARGIN_LEFT + np.flatnonzero(tick_row.max(axis=-1) < 60)
    for k in (0, 5, 10, 15):  # 0, 100, 200, 300 ms
        inside = frames[k, BANNER + h // 2, MARGIN_LEFT:]
        cursor = MARGIN_LEFT + np.flatnonzero(inside.max(axis=-1) < 60)
        assert len(cursor) == 1
        assert np.abs(ticks - cursor[0]).min() == 0, (k, cursor, ticks)


def test_nodes_whose_band_is_wide_are_greyed_and_the_title_says_so():
    """A curvature of 10 /mm whose 95 % band is 2 /mm but 8 /mm over a block of nodes (over
    half the value): those nodes fade towards grey, the others keep their colour, the
    title says what grey means, and the per-pixel normalised video is not greyed."""
    from oftimg.output.video import UNCERTAIN_GREY, uncertain_nodes, video_tasks

    n_u, n_v, n_t = 80, 50, 4
    curvature = np.full((n_u, n_v, n_t), 10.0) + np.linspace(-3, 3, n_u)[:, None, None]
    band = np.full_like(curvature, 2.0)
    band[10:20, 5:15] = 8.0
    arrays = {
        "radial_curvature_outer_per_mm": curvature,
        "t_ms": np.arange(n_t) * 10.0,
        "radial_curvature_outer_band95_per_mm": band,
        "s_mm": np.linspace(0, 1.2, n_v),
        "area_outer_mm2": np.ones((n_v, n_t)),
    }
    marks = uncertain_nodes(arrays, "radial_curvature_outer_per_mm")
    assert marks["uncertain"].sum() == 10 * 10 * n_t and "grey" in marks["uncertain_note"]
    assert uncertain_nodes(arrays, "strain_energy_outer") == {}
    options = dict(vmin=-13, vmax=13, cmap="RdBu_r", annotate=False)
    plain = field_frames(curvature, arrays["t_ms"], **options)[1]
    greyed = field_frames(curvature, arrays["t_ms"], **options, **marks)[1]
    changed = np.any(plain != greyed, axis=-1)
    assert changed.sum() == 10 * 10 * FIELD_SCALE**2  # those nodes' pixels only
    assert np.all(
        np.abs(greyed[changed].astype(int) - UNCERTAIN_GREY)
        <= np.abs(plain[changed].astype(int) - UNCERTAIN_GREY)
    )
    titled = [
        field_frames(curvature, arrays["t_ms"], vmin=-13, vmax=13, title="outer wall", **extra)[1]
        for extra in ({}, marks)
    ]
    assert not np.array_equal(titled[0][:30], titled[1][:30])  # the note in the banner
    tasks = {t[1]["name"]: t[1]["options"] for t in video_tasks(arrays, kinds=["field"])}
    assert "uncertain" in tasks["radial_curvature_outer"]
    assert "uncertain" not in tasks["radial_curvature_outer_normalized"]


def test_a_video_colour_map_runs_its_whole_length():
    """Issue 87: the videos' colour table runs each map from its start to its end
    (twilight's 510-entry table was indexed 0-255: its first half alone)."""
    from matplotlib import colormaps

    for name in ("twilight", "viridis", "RdBu_r"):
        lut = video._lut(name)
        ends = np.round(colormaps[name]([0.0, 1.0])[:, :3] * 255)
        assert np.abs(lut[[0, -1]] - ends).max() <= 1, name


def test_a_phase_wrapping_across_the_wall_is_drawn_without_a_seam():
    """Issue 87: a phase near +-pi on neighbouring nodes is one colour (twilight's ends
    meet); averaging the corners' values ran through 0, twilight's black middle, along
    every wrap. Nodes too still to time are grey, as the activation figure has them."""
    n_u, n_v = 40, 20
    grid = _straight_tube(n_u, n_v)
    camera = video.SurfaceCamera(grid[:, :, None], size=160)
    phase = np.where((np.arange(n_u)[:, None] + np.arange(n_v)[None, :]) % 2, 3.1, -3.1)
    shown = {
        cyclic: camera.render(grid, phase, vmin=-np.pi, vmax=np.pi, cmap="twilight", cyclic=cyclic)
        for cyclic in (False, True)
    }
    tube = shown[True].min(axis=-1) < 250  # the tube's pixels, not the white
    # twilight's ends are white (226 at most in any channel, at least 0.35 of it shaded:
    # 79); its middle is dark (54 at most)
    assert np.percentile(shown[True][tube].max(axis=-1), 5) > 75
    assert np.percentile(shown[False][tube].max(axis=-1), 5) < 60
    arrays = {
        "phase_outer": np.zeros((n_u, n_v, 3), np.float32),
        "wave_velocity_outer_mm_s": np.where(np.arange(n_u)[:, None, None] < 10, np.nan, 1.0)
        * np.ones((n_u, n_v, 2)),
    }
    timed = video.timed_phase(arrays)
    assert np.isnan(timed[:10]).all() and not np.isnan(timed[10:]).any()
