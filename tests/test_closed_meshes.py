"""A lumen given as meshes that the cushions close (issue 85): pieces found, filled into
voxels, joined inside the inner wall as one tube whose bridge is flagged; a lumen in
pieces in one frame alone is a segmentation's gap, filled from the frames around it."""

from __future__ import annotations

import numpy as np
import pytest

from oftimg.io.dataset import load_dataset
from oftimg.io.lumen_closures import bridged_dataset, closed_frames
from oftimg.io.meshfile import read_mesh_file, read_vertex_values, write_ply
from oftimg.mesh.closed_meshes import (
    capped,
    closed_lumen_from_meshes,
    continued_past_ends,
    is_closed_lumen,
    occupancy,
    surface_pieces,
)
from oftimg.mesh.labels import CLOSED_PROPERTY, MeshOptions
from oftimg.mesh.topology import capped_signed_volume, check_tube
from oftimg.synthetic.phantom import Phantom, sample_params, write_phantom


def _cylinder(radius=1.0, length=4.0, n_around=48, n_along=40, z0=0.0):
    """An open cylinder along z: ``(V, F)`` outward, its ends at z0 and z0 + length."""
    th = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
    z = np.linspace(z0, z0 + length, n_along)
    V = np.stack(
        np.broadcast_arrays(radius * np.cos(th)[None, :], radius * np.sin(th)[None, :], z[:, None]),
        -1,
    ).reshape(-1, 3)
    i = np.arange(n_along * n_around).reshape(n_along, n_around)
    a, b = i[:-1], np.roll(i, -1, axis=1)[:-1]
    c, d = np.roll(i, -1, axis=1)[1:], i[1:]
    F = np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )
    return V, F


def test_a_capped_cylinder_fills_its_volume_and_a_cut_one_is_two_pieces():
    V, F = _cylinder()
    side = 0.05
    mask = occupancy([capped(V, F)], np.array([-1.2, -1.2, -0.2]), side, (90, 49, 49))
    assert mask.sum() * side**3 == pytest.approx(np.pi * 4.0, rel=0.03)
    assert not is_closed_lumen(V, F)  # a tube
    z = V[F].mean(axis=1)[:, 2]
    cut = F[(z < 1.8) | (z > 2.2)]  # the middle gone: closed there
    assert len(surface_pieces(cut, len(V))) == 2 and is_closed_lumen(V, cut)
    Vc, Fc = capped(V, F[z < 3.0])  # closed up to one end: the
    inlet_centre = len(V) + np.flatnonzero(Vc[len(V) :, 2] < 0.1)  # inlet opened again
    assert is_closed_lumen(Vc, Fc[~np.isin(Fc, inlet_centre).any(axis=1)])


def test_a_mask_is_continued_past_an_end_as_its_end_section():
    mask = np.zeros((20, 10, 10), bool)
    mask[5:, 3:7, 2:6] = True  # the tube begins at z = 5
    planes = [(np.array([0.0, 0.0, 5.0]), np.array([0.0, 0.0, 1.0]))]
    out = continued_past_ends(mask, 1.0, planes, 3)
    assert (out[2:5] == mask[5]).all() and not out[:2].any()
    assert (out[5:] == mask[5:]).all()


def _volume(tube) -> float:
    return capped_signed_volume(tube.V, tube.F, [tube.inlet, tube.outlet])


@pytest.fixture(scope="module")
def cushion_phantom():
    return Phantom(
        sample_params(
            "normal",
            3,
            n_frames=24,
            cushion_aspect_expanded=0.6,
            cushion_aspect_contracted=-0.4,
            cushion_deg=30.0,
            cushion_from_mm=0.45,
            cushion_to_mm=0.75,
        )
    )


def test_a_lumen_in_pieces_is_joined_inside_the_inner_wall_with_its_bridge_flagged(cushion_phantom):
    ph = cushion_phantom
    t = ph.frame_times_ms()[0]  # closed mid-tube in this frame
    lumen = ph.voxel_mesh("lumen", t, 0.006)
    assert is_closed_lumen(*lumen)
    inner = ph.mesh("inner", t, np.random.default_rng(1))
    mesh = closed_lumen_from_meshes(lumen, inner, MeshOptions(), length_unit="mm")
    assert mesh is not None
    check_tube(mesh.V, mesh.F)  # one open tube
    s, _ = ph.window_coordinates(mesh.V)
    assert s.min() < 0.01 and s.max() > ph.p.length_mm - 0.01  # end to end
    # the bridge lies where the model is closed, and only about there
    shut = ph.cushion_aspect(s, t) <= 0
    assert mesh.closed.any() and shut[mesh.closed].mean() > 0.8
    assert mesh.closed[~shut & (np.abs(s - 0.6) > 0.25)].sum() == 0


