"""From label volumes to wall surfaces (issue 53, first part): masks per wall, a
segmentation's specks and pinholes cleaned, marching cubes with the voxel size, open
where the tube leaves the volume, outward."""
import numpy as np
import pytest

from oftimg.errors import InputError
from oftimg.mesh.labels import clean_mask, mesh_mask, wall_masks
from oftimg.mesh.topology import boundary_loops, capped_signed_volume, check_tube

LAYERS = {"myocardium": 1, "jelly": 2, "lumen": 3}


def tube_labels(voxel_um=(4.0, 4.0, 4.0), radii_um=(60.0, 45.0, 30.0), length_um=240.0,
                box_um=160.0):
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
    assert set(wall_masks(labels, {"myocardium": 1})) == {"outer"}     # one label: outer only
    with pytest.raises(InputError, match="not integers"):
        wall_masks(labels.astype(np.float32), LAYERS)


def test_an_open_tube_through_the_volume_with_the_right_volume():
    """Two boundary loops where the tube crosses the volume's faces (the first and the
    last voxel planes, z = 0 and (n - 1) dz), none elsewhere; outward; the enclosed
    volume within 3 % of the cylinder's (marching cubes on a bare binary mask cuts
    the corners of a 15-voxel radius by about 2 %)."""
    labels = tube_labels()
    for wall, radius in zip(("outer", "inner", "lumen"), (60.0, 45.0, 30.0)):
        V, F = mesh_mask(wall_masks(labels, LAYERS)[wall], (4.0, 4.0, 4.0))
        loops = boundary_loops(F)
        assert len(loops) == 2
        check_tube(V, F)
        ends = sorted(float(V[loop, 2].mean()) for loop in loops)
        assert ends[0] == pytest.approx(0.0) and ends[1] == pytest.approx(240.0 - 4.0)
        volume = capped_signed_volume(V, F, loops)
        assert 0 < volume == pytest.approx(np.pi * radius ** 2 * (ends[1] - ends[0]), rel=0.03)


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
    assert np.ptp(V[:, 0]) > 2 * np.ptp(V[:, 1])                  # stretched along x


def test_specks_and_pinholes_are_cleaned_and_counted():
    rng = np.random.default_rng(0)
    mask = wall_masks(tube_labels(), LAYERS)["outer"]
    noisy = mask.copy()
    from scipy import ndimage

    away = ~ndimage.binary_dilation(mask, iterations=2)             # not touching the tube
    candidates = np.flatnonzero(away)
    specks = np.unravel_index(rng.choice(candidates, 40, replace=False), noisy.shape)
    noisy[specks] = True                                           # islands in the background
    noisy[30, 20, 20] = False                                       # a pinhole inside
    cleaned, counts = clean_mask(noisy)
    assert counts.island_voxels == 40                               # every speck, removed
    assert counts.hole_voxels == 1 and cleaned[30, 20, 20]
    assert np.array_equal(cleaned, mask)
    V, F = mesh_mask(cleaned, (4.0, 4.0, 4.0))
    assert len(boundary_loops(F)) == 2
