"""From label volumes to wall surfaces (issue 53, first part): masks per wall, a
segmentation's specks and pinholes cleaned, marching cubes with the voxel size, open
where the tube leaves the volume, outward."""

import numpy as np
import pytest

from oftimg.errors import InputError
from oftimg.mesh.labels import MeshOptions, mesh_wall, wall_masks
from oftimg.mesh.topology import boundary_loops, capped_signed_volume, check_tube

LAYERS = {"myocardium": 1, "jelly": 2, "lumen": 3}


def mesh_mask(mask, voxel, **options):
    wall = mesh_wall(mask, voxel, MeshOptions(**options))
    return wall.V, wall.F


def tube_labels(
    voxel_um=(4.0, 4.0, 4.0), radii_um=(60.0, 45.0, 30.0), length_um=240.0, box_um=160.0
):
    """Three nested cylinders along z through the whole volume (z, y, x): myocardium
    outside, then jelly, then lumen."""
    dx, dy, dz = voxel_um
    z = (np.arange(int(round(length_um / dz))) + 0.5) * dz
    y = (np.arange(int(round(box_um / dy))) + 0.5) * dy - box_um / 2
    x = (np.arange(int(round(box_um / dx))) + 0.5) * dx - box_um / 2
    r = np.hypot(x[None, None, :], y[None, :, None]) + 0 * z[:, None, None]
    labels = np.zeros(r.shape, np.uint8)
    for value, radius in zip((1, 2, 3), radii_um):
        labels[r <= radius] = value
    return labels


def test_each_wall_encloses_its_layers():
    labels = tube_labels()
    masks = wall_masks(labels, LAYERS)
    assert masks["outer"].sum() > masks["inner"].sum() > masks["lumen"].sum() > 0
    assert set(wall_masks(labels, {"myocardium": 1})) == {"outer"}  # one label: outer only
    with pytest.raises(InputError, match="not integers"):
        wall_masks(labels.astype(np.float32), LAYERS)


def test_an_open_tube_through_the_volume_with_the_right_volume():
    """Two boundary loops where the tube crosses the volume's faces (the first and the
    last voxel planes, z = 0 and (n - 1) dz), none elsewhere; outward; the enclosed
    volume within 1.5 % of the mask's (its voxels' volume; on a bare binary mask,
    marching cubes cuts the corners of a 15-voxel radius by about 2 %) and within 3 %
    of the cylinder's (a 7.5-voxel disc of voxels is itself 2.7 % short)."""
    labels = tube_labels()
    for wall, radius in zip(("outer", "inner", "lumen"), (60.0, 45.0, 30.0)):
        mask = wall_masks(labels, LAYERS)[wall]
        V, F = mesh_mask(mask, (4.0, 4.0, 4.0))
        loops = boundary_loops(F)
        assert len(loops) == 2
        check_tube(V, F)
        ends = sorted(float(V[loop, 2].mean()) for loop in loops)
        assert ends[0] == pytest.approx(0.0) and ends[1] == pytest.approx(240.0 - 4.0)
        volume = capped_signed_volume(V, F, loops)
        assert 0 < volume == pytest.approx(np.pi * radius**2 * (ends[1] - ends[0]), rel=0.03)
        voxels = mask[1:-1].sum() * 4.0**3 + mask[[0, -1]].sum() * 4.0**3 / 2
        assert volume == pytest.approx(voxels, rel=0.015)


def test_anisotropic_voxels_give_the_same_tube_and_the_order_matters():
    """4 x 4 x 4 and 4 x 4 x 12 um voxels: mean section areas (volume over length)
    within 2 %; the voxel size given in the wrong order (z first) gives another tube,
    so a right answer is no accident."""

    def volume(voxel, given=None):
        V, F = mesh_mask(wall_masks(tube_labels(voxel), LAYERS)["outer"], given or voxel)
        return capped_signed_volume(V, F, boundary_loops(F)) / np.ptp(V[:, 2]), V

    fine, _ = volume((4.0, 4.0, 4.0))
    coarse, _ = volume((4.0, 4.0, 12.0))
    assert coarse == pytest.approx(fine, rel=0.02)
    wrong, V = volume((4.0, 4.0, 12.0), given=(12.0, 4.0, 4.0))
    assert abs(wrong / fine - 1) > 0.2
    assert np.ptp(V[:, 0]) > 2 * np.ptp(V[:, 1])  # stretched along x


def test_specks_and_pinholes_are_dropped_and_counted():
    """Specks of 3 voxels a side outside the wall and a pinhole cavity inside it
    each give a piece of surface of its own: dropped and counted. Specks of one
    voxel fall below the smoothed mask's level and leave no trace."""
    from scipy import ndimage

    rng = np.random.default_rng(0)
    mask = wall_masks(tube_labels(), LAYERS)["outer"]
    noisy = mask.copy()
    away = ndimage.binary_erosion(
        ~ndimage.binary_dilation(mask, iterations=4), iterations=3, border_value=0
    )
    corners = np.flatnonzero(away[:-3, :-3, :-3])
    placed = 0
    for flat in rng.permutation(corners):
        k, j, i = np.unravel_index(flat, np.array(mask.shape) - 3)
        block = noisy[k - 2 : k + 5, j - 2 : j + 5, i - 2 : i + 5]
        if k >= 2 and j >= 2 and i >= 2 and not block.any():
            noisy[k : k + 3, j : j + 3, i : i + 3] = True  # a speck, apart
            placed += 1
        if placed == 10:
            break
    singles = 0
    for flat in rng.permutation(np.flatnonzero(away)):
        k, j, i = np.unravel_index(flat, mask.shape)
        if min(k, j, i) >= 2 and not noisy[k - 2 : k + 3, j - 2 : j + 3, i - 2 : i + 3].any():
            noisy[k, j, i] = True  # a one-voxel speck, apart
            singles += 1
        if singles == 20:
            break
    noisy[28:32, 18:22, 18:22] = False  # a pinhole in the wall
    assert mask[28:32, 18:22, 18:22].all()
    wall = mesh_wall(noisy, (4.0, 4.0, 4.0))
    assert wall.cleaned.pieces == placed + 1 and wall.cleaned.vertices > 0
    clean = mesh_wall(mask, (4.0, 4.0, 4.0))
    assert clean.cleaned.pieces == 0
    check_tube(wall.V, wall.F)
    volume = capped_signed_volume(wall.V, wall.F, boundary_loops(wall.F))
    # the same wall (the specks' faces make the sampling a little finer)
    assert volume == pytest.approx(
        capped_signed_volume(clean.V, clean.F, boundary_loops(clean.F)), rel=0.02
    )


@pytest.mark.parametrize("shape", [(16, 21, 19), (2, 3, 5), (1, 7, 4)])
def test_the_blur_is_scipys_gaussian_with_the_border_continued(shape):
    """Along each axis, for a thin and a wide Gaussian, to float32's precision."""
    from scipy import ndimage

    from oftimg.mesh.labels import _blurred

    field = (np.random.default_rng(0).random(shape) > 0.5).astype(np.float32)
    for axis in range(3):
        for sigma in (0.5, 1.64):
            expected = ndimage.gaussian_filter1d(
                field, sigma, axis=axis, mode="nearest", truncate=3.0
            )
            assert np.allclose(_blurred(field, sigma, axis), expected, rtol=0, atol=3e-7)
