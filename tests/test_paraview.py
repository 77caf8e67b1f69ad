"""ParaView export: closed, outward-facing quad grids and section rings carrying
the results' own numbers at the right times."""

import json
import shutil
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

import oftimg
from oftimg.cli import main
from oftimg.errors import DatasetError, InputError
from oftimg.output.export import describe_array
from oftimg.output.paraview import node_field_names, quad_cells, ring_segments, row_area_name


def _edge_uses(cells: np.ndarray) -> dict:
    """How many cells use each undirected edge of polygons ``cells (n, k)``."""
    a, b = cells.ravel(), np.roll(cells, -1, axis=1).ravel()
    keys, counts = np.unique(np.sort(np.stack([a, b], 1), axis=1), axis=0, return_counts=True)
    return dict(zip(map(tuple, keys), counts))


def _quad_normals(P: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Vector areas of quads (sum of the two triangles' cross products / 2)."""
    a, b, c, d = (P[quads[:, k]] for k in range(4))
    return 0.5 * (np.cross(b - a, c - a) + np.cross(c - a, d - a))


def test_cylinder_grid_is_closed_round_the_seam_and_faces_outwards():
    n_u, n_v, r, length = 24, 6, 0.2, 1.0
    u, v = np.meshgrid(np.arange(n_u) / n_u, np.linspace(0, 1, n_v), indexing="ij")
    # u clockwise looking from the inlet (z = 0) towards the outlet (+z)
    G = np.stack([r * np.cos(2 * np.pi * u), r * np.sin(2 * np.pi * u), length * v], -1)
    P, quads = G.reshape(-1, 3), quad_cells(n_u, n_v)
    assert quads.shape == (n_u * (n_v - 1), 4)
    uses = _edge_uses(quads)
    boundary = [e for e, k in uses.items() if k == 1]
    assert set(uses.values()) == {1, 2}
    # the only open edges are the two end rings: none along the seam
    assert len(boundary) == 2 * n_u
    assert {int(round(P[list(e), 2].mean() / length * (n_v - 1))) for e in boundary} == {0, n_v - 1}
    N = _quad_normals(P, quads)
    centre = P[quads].mean(axis=1)
    radial = centre * [1, 1, 0]
    assert np.all(np.einsum("ij,ij->i", N, radial) > 0)
    # the polygon's area: n_u chords of the circle times the length
    assert N.sum(axis=0) == pytest.approx(0, abs=1e-12)
    area = np.linalg.norm(N, axis=1).sum()
    assert area == pytest.approx(n_u * 2 * r * np.sin(np.pi / n_u) * length, rel=1e-12)


def test_ring_segments_close_each_ring():
    n_u, n_v = 7, 3
    seg = ring_segments(n_u, n_v)
    assert seg.shape == (n_u * n_v, 2)
    # every point starts one segment and ends one, both on its own ring (same j)
    assert np.array_equal(np.sort(seg[:, 0]), np.arange(n_u * n_v))
    assert np.array_equal(np.sort(seg[:, 1]), np.arange(n_u * n_v))
    assert np.all(seg[:, 0] % n_v == seg[:, 1] % n_v)


def test_each_wall_carries_its_own_node_fields_and_its_rows_areas():
    names = [
        "outer",
        "inner",
        "contour_inner_mm",
        "area_inner_mm2",
        "area_rows_inner_mm2",
        "radial_curvature_inner_per_mm",
        "strain_energy_inner",
        "principal_stretch_inner",
        "strain_energy_outer",
        "wall_thickness_mm",
        "phase_max_wall_thickness_mm_ms",
        "phase_min_strain_energy_inner_ms",
        "mean_curvature_lumen_per_mm",
        "jelly_thickness_mm",
        "phase_max_jelly_thickness_mm_ms",
    ]
    described = {
        n: dict(
            describe_array(n, map_positions="fixed"),
            file="grids.npz" if n in ("outer", "inner") else "arrays.npz",
        )
        for n in names
    }
    assert sorted(node_field_names(described, "inner")) == sorted(
        [
            "radial_curvature_inner_per_mm",
            "strain_energy_inner",
            "principal_stretch_inner",
            "wall_thickness_mm",
            "phase_max_wall_thickness_mm_ms",
            "phase_min_strain_energy_inner_ms",
            "jelly_thickness_mm",
            "phase_max_jelly_thickness_mm_ms",
        ]
    )
    assert "jelly_thickness_mm" not in node_field_names(described, "outer")
    assert node_field_names(described, "lumen") == ["mean_curvature_lumen_per_mm"]
    # maps resampled to fixed positions: the grid rows' own areas are area_rows_*
    assert row_area_name(described, "inner") == "area_rows_inner_mm2"
    assert row_area_name({"area_outer_mm2": {}}, "outer") == "area_outer_mm2"


def _steps(pvd):
    root = ET.parse(pvd).getroot()
    assert root.get("type") == "Collection"
    return [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]


@pytest.mark.slow
def test_paraview_series_hold_the_results(run_out, tmp_path):
    pv = tmp_path / "pv"
    assert main(["paraview", str(run_out), "--out", str(pv), "--quiet"]) == 0
    folder, out = run_out / "normal", pv / "normal"
    arrays, grids = np.load(folder / "arrays.npz"), np.load(folder / "grids.npz")
    t_ms = arrays["t_ms"]
    walls = ("outer", "inner", "lumen")
    expected = (
        {f"{g}.pvd" for g in grids.files}
        | {f"{w}_clipped.pvd" for w in walls}
        | {f"sections_{w}.pvd" for w in walls}
    )  # the clipped: made on load
    assert {p.name for p in out.glob("*.pvd")} == expected
    steps = _steps(out / "outer.pvd")
    assert [t for t, _ in steps] == pytest.approx(t_ms.tolist())
    n_u, n_v = grids["outer"].shape[:2]
    for t in (0, 17):
        m = meshio.read(out / steps[t][1])
        assert np.array_equal(m.points, grids["outer"][:, :, t].reshape(-1, 3))
        quads = m.cells_dict["quad"]
        assert len(np.unique(quads)) == n_u * n_v
        assert sum(k == 1 for k in _edge_uses(quads).values()) == 2 * n_u
        # outward: away from each row's section centroid
        centre = m.points[quads].mean(axis=1)
        row = quads[:, 0] % n_v
        away = centre - arrays["centroid_outer_mm"][row, t]
        assert np.mean(np.einsum("ij,ij->i", _quad_normals(m.points, quads), away) > 0) > 0.99
        for name in ("strain_energy_outer", "radial_curvature_outer_per_mm", "wall_thickness_mm"):
            assert np.array_equal(
                m.point_data[name], arrays[name][:, :, t].astype(np.float32).ravel()
            )
        assert np.array_equal(
            m.point_data["principal_stretch_outer"],
            arrays["principal_stretch_outer"][:, :, t].reshape(-1, 2).astype(np.float32),
        )
        area = m.point_data["area_outer_mm2"].reshape(n_u, n_v)
        assert np.array_equal(area[3], arrays["area_outer_mm2"][:, t].astype(np.float32))
        assert m.point_data["u"].reshape(n_u, n_v)[:, 0] == pytest.approx(np.arange(n_u) / n_u)
    # the wall thickness is the myocardium's: on outer and inner, not on the lumen; the
    # jelly's is measured from the inner nodes
    inner = meshio.read(out / _steps(out / "inner.pvd")[0][1]).point_data
    assert np.array_equal(
        inner["jelly_thickness_mm"], arrays["jelly_thickness_mm"][:, :, 0].ravel()
    )
    assert "wall_thickness_mm" in inner
    assert "jelly_thickness_mm" not in m.point_data
    lumen = meshio.read(out / _steps(out / "lumen.pvd")[0][1]).point_data
    assert "mean_curvature_lumen_per_mm" in lumen and "wall_thickness_mm" not in lumen
    # section rings: closed, and enclosing the section's measured area
    t = 9
    m = meshio.read(out / _steps(out / "sections_outer.pvd")[t][1])
    P = m.points.reshape(n_u, n_v, 3)
    ring_area = np.linalg.norm(0.5 * np.cross(P, np.roll(P, -1, axis=0)).sum(axis=0), axis=1)
    assert ring_area == pytest.approx(arrays["area_outer_mm2"][:, t], rel=0.02)


@pytest.mark.slow
def test_paraview_files_open_in_vtk_and_do_not_depend_on_jobs(run_out, tmp_path):
    vtk_xml = pytest.importorskip("vtkmodules.vtkIOXML")
    pv = tmp_path / "pv"
    assert main(["paraview", str(run_out / "normal"), "--out", str(pv), "--quiet"]) == 0
    reader = vtk_xml.vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(pv / "normal" / _steps(pv / "normal" / "inner.pvd")[5][1]))
    reader.Update()
    grid = reader.GetOutput()
    assert grid.GetNumberOfPoints() == 80 * 50 and grid.GetNumberOfCells() == 80 * 49
    assert grid.GetPointData().GetArray("strain_energy_inner").GetNumberOfTuples() == 4000
    # one process writes the same files as several
    serial = tmp_path / "serial"
    assert (
        main(["paraview", str(run_out / "normal"), "--out", str(serial), "--jobs", "1", "--quiet"])
        == 0
    )
    files = sorted(p.relative_to(pv) for p in pv.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(serial) for p in serial.rglob("*") if p.is_file())
    assert all((pv / f).read_bytes() == (serial / f).read_bytes() for f in files)


@pytest.mark.slow
def test_paraview_refuses_what_it_cannot_write(run_out, tmp_path):
    (tmp_path / "taken").mkdir()
    (tmp_path / "taken" / "mine.txt").write_text("keep me")
    with pytest.raises(InputError, match="not an empty folder"):
        oftimg.paraview(run_out, tmp_path / "taken", quiet=True)
    assert (tmp_path / "taken" / "mine.txt").read_text() == "keep me"
    with pytest.raises(DatasetError, match="no summary.json"):
        oftimg.paraview(tmp_path / "taken", tmp_path / "pv", quiet=True)
    copy = tmp_path / "copy"
    shutil.copytree(run_out / "normal", copy, ignore=shutil.ignore_patterns("videos", "*.png"))
    (copy / "grids.npz").unlink()
    with pytest.raises(DatasetError, match=r"copy: has no grids\.npz"):
        oftimg.paraview(copy, tmp_path / "pv", quiet=True)
    shutil.copy(run_out / "normal" / "grids.npz", copy / "grids.npz")
    (copy / "arrays.json").unlink()
    with pytest.raises(DatasetError, match=r"copy: has no arrays\.json"):
        oftimg.paraview(copy, tmp_path / "pv", quiet=True)
    assert not (tmp_path / "pv").exists()
    assert main(["paraview", str(copy), "--out", str(tmp_path / "pv")]) == 2
    assert json.loads((copy / "summary.json").read_text())["name"] == "normal"
