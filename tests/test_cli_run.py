"""End to end through the command line on a small phantom: the output contract."""

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest

from oftimg.cli import main
from oftimg.output.style import vector_formats

pytestmark = pytest.mark.slow

SUMMARY_KEYS = {
    "name",
    "group",
    "n_frames",
    "period_ms",
    "t0_frame",
    "expand_fraction",
    "contract_fraction",
    "expand_contract_ratio",
    "expand_ms",
    "contract_ms",
    "tube_length_mm",
    "myocardial_volume_change",
    "jelly_volume_change",
    "provenance",
}


@pytest.fixture
def png_figures():
    """conftest's png_figures_only for one test: the output contract's run keeps its PDFs."""
    with vector_formats(()):
        yield


def test_output_contract(run_out, phantom_normal):
    folder = run_out / "normal"
    summary = json.loads((folder / "summary.json").read_text())
    assert SUMMARY_KEYS <= set(summary)
    assert summary["provenance"]["oftimg_version"]
    assert len(summary["provenance"]["inputs"]["meshes"]["outer"]) == 36
    dataset = summary["provenance"]["dataset"]  # found from anywhere (issue 71)
    assert Path(dataset["path"]).is_absolute() and Path(dataset["path"]) == phantom_normal
    assert (folder / dataset["from_results"]).resolve() == phantom_normal.resolve()
    assert summary["tracking"]["grid"] == "tracked"  # the default
    assert summary["tracking"]["ring_rms_mm"] <= summary["tracking"]["ring_rms_unturned_mm"]
    assert "on the tracked grid" in (folder / "index.html").read_text()
    band = summary["wave_speed_band_95_mm_s"]["cycle"]  # calibrated on the zoo
    assert band > 1.96 * summary["wave_speed_noise_sd_mm_s"]["cycle"]
    speed = summary["wave_speed_mm_s"]["cycle"]
    assert re.search(
        r"<td>[0-9.]+ ± [0-9.]+ \(95 % band\)</td>", (folder / "index.html").read_text()
    )
    from oftimg.output.numbers import decimals_of, with_interval

    assert (
        f"| {with_interval(speed, band, decimals_of(speed))} |"
        in (run_out / "table1.md").read_text()
    )
    grids = np.load(folder / "grids.npz")
    for wall in ("outer", "inner", "lumen"):
        assert grids[wall].shape == (80, 50, 36, 3) and grids[wall].dtype == np.float32
    arrays = np.load(folder / "arrays.npz")
    described = json.loads((folder / "arrays.json").read_text())
    pca = np.load(folder / "pca.npz")
    made_on_load = {n for n, d in described.items() if "made_on_load" in d}
    assert made_on_load == {f"{w}_clipped" for w in ("outer", "inner", "lumen")}
    assert set(arrays.files) | set(grids.files) | set(pca.files) == set(described) - made_on_load
    for file, held in (("arrays.npz", arrays), ("grids.npz", grids), ("pca.npz", pca)):
        for name in held.files:
            assert described[name]["file"] == file
            assert described[name]["shape"] == list(held[name].shape)
            assert described[name]["dtype"] == str(held[name].dtype)
            assert described[name]["dims"] and "description" in described[name]
    for name in arrays.files:
        assert described[name]["unit"]
        if "v" in described[name]["dims"] and "t" in described[name]["dims"]:
            dims = described[name]["dims"]
            assert arrays[name].shape[dims.index("v")] == 50
            assert arrays[name].shape[dims.index("t")] == 36
    for fig in (
        "volume_over_cycle.png",
        "trim_over_cycle.png",
        "frame_t0_contours.png",
        "wall_thickness_map.png",
        "jelly_thickness_map.png",
    ):
        assert (folder / "figures" / fig).stat().st_size > 10_000
    rows = list(csv.DictReader(open(run_out / "table1.csv")))
    assert len(rows) == 1 and rows[0]["name"] == "normal"
    assert float(rows[0]["expand_percent"]) == pytest.approx(
        100 * summary["expand_fraction"], abs=0.005
    )  # 2 decimals
    for fig in ("volume_over_cycle", "area_map_outer"):  # vector beside the PNG
        assert (folder / "figures" / (fig + ".pdf")).stat().st_size > 5_000
        assert not (folder / "figures" / (fig + ".svg")).exists()  # the paper script's


