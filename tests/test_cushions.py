"""The lumen's ellipticity and closure (issue 85): analytic sections and area maps, and a
cushioned phantom's lumen measured against its model."""

from __future__ import annotations

import numpy as np
import pytest

from oftimg.analysis.cushions import (
    closed_map,
    closure_times,
    node_angles,
    section_ellipse,
    sector_means,
)
from oftimg.synthetic.phantom import Phantom, PhantomParams


def _ellipse(a, b, tilt_deg, start_deg, n=80, centre=(1.0, 2.0, 3.0)):
    """A planar ellipse (semi-axes a, b mm, major axis at tilt_deg) in a tilted plane,
    its points turning positively about the plane's normal from the point at start_deg
    (parameter angle); returns (points (n, 3), normal (3,), in-plane basis e1, e2)."""
    normal = np.array([0.3, -0.2, 1.0])
    normal /= np.linalg.norm(normal)
    e1 = np.cross(normal, [1.0, 0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    t = np.radians(start_deg) + np.linspace(0, 2 * np.pi, n, endpoint=False)
    x, y = a * np.cos(t), b * np.sin(t)
    c, s = np.cos(np.radians(tilt_deg)), np.sin(np.radians(tilt_deg))
    X, Y = c * x - s * y, s * x + c * y
    return np.asarray(centre) + X[:, None] * e1 + Y[:, None] * e2, normal, e1, e2


@pytest.mark.parametrize(
    "a, b, tilt, start", [(0.2, 0.05, 30, 0), (0.1, 0.07, -50, 40), (0.15, 0.15 * 0.02, 100, 200)]
)
def test_an_ellipse_gives_its_axes_ratio_and_the_major_axis_from_the_seam(a, b, tilt, start):
    C, normal, e1, e2 = _ellipse(a, b, tilt, start, n=400)
    aspect, major = section_ellipse(C, normal)
    assert aspect == pytest.approx(b / a, rel=1e-3)
    # the seam's direction: centroid to point 0, in the plane
    seam = np.degrees(np.arctan2((C[0] - C.mean(0)) @ e2, (C[0] - C.mean(0)) @ e1))
    expected = (tilt - seam) % 180
    assert abs((major - expected + 90) % 180 - 90) < 0.05


def test_a_circle_is_round_and_a_section_without_area_has_no_axes():
    C, normal, *_ = _ellipse(0.1, 0.1, 0, 0)
    aspect, _ = section_ellipse(C, normal)
    assert aspect == pytest.approx(1.0, abs=1e-9)
    flat = np.repeat(C[:1], 80, axis=0)  # a lumen closed to one point
    aspect, major = section_ellipse(flat, normal)
    assert np.isnan(aspect) and np.isnan(major)


def test_sections_broadcast_over_rows_and_frames():
    C1, n1, *_ = _ellipse(0.2, 0.1, 10, 0)
    C2, n2, *_ = _ellipse(0.2, 0.05, 10, 0)
    C = np.stack([np.stack([C1, C2], 1)] * 3, 2)  # (n_u, 2 rows, 3 frames, 3)
    aspect, _ = section_ellipse(C, np.broadcast_to(n1, (2, 3, 3)))
    assert aspect.shape == (2, 3)
    np.testing.assert_allclose(aspect, [[0.5] * 3, [0.25] * 3], rtol=2e-3)


def _slit_area(n_t, period, lag_ms, depth=0.5):
    """A lumen's area ``(n_t,)`` that falls to 0 at a steady pace (a slit closing) and
    stays 0 while the cosine is under -depth, ``lag_ms`` later than row 0's."""
    t = np.arange(n_t) * period / n_t
    phase = 2 * np.pi * (t - lag_ms) / period
    return np.maximum(np.cos(phase) + depth, 0.0)


def test_closure_times_and_share_of_a_lumen_closing_and_opening():
    n_t, period = 40, 360.0
    lags = np.array([0.0, 20.0, 47.0])
    area = np.stack([_slit_area(n_t, period, lag) for lag in lags])
    close, reopen, share = closure_times(area, period)
    x = np.degrees(np.arccos(-0.5)) / 360 * period  # area 0 at cos = -0.5
    np.testing.assert_allclose(close, (x + lags) % period, atol=0.01 * period)
    np.testing.assert_allclose(reopen, (period - x + lags) % period, atol=0.01 * period)
    np.testing.assert_allclose(share, 1 - 2 * x / period, atol=0.02)
    closed = closed_map(area)
    assert closed.shape == area.shape and closed.any(axis=1).all()


def test_rows_that_never_close_or_are_always_closed():
    area = np.array([[1.0, 0.8, 0.9, 1.0], [0.0, 0.0, 0.0, 0.0], [np.nan] * 4])
    close, reopen, share = closure_times(area, 100.0)
    assert np.isnan(close[0]) and np.isnan(reopen[0]) and share[0] == 0
    assert share[1] == 1 and share[2] == 1  # no lumen all cycle: closed
    assert closed_map(area)[1:].all() and not closed_map(area)[0].any()


def test_node_angles_and_the_sectors_about_an_axis():
    centre, normal, toward = np.zeros(3), np.array([0, 0, 1.0]), np.array([1.0, 0, 0])
    ang = np.radians(np.arange(0, 360, 10))
    P = np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], -1)
    deg = node_angles(P, centre, normal, toward)
    np.testing.assert_allclose(deg, np.arange(0, 360, 10), atol=1e-9)
    values = np.where(np.abs(np.sin(ang)) > 0.9, 2.0, 1.0)  # thick about 90 and 270 deg
    assert sector_means(values, deg, np.array(90.0)) == 2.0
    assert sector_means(values, deg, np.array(0.0)) == 1.0