def test_a_lumen_in_pieces_in_one_frame_alone_is_filled_and_named_a_repair(tmp_path):
    params = sample_params("normal", 4, n_frames=12, lumen_voxel_mm=0.008)
    data = write_phantom(tmp_path / "gap", params)
    ds = load_dataset(data)
    volume = Phantom(params).volume_mm3("lumen", Phantom(params).frame_times_ms())
    k = int(np.argmax(np.minimum(np.roll(volume, 1), np.roll(volume, -1))))  # wide open
    path = ds.frames["lumen"][k]
    V, F = read_mesh_file(path)
    s, _ = Phantom(params).window_coordinates(V[F].mean(axis=1))
    write_ply(path, V, F[(s < 0.5) | (s > 0.58)])  # the segmentation lost a stretch
    assert closed_frames(ds) == [k]
    joined = bridged_dataset(ds, tmp_path / "joined", MeshOptions())
    record = joined.lumen_bridged
    assert not record["closures"] and [r["frame"] for r in record["repaired"]] == [k]
    assert "a gap in the segmentation, not the cushions" in record["repaired"][0]["why"]
    filled = joined.tube("lumen", k)  # a tube, its files untouched
    assert joined.frames["lumen"][k].parent == tmp_path / "joined"
    assert joined.inputs_by_kind()["meshes"]["lumen"][k] == path
    neighbours = [_volume(joined.tube("lumen", (k + d) % 12)) for d in (-1, 1)]
    assert _volume(filled) == pytest.approx(np.mean(neighbours), rel=0.1)


def test_a_lumen_the_cushions_close_over_frames_is_bridged_not_filled(tmp_path):
    params = sample_params(
        "normal",
        3,
        n_frames=8,
        cushion_aspect_expanded=0.6,
        cushion_aspect_contracted=-0.4,
        cushion_deg=30.0,
        cushion_from_mm=0.45,
        cushion_to_mm=0.75,
        lumen_voxel_mm=0.008,
    )
    ds = load_dataset(write_phantom(tmp_path / "closing", params))
    closed = closed_frames(ds)
    assert len(closed) >= 3
    joined = bridged_dataset(ds, tmp_path / "joined", MeshOptions(), closed=closed)
    assert [r["frame"] for r in joined.lumen_bridged["closures"]] == closed
    assert not joined.lumen_bridged["repaired"]
    flags = read_vertex_values(joined.frames["lumen"][closed[0]], CLOSED_PROPERTY)
    assert flags is not None and 0 < flags.sum() < 0.2 * len(flags)


def test_a_slit_meshed_with_holes_through_it_is_joined_as_a_closure(tmp_path):
    """Zoo mesh draw 405 (frame 16 of 40): the lab-like mesh of a lumen closing to a slit
    is one piece open at both ends with handles where the slit's faces touch (Euler
    characteristic -2); it was refused, and is a closure to join."""
    from oftimg.io.lumen_closures import bridge_frame
    from oftimg.synthetic.zoo import draw_scenario

    p = draw_scenario(405, "meshes", n_frames=40, cushions=True).phantom
    ph = Phantom(p)
    t = ph.frame_times_ms()[16]
    V, F = ph.voxel_mesh("lumen", t, p.lumen_voxel_mm)
    with pytest.raises(Exception, match="Euler characteristic"):
        check_tube(V, F)
    assert is_closed_lumen(V, F)
    write_ply(tmp_path / "lumen.ply", V, F)
    write_ply(tmp_path / "inner.ply", *ph.mesh("inner", t, np.random.default_rng(0)))
    record = bridge_frame(
        16,
        {"lumen": str(tmp_path / "lumen.ply"), "inner": str(tmp_path / "inner.ply")},
        None,
        str(tmp_path / "joined.ply"),
        MeshOptions(),
        "mm",
    )
    assert isinstance(record, dict) and not record["repaired"]
    joined = read_mesh_file(tmp_path / "joined.ply")
    check_tube(*joined)
    assert read_vertex_values(tmp_path / "joined.ply", CLOSED_PROPERTY).sum() > 0