def test_rerun_needs_overwrite_and_keeps_results(run_out, phantom_normal, capsys):
    before = (run_out / "normal" / "summary.json").read_text()
    assert main(["run", str(phantom_normal), "--out", str(run_out), "--quiet"]) == 2
    assert (run_out / "normal" / "summary.json").read_text() == before
    assert not [p for p in run_out.parent.iterdir() if ".partial-" in p.name]


def test_videos_read_back(run_out):
    import imageio.v2 as imageio

    videos = sorted((run_out / "normal" / "videos").glob("*.mp4"))
    assert {v.name for v in videos} >= {
        "radial_curvature_outer.mp4",
        "radial_curvature_outer_normalized.mp4",
        "strain_energy_outer.mp4",
        "radial_curvature_inner.mp4",
        "strain_energy_inner.mp4",
        "wall_thickness.mp4",
        "jelly_thickness.mp4",
        "mean_curvature_lumen.mp4",
        "area_map_cursor.mp4",
    }
    for path in videos:
        reader = imageio.get_reader(path)
        meta = reader.get_meta_data()
        assert meta["codec"] == "h264" and meta["pix_fmt"].startswith("yuv420p")
        w, h = meta["size"]
        assert w % 2 == 0 and h % 2 == 0
        assert reader.count_frames() == 36
        first, mid = reader.get_data(0).astype(float), reader.get_data(18).astype(float)
        assert np.abs(first - mid).mean() > 1.0  # the picture changes over the cycle
        reader.close()


def test_fields_on_the_phantom(run_out, phantom_normal):
    truth = json.loads((phantom_normal / "truth.json").read_text())
    summary = json.loads((run_out / "normal" / "summary.json").read_text())
    assert summary["corner_count"] == truth["corner_count"]
    a = np.load(run_out / "normal" / "arrays.npz")
    k = a["radial_curvature_outer_per_mm"]
    area = a["area_outer_mm2"]
    assert k.shape == (80, 50, 36) and k.dtype == np.float32
    # rounder when expanded: curvature varies less around the contour (paper 7.3)
    rows = range(5, 45)
    cv = lambda t, j: k[:, j, t].std() / k[:, j, t].mean()  # noqa: E731
    expanded = np.mean([cv(np.argmax(area[j]), j) for j in rows])
    contracted = np.mean([cv(np.argmin(area[j]), j) for j in rows])
    assert expanded < contracted
    e = a["strain_energy_outer"]
    assert np.nanmax(np.abs(e[:, :, 0])) < 1e-12  # the reference frame itself
    assert a["mean_curvature_lumen_per_mm"].shape == (80, 50, 36)


def test_shape_pca_on_the_phantom(run_out):
    from oftimg.image.pca import outward_normals

    summary = json.loads((run_out / "normal" / "summary.json").read_text())
    pca = np.load(run_out / "normal" / "pca.npz")
    assert len(summary["pca"]["rows"]) == 3
    for k, row in enumerate(summary["pca"]["rows"]):
        for phase in ("expansion", "contraction"):
            assert row[phase]["converged"]
            key = f"pca_row{k}_{phase}"
            expl = pca[f"{key}_explained"]
            assert expl[0] > 0.7 and expl[0] == expl.max()  # mode 1 dominates: size
            d = pca[f"{key}_displacement_mm"][0]
            along = np.sum(d * outward_normals(pca[f"{key}_mean_mm"]), axis=1)
            along /= np.linalg.norm(d, axis=1)
            assert np.median(np.abs(along)) > 0.8
            assert np.mean(along > 0) > 0.9  # one sign around the contour
    assert (run_out / "normal" / "figures" / "shape_pca.png").stat().st_size > 20_000