def test_the_phantoms_cushions_make_its_lumen_an_ellipse_that_closes():
    """The model's truth: a lumen without folds or corners is the cushions' ellipse
    (its aspect, its axis at cushion_deg) and closes where the aspect reaches 0."""
    p = PhantomParams(
        n_frames=40,
        folds=0,
        corner_contracted=0.0,
        corner_expanded=0.0,
        ellipse_contracted=0.0,
        cushion_aspect_expanded=0.6,
        cushion_aspect_contracted=-0.3,
        cushion_deg=30.0,
        cushion_from_mm=0.4,
        cushion_to_mm=0.8,
    )
    P = Phantom(p)
    t = P.frame_times_ms()
    s = np.array([0.1, 0.6])
    aspect, major = P.section_ellipse("lumen", s[:, None], t[None, :])
    model = P.cushion_aspect(s[:, None], t[None, :])
    open_ = model > 0
    np.testing.assert_allclose(aspect[open_], model[open_], rtol=1e-3)
    np.testing.assert_allclose(major[open_], 30.0, atol=1e-6)
    assert np.isnan(aspect[~open_]).all() and (~open_[1]).any() and open_[0].all()
    assert (P.area_mm2("lumen", s[1], t[~open_[1]]) == 0).all()


def _tube_masks(gap=(20, 30), n=(50, 40, 40)):
    """A straight lumen (radius 6 voxels) along z inside an inner wall's mask (radius 12),
    the lumen closed (no voxel) between z = gap[0] and gap[1]."""
    z, y, x = np.indices(n)
    r2 = (y - n[1] / 2) ** 2 + (x - n[2] / 2) ** 2
    inner = r2 <= 12**2
    lumen = (r2 <= 6**2) & ~((z >= gap[0]) & (z < gap[1]))
    return lumen, inner


def test_a_lumen_in_two_pieces_is_bridged_through_the_closed_stretch_only():
    from oftimg.mesh.closure import bridged_lumen, lumen_pieces

    lumen, inner = _tube_masks()
    assert lumen_pieces(lumen)[1] == 2
    whole, bridge = bridged_lumen(lumen, inner, (4.0, 4.0, 4.0))
    assert lumen_pieces(whole)[1] == 1
    z = np.nonzero(bridge)[0]
    # the gap's voxels and, beside the pieces' ends, within the bridge's radius of them
    assert z.min() >= 18 and z.max() < 32 and bridge.sum() < 0.05 * lumen.sum()
    assert not (bridge & lumen).any() and not (bridge & ~inner).any()
    assert bridged_lumen(lumen | bridge, inner, (4.0, 4.0, 4.0)) is None  # one piece


def test_a_bridged_lumen_is_meshed_as_one_tube_whose_bridge_is_flagged():
    from oftimg.mesh.labels import MeshOptions, closed_lumen_mesh
    from oftimg.mesh.topology import boundary_loops

    lumen, inner = _tube_masks()
    mesh = closed_lumen_mesh(lumen, inner, (4.0, 4.0, 4.0), MeshOptions(), None)
    assert mesh is not None and len(boundary_loops(mesh.F)) == 2
    z_um = mesh.V[mesh.closed, 2]
    # the gap (z 80-116 um) and the pieces' ends the level set's blur rounds into it
    assert mesh.closed.any() and z_um.min() >= 16 * 4 and z_um.max() <= 33 * 4
    assert (mesh.V[mesh.closed, 2] > 19 * 4).mean() > 0.8
    assert mesh.closure["pieces"] == 2


