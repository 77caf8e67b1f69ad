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
    framed = field_frames(field, t_ms, label="radial curvature (1/mm)", title="outer wall",
                          grid_note="tracked grid", length_mm=1.2)
    h, w = 50 * FIELD_SCALE, 80 * FIELD_SCALE
    picture = framed[3, BANNER:BANNER + h, MARGIN_LEFT:MARGIN_LEFT + w]
    assert np.array_equal(picture, bare[3, :h, :w])                 # the data untouched
    assert _ink(framed[3, BANNER:BANNER + h, :MARGIN_LEFT]) > 0.02   # v ticks and names
    assert _ink(framed[3, BANNER + h:BANNER + h + 60, MARGIN_LEFT:MARGIN_LEFT + w]) > 0.02
    bar = framed[3, BANNER - 40:BANNER + h, MARGIN_LEFT + w:]
    assert _ink(bar) > 0.05                                          # the colour bar
    assert _ink(bar[:20]) > 0.02                                     # and its label above it
    # the time stamp: in the white banner, different from frame to frame
    banner = framed[:, :BANNER, :MARGIN_LEFT + w]
    assert _ink(banner[3]) > 0.01
    assert not np.array_equal(banner[3], banner[4])
    assert _ink(bare[3, :20, :200]) > 0.5                            # no banner: the field


@pytest.mark.parametrize("level", [-50.0, 50.0])
def test_the_time_stamp_reads_on_dark_and_light_frames(level):
    """The stamp is black on the white banner, not on the picture: the same text
    pixels whatever the field's colours."""
    t_ms = np.arange(30) * 12.0
    frames = [field_frames(_field(level=lv), t_ms, vmin=-1, vmax=1, label="x (1)")
              for lv in (level, 0.0)]
    assert np.array_equal(frames[0][:, 30:BANNER - 12, :280], frames[1][:, 30:BANNER - 12, :280])
    assert _ink(frames[0][5, 30:BANNER - 12, :280]) > 0.02


def test_a_strain_video_names_its_reference_frame():
    t_ms = np.arange(30) * 12.0
    strain = np.abs(_field()) * (np.arange(30) > 0)                  # 0 at t = 0 by definition
    frames = field_frames(strain, t_ms, label="strain energy (1)", reference_frame=0)
    note = slice(BANNER - 20, BANNER - 4)
    assert _ink(frames[0, note, :400]) > 0.02
    assert _ink(frames[1, note, :400]) == 0.0


def test_a_beat_plays_in_three_to_five_seconds(tmp_path):
    for n_t in (12, 30, 40, 195):
        assert 3.0 <= n_t / beat_fps(n_t) <= 5.0
    arrays = {"t_ms": np.arange(30) * 12.0, "s_mm": np.linspace(0, 1.2, 50),
              "area_outer_mm2": 0.1 + 0.01 * _field()[0],
              "radial_curvature_outer_per_mm": _field()}
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
    arrays = {"t_ms": np.arange(n_t) * 30.0, "s_mm": np.linspace(0, 1, n_v),
              "area_outer_mm2": np.pi * r[0] ** 2 * np.ones((n_v, 1)),
              "mean_curvature_lumen_per_mm": 1 / r + 0 * r}
    written = {}
    for kind, inputs in video.video_tasks(arrays, {"outer": grid, "lumen": grid}):
        if kind in ("area", "lumen_3d"):
            written.update(video.render_videos(kind, inputs))
    for name in ("outer_wall_3d_area_map.mp4", "lumen_mean_curvature_3d.mp4"):
        (tmp_path / name).write_bytes(written[name])
        frame = iio.imread(tmp_path / name, index=0)
        assert frame.shape[1] >= 1280, name
        assert _ink(frame[:BANNER, :400]) > 0.01                     # title and time