@pytest.mark.usefixtures("png_figures")
def test_log_file_fps_and_options_reach_the_run(tmp_path):
    from oftimg.synthetic.phantom import sample_params, write_phantom

    ds = write_phantom(
        tmp_path / "tiny",
        sample_params("normal", 2, n_frames=5, vertices_min=1500, vertices_max=1800),
    )
    meta = json.loads((ds / "meta.json").read_text())
    del meta["period_ms"]  # the period comes from the command
    (ds / "meta.json").write_text(json.dumps(meta))
    log = tmp_path / "run.log"
    out = tmp_path / "out"
    assert main(["run", str(ds), "--out", str(out), "--quiet", "--jobs", "1"]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tiny"]  # no out, nothing kept
    assert (
        main(
            [
                "run",
                str(ds),
                "--out",
                str(out),
                "--quiet",
                "--jobs",
                "1",
                "--fps",
                "10",
                "--period-ms",
                "400",
                "--log",
                str(log),
                "--warp",
                "--n-u",
                "40",
                "--n-v",
                "20",
                "--authalic-weight",
                "0.25",
                "--seam-method",
                "heat",
                "--map-positions",
                "fixed",
                "--field-smoothing-ms",
                "7",
                "--strain-smoothing-ms",
                "2.5",
                "--cluster-alpha",
                "0.2",
                "--tracking",
                "none",
            ]
        )
        == 0
    )
    assert json.loads((out / "run.json").read_text())["cluster_alpha"] == 0.2
    assert np.load(out / "cohort_maps.npz")["cluster_alpha"] == 0.2
    assert "uncorrected p &le; 0.2" not in (out / "index.html").read_text()  # one group
    summary = json.loads((out / "tiny" / "summary.json").read_text())
    assert (summary["period_ms"], summary["period_from"]) == (400, "--period-ms")
    assert summary["time_warp"] is True
    assert summary["provenance"]["options"]["map_positions"] == "fixed"
    assert summary["provenance"]["options"]["field_smoothing_ms"] == 7
    assert set(summary["field_smoothing_ms"].values()) == {7}  # taken by every field
    assert all(n["smoothing_ms"] == 7 for n in summary["field_noise"].values())
    assert summary["provenance"]["options"]["strain_smoothing_ms"] == 2.5
    assert summary["strain_smoothing_ms"] == {
        "strain_energy_outer": 2.5,
        "strain_energy_inner": 2.5,
    }
    assert all(n["smoothing_ms"] == 2.5 for n in summary["strain_noise"].values())
    arrays = np.load(out / "tiny" / "arrays.npz")  # the maps at fixed positions, and
    described = json.loads((out / "tiny" / "arrays.json").read_text())  # the rows' own
    for wall in ("outer", "inner", "lumen"):
        assert arrays[f"area_rows_{wall}_mm2"].shape == arrays[f"area_{wall}_mm2"].shape == (20, 5)
        assert "cubic spline" in described[f"area_{wall}_mm2"]["description"]
        assert described[f"area_rows_{wall}_mm2"]["unit"] == "mm^2"
    assert summary["provenance"]["options"]["grid"]["authalic_weight"] == 0.25
    assert summary["provenance"]["options"]["grid"]["seam_method"] == "heat"
    assert summary["provenance"]["options"]["tracking"] == "none"
    assert summary["tracking"] == {"grid": "per-frame"}
    assert "on the per-frame grid" in (out / "tiny" / "index.html").read_text()
    assert np.load(out / "tiny" / "grids.npz")["outer"].shape[:2] == (40, 20)
    text = log.read_text()
    assert "tiny: analysing 5 frames" in text and "tiny: done" in text
    import logging  # the log is let go when the command ends

    assert not [
        h
        for name in ("oftimg", "py.warnings")
        for h in logging.getLogger(name).handlers
        if isinstance(h, logging.FileHandler)
    ]
    import imageio.v2 as imageio

    assert (
        imageio.get_reader(out / "tiny" / "videos" / "area_map_cursor.mp4").get_meta_data()["fps"]
        == 10
    )


def test_a_log_where_it_would_be_lost_or_cannot_be_is_refused(tmp_path, capsys):
    """A --log inside --out ended in a traceback (its folder did not exist yet); once it
    did, the results would have replaced it. Inside the dataset it wrote into the input."""
    from helpers import tube_mesh, write_series

    ds = write_series(tmp_path / "emb", [tube_mesh(n_theta=20, n_s=6)] * 5)
    out = tmp_path / "out"
    for log, said in (
        (out / "run.log", "is inside --out, which the results replace"),
        (ds / "run.log", "is inside the input, which oftimg never writes to"),
        (tmp_path / "none" / "run.log", f"the folder {tmp_path / 'none'} does not exist"),
    ):
        assert main(["run", str(ds), "--out", str(out), "--log", str(log), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert f"oftimg: error: --log {log}" in err and said in err
        assert not log.exists() and not out.exists()


@pytest.mark.usefixtures("png_figures")
def test_demo_names_its_data_where_they_stay(tmp_path, capsys, monkeypatch):
    """`oftimg demo`: results whose provenance points at the demo's own data folder
    (not the temporary folder it was made in), and a second demo refused without
    --overwrite; off a terminal, a line of progress at least every few seconds, and the
    last line names the report to open. (A smaller demo: tests/test_documented_outputs.py
    runs the real one.)"""
    from oftimg import demos
    from oftimg import progress

    monkeypatch.setattr(
        demos, "DEMO_SMALL", (1, {"frames": 12, "vertices_min": 1500, "vertices_max": 1800})
    )
    monkeypatch.setattr(progress, "LINE_EVERY_S", 0.5)
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out)]) == 0
    said = capsys.readouterr()
    lines = [line for line in said.err.splitlines() if re.search(r": \d+/\d+ \w+s", line)]
    assert any(
        re.search(
            r"normal_0: grids and sections \(pass 2 of 2\): \d+/12 frames "
            r"\(\d+ %\)",
            line,
        )
        for line in lines
    )  # 12 frames, not 24
    assert said.out.splitlines()[-1].startswith(f"report: {out / 'results' / 'index.html'}")
    assert "the warnings above are the phantoms' own, made on purpose" in said.out
    assert (out / "results" / "index.html").is_file()
    run_info = json.loads((out / "results" / "run.json").read_text())
    assert sorted(run_info["inputs"]) == sorted(str(p) for p in (out / "data").iterdir())
    for name in ("normal_0", "banded_0"):
        summary = json.loads((out / "results" / name / "summary.json").read_text())
        files = [f["file"] for f in summary["provenance"]["inputs"]["meshes"]["outer"]]
        assert len(files) == 12
        assert all(Path(f).parent.samefile(out / "data" / name / "outer") for f in files)
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no staging left
    assert main(["demo", "--out", str(out), "--quiet"]) == 2
    assert "--overwrite" in capsys.readouterr().err