def test_pieces_meeting_at_a_corner_are_two_and_their_bridge_survives_the_sampling():
    """Zoo cushion draw 417: a lumen whose pieces meet only at a voxel's corner is one
    piece to a 26-connected count but two surfaces to marching cubes; counted
    6-connected it is bridged, and the bridge, as thick as the level set's sampling
    (here 2-3 voxels), is meshed as one tube."""
    from oftimg.mesh.closure import lumen_pieces
    from oftimg.mesh.labels import MeshOptions, closed_lumen_mesh
    from oftimg.mesh.topology import boundary_loops

    lumen, inner = _tube_masks(gap=(20, 21))
    lumen[20] = False
    lumen[20, 21, 21] = True  # a corner's contact with z = 19's (20, 20)
    lumen[19] = False
    lumen[19, 14:27, 14:27] = _tube_masks()[0][0, 14:27, 14:27]
    lumen[19, 21, 21] = lumen[19, 21, 20] = lumen[19, 20, 21] = False
    assert lumen_pieces(lumen)[1] == 2
    mesh = closed_lumen_mesh(lumen, inner, (4.0, 4.0, 4.0), MeshOptions(target_vertices=2000), None)
    assert mesh is not None and len(boundary_loops(mesh.F)) == 2 and mesh.closed.any()


def _bent_tube(shape=(40, 120, 120), bend_voxels=60.0, radius=8.0):
    """Boolean masks (z, y, x) of a tube bent round a circle of ``bend_voxels`` (a
    quarter of it, from the face y = 0 to the face x = 0 ... as the phantom's): the
    solid ``inner`` (radius ``radius``) and its angle at each voxel (rad)."""
    z, y, x = np.indices(shape)
    r = np.hypot(y - shape[1], x - shape[2])  # about the far corner
    angle = np.arctan2(shape[1] - y, shape[2] - x)
    inner = np.hypot(r - bend_voxels, z - shape[0] / 2) <= radius
    return inner, angle


def test_a_lumen_in_pieces_round_a_bend_is_bridged_through_the_middle_of_the_inner_wall():
    """The pieces of a lumen closed over a long stretch of a bent tube: a straight chord
    between them leaves the inner wall and, kept inside it, falls in two (zoo cushion
    draw 402); the bridge follows the inner wall's middle and joins them."""
    from oftimg.mesh.closure import bridged_lumen, lumen_pieces

    inner, angle = _bent_tube()
    z, y, x = np.indices(inner.shape)
    core = np.hypot(np.hypot(y - 120, x - 120) - 60.0, z - 20) <= 4.0
    lumen = core & ((angle < 0.25) | (angle > np.pi / 2 - 0.25))  # closed between
    assert lumen_pieces(lumen)[1] == 2
    mask, bridge = bridged_lumen(lumen, inner, (4.0, 4.0, 4.0))
    assert lumen_pieces(mask)[1] == 1 and bridge.any()
    assert not (bridge & ~inner).any()


def test_a_lumen_closed_up_to_the_tubes_end_is_bridged_to_it():
    """A lumen closed from one end of the tube over a stretch reaches one face only: with
    the tube's ends (its inner wall's patches on the volume's faces) it is bridged to
    the other; without a closure it is left as it is."""
    from oftimg.mesh.closure import bridged_lumen, tube_ends

    inner, angle = _bent_tube()
    z, y, x = np.indices(inner.shape)
    core = np.hypot(np.hypot(y - 120, x - 120) - 60.0, z - 20) <= 4.0
    ends = tube_ends(inner, (4.0, 4.0, 4.0))
    assert len(ends) == 2
    assert bridged_lumen(core, inner, (4.0, 4.0, 4.0), ends=ends) is None  # open
    lumen = core & (angle > 0.5)  # closed from one end for 0.5 rad
    mask, bridge = bridged_lumen(lumen, inner, (4.0, 4.0, 4.0), ends=ends)
    for end in ends:  # the joined lumen reaches both faces
        assert mask[tuple(end.T)].any()
    assert bridged_lumen(lumen, inner, (4.0, 4.0, 4.0)) is None  # ends not asked
