"""Results read back (oftimg.load_results): every array as the run wrote it, with
its dims, unit and meaning; as an xarray Dataset on labelled axes."""

import json
import shutil
import sys

import numpy as np
import pytest

import oftimg
from oftimg.errors import DatasetError


def _npz(folder, file):
    with np.load(folder / file) as npz:
        return {k: npz[k] for k in npz.files}


def test_every_array_reads_back_with_its_dims(run_out):
    folder = run_out / "normal"
    res = oftimg.load_results(folder)
    assert (res.name, res.group) == ("normal", "normal")
    stored = {f: _npz(folder, f) for f in ("arrays.npz", "grids.npz", "pca.npz")}
    made = {n for n in res.names if "made_on_load" in res.info(n)}
    assert made == {"outer_clipped", "inner_clipped", "lumen_clipped"}  # not stored
    assert set(res.names) - made == set().union(*map(set, stored.values()))
    read = res.arrays(res.names)
    stored["grids.npz"].update({n: read[n] for n in made})
    summary = json.loads((folder / "summary.json").read_text())
    n_u, n_v = (
        summary["provenance"]["options"]["grid"]["n_u"],
        summary["provenance"]["options"]["grid"]["n_v"],
    )
    sizes = {
        "u": n_u,
        "v": n_v,
        "v_clipped": n_v,
        "t": len(stored["arrays.npz"]["t_ms"]),
        "xyz": 3,
        "xy": 2,
        "l1,l2": 2,
        "up/down": 2,
    }
    for name in res.names:
        info = res.info(name)
        np.testing.assert_array_equal(read[name], stored[info["file"]][name])
        assert len(info["dims"]) == read[name].ndim, name
        for dim, n in zip(info["dims"], read[name].shape):
            assert sizes.get(dim, n) == n, (name, dim)
    np.testing.assert_array_equal(res["outer"], stored["grids.npz"]["outer"])
    assert "outer_clipped" in res and "no_such_array" not in res


def test_the_clipped_grids_made_on_load_are_the_runs(analysed_normal, tmp_path):
    """Not stored (a third of grids.npz), the clipped grids are made on load from the
    stored grids and clipping planes: the run's own, within the grids' stored precision."""
    from oftimg.output.export import write_dataset_results

    _, _, result = analysed_normal
    folder = tmp_path / "normal"
    folder.mkdir()
    write_dataset_results(folder, result, fps=10)
    with np.load(folder / "grids.npz") as grids:
        assert sorted(grids.files) == ["inner", "lumen", "outer"]
    res = oftimg.load_results(folder)
    for wall in ("outer", "inner", "lumen"):
        run = result["grids"][f"{wall}_clipped"]
        loaded = res[f"{wall}_clipped"]
        assert loaded.shape == run.shape and loaded.dtype == np.float32
        np.testing.assert_allclose(loaded, run, rtol=0, atol=2e-5)  # mm: 20 nm
        assert np.array_equal(np.isnan(loaded), np.isnan(run))
        assert res.info(f"{wall}_clipped")["dims"] == ["u", "v_clipped", "t", "xyz"]
    both = res.arrays(["outer_clipped", "area_outer_mm2"])  # with others, at once
    np.testing.assert_array_equal(both["outer_clipped"], res["outer_clipped"])


def test_unknown_names_and_bad_folders_are_named(run_out, tmp_path):
    res = oftimg.load_results(run_out / "normal")
    with pytest.raises(KeyError, match="area_outer_mm2"):
        res["area_outr_mm2"]
    with pytest.raises(DatasetError, match="load_cohort"):
        oftimg.load_results(run_out)
    broken = tmp_path / "normal"
    shutil.copytree(run_out / "normal", broken)
    described = json.loads((broken / "arrays.json").read_text())
    described["ghost"] = dict(described["area_outer_mm2"])
    (broken / "arrays.json").write_text(json.dumps(described))
    with pytest.raises(DatasetError, match="arrays.npz: has no ghost, which arrays.json lists"):
        oftimg.load_results(broken)["ghost"]
    (broken / "arrays.npz").write_bytes(b"not a zip file")
    with pytest.raises(DatasetError, match="arrays.npz: cannot be read"):
        oftimg.load_results(broken)["area_outer_mm2"]
    (broken / "arrays.json").unlink()
    with pytest.raises(DatasetError, match="has no arrays.json"):
        oftimg.load_results(broken)
    with pytest.raises(DatasetError, match="no summary.json"):
        oftimg.load_cohort(tmp_path / "nothing")