@pytest.mark.usefixtures("png_figures")
def test_a_full_disk_is_an_error_not_an_internal_one(tmp_path, monkeypatch, capsys):
    """The system refusing a write (no space, no permission, a read-only disk) is
    said as such, naming the file; nothing appears in --out."""
    import errno

    from oftimg.output import export
    from oftimg.synthetic.phantom import sample_params, write_phantom

    ds = write_phantom(
        tmp_path / "tiny",
        sample_params("normal", 2, n_frames=5, vertices_min=1500, vertices_max=1800),
    )
    real_write_json = export.write_json

    def disk_full(path, data):
        if Path(path).name == "summary.json":
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        real_write_json(path, data)

    monkeypatch.setattr(export, "write_json", disk_full)
    out = tmp_path / "out"
    assert main(["run", str(ds), "--out", str(out), "--quiet", "--jobs", "1"]) == 1
    err = capsys.readouterr().err
    assert "oftimg: error: [Errno 28] No space left on device:" in err and "summary.json" in err
    assert "internal error" not in err and not out.exists()


@pytest.mark.usefixtures("png_figures")
def test_a_library_failing_is_an_internal_error_not_bad_input(tmp_path, monkeypatch, capsys):
    """A TypeError or ValueError out of a library while the numbers are made (say a
    SciPy too old for a keyword) is oftimg's failure: exit status 1, "internal error",
    not 2 and "error" as if the input were bad; oftimg's own checks still say "error"
    with 2. (A library failing in a drawing leaves that drawing out, the numbers
    written: tests/test_unusual_meshes.py.)"""
    import scipy.ndimage

    from oftimg.synthetic.phantom import sample_params, write_phantom

    ds = write_phantom(
        tmp_path / "tiny",
        sample_params("normal", 2, n_frames=5, vertices_min=1500, vertices_max=1800),
    )

    def broken_filter(*args, **kwargs):
        raise TypeError("gaussian_filter1d() got an unexpected keyword argument 'mode'")

    monkeypatch.setattr(scipy.ndimage, "gaussian_filter1d", broken_filter)
    out = tmp_path / "out"
    assert main(["run", str(ds), "--out", str(out), "--quiet", "--jobs", "1"]) == 1
    err = capsys.readouterr().err
    assert "oftimg: internal error: TypeError: gaussian_filter1d()" in err and not out.exists()
    assert "(at oftimg/" in err and "please report it)" in err  # where, to act on
    monkeypatch.undo()
    assert main(["run", str(ds), "--out", str(out), "--quiet", "--n-u", "2"]) == 2
    assert "oftimg: error: grid must be at least 3 x 2, found 2 x 50" in capsys.readouterr().err


