"""Image order (inlet at the bottom, time as frames) and the TIFF images Fiji opens:
the results' own numbers, pixel for pixel, with what they are."""

import json

import numpy as np
import pytest

from oftimg.cli import main
from oftimg.errors import InputError
from oftimg.output.image_order import in_image_order
from oftimg.errors import DatasetError


def test_image_order_puts_the_inlet_at_the_bottom_and_time_in_frames():
    n_u, n_v, n_t = 5, 4, 3
    field = np.arange(n_u * n_v * n_t, dtype=float).reshape(n_u, n_v, n_t)
    image, axes = in_image_order(field, ["u", "v", "t"])
    assert axes == "TYX" and image.shape == (n_t, n_v, n_u)
    i, j, t = 3, 0, 2  # u = 3/5, the inlet row
    assert image[t, n_v - 1, i] == field[i, j, t]
    area = field[0]  # (v, t)
    image, axes = in_image_order(area, ["v", "t"])
    assert axes == "YX" and image[-1].tolist() == area[0].tolist()  # inlet: bottom row
    image, axes = in_image_order(field[:, :, 0], ["u", "v"])
    assert axes == "YX" and image[0].tolist() == field[:, -1, 0].tolist()  # outlet: top row
    stretch = np.stack([field, -field], axis=-1)
    image, axes = in_image_order(stretch, ["u", "v", "t", "l1,l2"])
    assert axes == "TCYX" and image[t, 1, n_v - 1, i] == -field[i, j, t]
    for dims in (["t"], ["v"], ["u", "v", "t", "xyz", "k"], ["up/down", "v"]):
        with pytest.raises(ValueError, match="no image has the axes"):
            in_image_order(np.zeros((2,) * len(dims)), dims)


def test_videos_show_the_inlet_at_the_bottom():
    from oftimg.output.video import field_frames

    field = np.zeros((8, 6, 2))
    field[:, 0] = 1.0  # the inlet row high
    frame = field_frames(
        field, np.arange(2.0), vmin=0, vmax=1, cmap="jet", scale=12, annotate=False
    )[0]
    picture = frame[: 6 * 12, : 8 * 12].astype(float)  # without the bar and the padding
    red, blue = picture[..., 0], picture[..., 2]  # jet: 1 red, 0 blue
    assert red[60:].min() > 100 and blue[60:].max() < 10  # the last 12 rows: v = 0
    assert red[:60].max() < 10 and blue[:60].min() > 100  # the rest: v > 0


def test_tiff_images_hold_the_results(run_out, tmp_path, capsys):
    import tifffile

    out = tmp_path / "tiff"
    assert main(["tiff", str(run_out), "--out", str(out), "--quiet"]) == 0
    assert "TIFF images" in capsys.readouterr().out
    results = run_out / "normal"
    described = json.loads((results / "arrays.json").read_text())
    arrays = np.load(results / "arrays.npz")
    written = sorted(p.stem for p in (out / "normal").iterdir())
    images = sorted(
        name
        for name, d in described.items()
        if d.get("file") == "arrays.npz"
        and d["dims"] in (["v", "t"], ["u", "v"], ["u", "v", "t"], ["u", "v", "t", "l1,l2"])
    )
    assert written == images and "strain_energy_outer" in written and "area_outer_mm2" in written
    t_ms = arrays["t_ms"]
    for name in written:
        a, dims = arrays[name], described[name]["dims"]
        with tifffile.TiffFile(out / "normal" / f"{name}.tif") as tif:
            image, meta = tif.asarray(), tif.imagej_metadata
        assert described[name]["description"] in meta["Info"]
        if dims == ["v", "t"]:  # rows v (inlet at the bottom), cols t
            expected = a[::-1]
        elif dims == ["u", "v"]:
            expected = a.T[::-1]
        else:  # frames t, (channels,) rows v, cols u
            expected = np.moveaxis(a, 2, 0).swapaxes(1, 2)[:, ::-1]
            if a.ndim == 4:
                expected = np.moveaxis(expected, 3, 1)
            assert meta["frames"] == len(t_ms)
            assert meta["finterval"] == pytest.approx((t_ms[1] - t_ms[0]) / 1000, rel=1e-6)
            assert meta["Labels"][-1] == f"t = {t_ms[-1]:.1f} ms"
        if a.dtype == bool:  # a mask: 8-bit 0 / 255
            assert image.dtype == np.uint8 and np.array_equal(image, expected * np.uint8(255))
        else:
            assert image.dtype == np.float32
            assert np.array_equal(image, expected.astype(np.float32), equal_nan=True), name
    with tifffile.TiffFile(out / "normal" / "principal_stretch_outer.tif") as tif:
        assert tif.imagej_metadata["channels"] == 2
        assert "channels: l1, l2" in tif.imagej_metadata["Info"]
    # the run's cohort maps: one slice per embryo, rows position (inlet at the bottom)
    maps = np.load(run_out / "cohort_maps.npz")
    assert sorted(p.stem for p in (out / "cohort_maps").iterdir()) == [
        "area_outer_mm2",
        "area_outer_normalized",
        "jelly_thickness_mm",
        "strain_energy_outer",
        "wall_thickness_mm",
    ]
    for name in ("area_outer_normalized", "strain_energy_outer"):  # no comparison: 1 group
        with tifffile.TiffFile(out / "cohort_maps" / f"{name}.tif") as tif:
            image, meta = tif.asarray(), tif.imagej_metadata
        stack = maps[name][:, ::-1].astype(np.float32)
        assert np.array_equal(image.reshape(stack.shape), stack, equal_nan=True)
        labels = meta["Labels"]  # one label is read back bare
        assert ([labels] if isinstance(labels, str) else labels) == ["normal (normal)"]
        assert "slices: embryos: normal (normal)" in meta["Info"]


def test_tiff_refuses_what_it_cannot_write(run_out, tmp_path):
    import oftimg

    taken = tmp_path / "taken"
    (taken / "mine.txt").parent.mkdir()
    (taken / "mine.txt").write_text("a lab's notes")
    with pytest.raises(InputError, match="exists and is not an empty folder"):
        oftimg.tiff(run_out, taken)
    assert [p.name for p in taken.iterdir()] == ["mine.txt"]
    partial = tmp_path / "partial" / "normal"
    partial.mkdir(parents=True)
    (partial / "summary.json").write_text((run_out / "normal" / "summary.json").read_text())
    with pytest.raises(DatasetError, match=r"normal: has no arrays.npz"):
        oftimg.tiff(partial, tmp_path / "out")
    assert not (tmp_path / "out").exists()