def test_load_cohort_reads_every_dataset_in_name_order(run_out, tmp_path):
    for name in ("b10", "b2"):
        shutil.copytree(run_out / "normal", tmp_path / name)
        summary = json.loads((tmp_path / name / "summary.json").read_text())
        (tmp_path / name / "summary.json").write_text(json.dumps(dict(summary, name=name)))
    cohort = oftimg.load_cohort([tmp_path])
    assert list(cohort) == ["b2", "b10"] and cohort["b10"].name == "b10"
    assert list(oftimg.load_cohort(run_out)) == ["normal"]
    with pytest.raises(DatasetError, match="named 'normal', as .* is"):
        oftimg.load_cohort([run_out, tmp_path / "b2", run_out / "normal"])


def test_xarray_dataset_on_labelled_axes(run_out):
    pytest.importorskip("xarray")
    res = oftimg.load_results(run_out / "normal")
    ds = res.to_xarray()
    n_u, n_v, n_t = res["outer"].shape[:3]
    assert dict(ds.sizes) == {
        "u": n_u,
        "v": n_v,
        "v_clipped": n_v,
        "t": n_t,
        "xyz": 3,
        "stretch": 2,
        "crossing": 2,
        "uv": 2,  # uv: pathlines_uv
        "direction": 2,
    }  # the wave's velocity
    np.testing.assert_array_equal(ds["t"], res["t_ms"])
    np.testing.assert_array_equal(ds["s_mm"], res["s_mm"])
    np.testing.assert_allclose(ds["u"], np.arange(n_u) / n_u)
    assert ds["v"][0] == 0 and ds["v"][-1] == 1
    assert ds["area_outer_mm2"].attrs["units"] == "mm^2"
    assert ds["outer_clipped"].dims == ("u", "v_clipped", "t", "xyz")
    # labelled selection picks what indexing the arrays does
    t5 = float(res["t_ms"][5])
    np.testing.assert_array_equal(ds["area_outer_mm2"].sel(t=t5), res["area_outer_mm2"][:, 5])
    np.testing.assert_array_equal(
        ds["outer"].sel(xyz="z", u=0.0).isel(t=5), res["outer"][0, :, 5, 2]
    )
    np.testing.assert_array_equal(
        ds["principal_stretch_outer"].sel(stretch="l2"), res["principal_stretch_outer"][..., 1]
    )
    # the mean around the tube of the wall thickness, by dim name
    np.testing.assert_allclose(
        ds["wall_thickness_mm"].mean("u"), res["wall_thickness_mm"].mean(axis=0), rtol=1e-6
    )
    assert set(ds.data_vars) == {n for n in res.names if not n.startswith("pca_")} - {
        "s_mm",
        "t_ms",
    }
    only = res.to_xarray(["volume_outer_mm3"])
    assert list(only.data_vars) == ["volume_outer_mm3"] and only["t"].size == n_t
    pca = next(n for n in res.names if n.startswith("pca_"))
    with pytest.raises(KeyError, match="PCA"):
        res.to_xarray([pca])


def test_xarray_missing_says_how_to_install(run_out, monkeypatch):
    monkeypatch.setitem(sys.modules, "xarray", None)
    with pytest.raises(ImportError, match=r"oftimg\[xarray\]"):
        oftimg.load_results(run_out / "normal").to_xarray()


def test_cohort_maps_as_xarray(run_out, tmp_path):
    pytest.importorskip("xarray")
    ds = oftimg.load_cohort_maps(run_out)
    with np.load(run_out / "cohort_maps.npz") as npz:
        assert ds["embryo"].values.tolist() == npz["names"].tolist() == ["normal"]
        assert ds["group"].values.tolist() == ["normal"]
        np.testing.assert_array_equal(ds["position"], npz["position_fraction"])
        np.testing.assert_array_equal(ds["phase"], npz["cycle_fraction"])
        np.testing.assert_array_equal(
            ds["area_outer_mm2"].sel(embryo="normal"), npz["area_outer_mm2"][0]
        )
        assert ds.sizes["comparison"] == 0  # one group: nothing to compare
    assert ds["wall_thickness_mm"].attrs["units"] == "mm"
    assert ds["area_outer_normalized"].dims == ("embryo", "position", "phase")
    with pytest.raises(DatasetError, match="has no cohort_maps.npz"):
        oftimg.load_cohort_maps(tmp_path)