def test_too_few_frames_for_a_cycle_stop_the_run_before_any_work(tmp_path, capsys, monkeypatch):
    """4 frames ran the whole analysis, then failed at the shape modes with "need at
    least 3 planar curves"; now the run stops first, naming the folder."""
    from oftimg import api
    from oftimg.synthetic.phantom import sample_params, write_phantom

    ds = write_phantom(
        tmp_path / "short",
        sample_params("normal", 2, n_frames=4, vertices_min=1500, vertices_max=1800),
    )
    monkeypatch.setattr(api, "_validated", lambda *a: pytest.fail("validated"))
    out = tmp_path / "out"
    assert main(["run", str(ds), "--out", str(out), "--quiet", "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert f"oftimg: error: {ds / 'outer'}: 4 frames; an analysis needs at least 5" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["short"]  # no out, nothing kept


def test_without_a_period_a_run_refuses_and_says_how_to_give_one(tmp_path, capsys):
    """A dataset without period_ms was timed at 2 ms a frame: a 24-frame series became a
    48 ms beat and its wave 7x too fast, with a warning naming a meta.json that did not
    exist. Now validate and run both refuse it (a run naming every such dataset, and
    a missing meta.json as missing) until meta.json or --period-ms gives one; validate
    exited 0 ("problems: none") where the run then refused."""
    import shutil

    from oftimg.synthetic.phantom import sample_params, write_phantom

    cohort = tmp_path / "cohort"
    for name in ("a", "b"):
        ds = write_phantom(
            cohort / name,
            sample_params("normal", 2, n_frames=5, vertices_min=500, vertices_max=600),
            walls=("outer",),
        )
        (ds / "meta.json").unlink()
    shutil.copytree(cohort / "a", cohort / "c")
    (cohort / "c" / "meta.json").write_text(json.dumps({"period_ms": 300}))
    assert main(["validate", str(cohort / "a")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(
        f"oftimg: error: {cohort / 'a'}: no meta.json, so no period_ms: "
    ), err
    assert main(["validate", str(cohort), "--period-ms", "300"]) == 0
    said = capsys.readouterr().out
    assert said.count("period: 300 ms (--period-ms)") == 2 and "period: 300 ms (meta.json)" in said
    out = tmp_path / "out"
    assert main(["run", str(cohort), "--out", str(out), "--quiet", "--jobs", "1"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"oftimg: error: {cohort / 'a'}: no meta.json, so no period_ms (and 1 more of "
        "the 3 datasets: b): oftimg gives times in ms and speeds in mm/s, which "
        'need the beat\'s length; add "period_ms" to meta.json or run with '
        "--period-ms MS (the frame interval times the 5 frames of one beat)"
    ]
    assert not out.exists()
    for bad in ("0", "nan", "1e9"):
        assert main(["run", str(cohort), "--out", str(out), "--period-ms", bad]) == 2
        assert "--period-ms: period_ms is the beat's length in ms" in capsys.readouterr().err


@pytest.mark.parametrize("fps", ["0", "-5", "nan", "inf"])
def test_frames_per_second_must_be_positive(tmp_path, capsys, fps):
    """--fps 0 wrote videos that do not play; -5 and nan ended in internal errors."""
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "any"), "--out", str(out), "--quiet", "--fps", fps]) == 2
    assert "oftimg: error: --fps must be a positive number" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("command", ["run", "cohort"])
@pytest.mark.parametrize("alpha", ["0", "1", "-0.1", "nan"])
def test_a_cluster_forming_threshold_must_be_a_p_value(tmp_path, capsys, command, alpha):
    """Refused before any work (a run would otherwise fail after its embryos, at the
    cohort maps), leaving no --out."""
    out = tmp_path / "out"
    assert main([command, str(tmp_path / "any"), "--out", str(out), "--cluster-alpha", alpha]) == 2
    assert "--cluster-alpha) must be an uncorrected p between 0 and 1" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.usefixtures("png_figures")
def test_swapped_walls_are_refused(tmp_path, capsys):
    """inner/ and outer/ swapped gave negative myocardial volumes and a 100 % trim
    without a word; then warnings and exit 0; now exit 2 with one line (issue 71),
    after the warnings that say what was seen."""
    import warnings

    from oftimg.synthetic.phantom import sample_params, write_phantom

    ds = write_phantom(
        tmp_path / "swapped",
        sample_params("normal", 2, n_frames=5, vertices_min=1500, vertices_max=1800),
    )
    (ds / "outer").rename(ds / "was_outer")
    (ds / "inner").rename(ds / "outer")
    (ds / "was_outer").rename(ds / "inner")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(["run", str(ds), "--out", str(tmp_path / "out"), "--quiet", "--jobs", "1"]) == 2
    swapped = [str(w.message) for w in caught if "swapped?" in str(w.message)]
    assert swapped == [
        f"{ds}: the inner wall encloses as much as the outer one or more in "
        "5 of 5 frames: are inner/ and outer/ swapped?"
    ]  # lumen/ is fine
    errors = [
        line for line in capsys.readouterr().err.splitlines() if line.startswith("oftimg: error:")
    ]
    assert len(errors) == 1 and errors[0].startswith(
        f"oftimg: error: {ds}: results that cannot be right, so none are written: the inner "
        "wall lies outside the outer one at 100% of the grid nodes"
    )
    assert "the inner wall encloses as much as the outer one or more in 5 of 5 frames" in errors[0]
    assert not (tmp_path / "out").exists()


@pytest.mark.usefixtures("png_figures")
def test_a_dataset_with_mended_frames_gives_the_clean_datasets_numbers(tmp_path):
    """Debris beside the tube and one-face holes, in one frame of each wall, are mended
    in the workers as in the validation: the results are those of the clean files."""
    import shutil

    from oftimg.io.meshfile import read_mesh_file, write_ply
    from oftimg.synthetic.phantom import sample_params, write_phantom

    clean = write_phantom(
        tmp_path / "clean",
        sample_params("normal", 3, n_frames=6, vertices_min=2000, vertices_max=2500),
    )
    mended = tmp_path / "mended"
    shutil.copytree(clean, mended)
    # holes of one face: 13 % of the outer and inner walls' shorter end, 22 % of the
    # folded lumen's at this coarse meshing (too large to fill): debris only there
    for wall, t, holes in (
        ("outer", 2, [1000, 1500]),
        ("inner", 0, [1000, 1500]),
        ("lumen", 5, []),
    ):
        frame = sorted((mended / wall).iterdir())[t]
        V, F = read_mesh_file(frame)
        blob = V.max(axis=0) + [[0.1, 0, 0], [0.11, 0, 0], [0.1, 0.01, 0], [0.1, 0, 0.01]]
        write_ply(
            frame,
            np.concatenate([V, blob]),
            np.concatenate(
                [
                    np.delete(F, holes, axis=0),
                    len(V) + np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]),
                ]
            ),
        )
    for ds in (clean, mended):
        assert (
            main(
                [
                    "run",
                    str(ds),
                    "--out",
                    str(tmp_path / f"out_{ds.name}"),
                    "--quiet",
                    "--jobs",
                    "2",
                ]
            )
            == 0
        )
    a, b = (
        np.load(next((tmp_path / f"out_{name}").glob("*/arrays.npz")))
        for name in ("clean", "mended")
    )
    for wall in ("outer", "inner", "lumen"):
        assert np.allclose(b[f"area_{wall}_mm2"], a[f"area_{wall}_mm2"], rtol=1e-5)
        assert np.allclose(b[f"volume_{wall}_mm3"], a[f"volume_{wall}_mm3"], rtol=1e-9)
    summary = json.loads(next((tmp_path / "out_mended").glob("*/summary.json")).read_text())
    page = next((tmp_path / "out_mended").glob("*/index.html")).read_text()
    assert "frames repaired on reading" in page and "lumen 1 (f5.ply: dropped 1 part" in page
    repairs = {w: summary["validation"]["surfaces"][w]["repairs"] for w in ("outer", "lumen")}
    assert repairs == {
        "outer": {
            "f2.ply": "dropped 1 part apart from the tube (4 faces), filled "
            "2 holes in the wall (6 boundary edges)"
        },
        "lumen": {"f5.ply": "dropped 1 part apart from the tube (4 faces)"},
    }


def test_the_warnings_of_a_failed_analysis_are_not_lost(monkeypatch, tmp_path):
    """They are raised again, each text once, before the error goes on."""
    import warnings

    from oftimg import api

    from oftimg.analysis import pipeline
    from oftimg.errors import OftimgWarning

    def analyse(ds, opts, **kwargs):
        for text in ("a: first", "a: second", "a: first"):
            warnings.warn(text, OftimgWarning, stacklevel=2)
        raise RuntimeError("disk full")

    monkeypatch.setattr(pipeline, "analyse_dataset", analyse)
    with (
        warnings.catch_warnings(record=True) as caught,
        pytest.raises(RuntimeError, match="disk full"),
    ):
        warnings.simplefilter("always")
        api.analyse_and_write(object(), {}, tmp_path, None, fps=30.0, progress=lambda: None)
    assert [str(w.message) for w in caught] == ["a: first", "a: second"]
    assert all(w.category is OftimgWarning for w in caught)


def test_numbers_only_writes_the_numbers_and_says_so(tmp_path, capsys):
    """--numbers-only (sweeps, batches): arrays, summaries, tables and pages, no figure or
    video anywhere; each page and the last line say so (never reused by a --resume that
    draws them: tests/test_resume.py)."""
    from oftimg.synthetic.phantom import sample_params, write_phantom

    data = write_phantom(
        tmp_path / "emb",
        sample_params("normal", 2, n_frames=5, vertices_min=1500, vertices_max=1800),
    )
    out = tmp_path / "out"
    assert (
        main(["run", str(data), "--out", str(out), "--quiet", "--jobs", "1", "--numbers-only"]) == 0
    )
    assert capsys.readouterr().out.strip().endswith("(open it in a browser: tables; numbers only)")
    written = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert not [f for f in written if f.endswith((".png", ".pdf", ".svg", ".mp4"))], written
    assert {
        "emb/arrays.npz",
        "emb/grids.npz",
        "emb/summary.json",
        "emb/index.html",
        "table1.csv",
        "cohort.csv",
        "qc.csv",
        "index.html",
    } <= written
    summary = json.loads((out / "emb" / "summary.json").read_text())
    assert summary["numbers_only"] is True and np.isfinite(summary["wave_speed_mm_s"]["cycle"])
    assert json.loads((out / "run.json").read_text())["numbers_only"] is True
    assert "Numbers only" in (out / "emb" / "index.html").read_text()
    assert "<h2>Figures</h2>" not in (out / "emb" / "index.html").read_text()
    assert "numbers only" in (out / "index.html").read_text()