def test_results_are_stored_compressed_to_a_stated_precision(tmp_path):
    """float32 arrays are bit-rounded to 15 mantissa bits (relative error at most
    2^-16), NaN and infinities kept, other dtypes untouched; the npz is deflated."""
    import zipfile

    from oftimg.output.export import MANTISSA_BITS_KEPT, bit_round, write_npz

    rng = np.random.default_rng(0)
    x = (rng.normal(0, 3, 10000) * 10.0 ** rng.integers(-6, 6, 10000)).astype(np.float32)
    x[:3] = [np.nan, np.inf, -np.inf]
    stored = bit_round(x)
    finite = np.isfinite(x)
    assert np.nanmax(np.abs(stored[finite] / x[finite] - 1)) <= 2.0 ** -(MANTISSA_BITS_KEPT + 1)
    assert np.isnan(stored[0]) and stored[1] == np.inf and stored[2] == -np.inf
    assert (stored.view(np.uint32) & ((1 << (23 - MANTISSA_BITS_KEPT)) - 1) == 0).all()
    assert bit_round(np.arange(5.0)).dtype == np.float64  # float64 as it is
    grid = np.cumsum(rng.normal(0, 1e-3, (80, 50, 40, 3)), axis=2).astype(np.float32)
    write_npz(tmp_path / "a.npz", {"grid": bit_round(grid), "t": np.arange(40.0)})
    with np.load(tmp_path / "a.npz") as back:
        assert np.array_equal(back["grid"], bit_round(grid))
        assert np.array_equal(back["t"], np.arange(40.0))
    with zipfile.ZipFile(tmp_path / "a.npz") as zf:
        assert {i.compress_type for i in zf.infolist()} == {zipfile.ZIP_DEFLATED}
    assert (tmp_path / "a.npz").stat().st_size < 0.8 * grid.nbytes


def test_a_field_with_measured_noise_keeps_only_the_bits_above_a_tenth_of_it(tmp_path):
    """An array whose noise SD is known is stored to fewer mantissa bits, its largest
    rounding error under a tenth of that noise, and arrays.json says so; without a
    noise, 15 bits."""
    import json

    from oftimg.output.export import (
        MANTISSA_BITS_KEPT,
        NOISE_SHARE_KEPT,
        mantissa_bits,
        write_arrays,
    )

    rng = np.random.default_rng(1)
    field = (
        20 * np.sin(np.linspace(0, 6, 80 * 50 * 40)).reshape(80, 50, 40)
        + rng.normal(0, 0.5, (80, 50, 40))
    ).astype(np.float32)
    assert mantissa_bits(field, None) == MANTISSA_BITS_KEPT
    largest = float(np.abs(field).max())  # about 22
    assert mantissa_bits(field, 0.5) == 8  # ceil(log2(22 / 0.05)) - 1
    assert largest * 2.0**-9 <= 0.05 < largest * 2.0**-8
    described = {
        k: {"dims": ["u", "v", "t"], "unit": "1/mm", "description": k} for k in ("noisy", "exact")
    }
    write_arrays(
        tmp_path, {"arrays.npz": {"noisy": field, "exact": field}}, described, noise={"noisy": 0.5}
    )
    said = json.loads((tmp_path / "arrays.json").read_text())
    assert said["noisy"]["mantissa_bits"] == 8 and said["exact"]["mantissa_bits"] == 15
    assert said["noisy"]["noise_sd"] == 0.5 and "noise_sd" not in said["exact"]
    with np.load(tmp_path / "arrays.npz") as back:
        error = np.abs(back["noisy"].astype(float) - field).max()
        assert error <= said["noisy"]["rounding_error_max"] <= NOISE_SHARE_KEPT * 0.5
        assert np.abs(back["exact"].astype(float) - field).max() <= largest * 2.0**-16
    import zlib

    from oftimg.output.export import bit_round

    sizes = [len(zlib.compress(bit_round(field, bits).tobytes(), 1)) for bits in (8, 15)]
    assert sizes[0] < 0.8 * sizes[1]  # what the dropped bits cost zlib
