"""A wall's mask mended to a solid tube (issue 60, first part): a handle, a tunnel
through the wall and a bridge across the lumen each stopped a whole run; the least
opening or closing that makes the mask a solid tube is found, and a clean mask is
left alone."""

import numpy as np
import pytest

from oftimg.mesh.mask_topology import core, euler, solid_tube_mask

SHAPE = (60, 40, 40)


def solid_tube(radius=12):
    """A solid cylinder along z leaving the volume through both z faces."""
    z, y, x = np.indices(SHAPE)
    return np.hypot(y - 20, x - 20) < radius


def with_handle():
    """A one-voxel strand looping out of the side, joined to it at two places."""
    mask = solid_tube()
    mask[20:41, 20, 33] = True  # along z, one voxel outside the wall
    mask[20, 20, 31:34] = True
    mask[40, 20, 31:34] = True
    return mask


def with_tunnel():
    """A hole of one voxel through the solid, across it."""
    mask = solid_tube()
    mask[30, 20, :] = False
    return mask


def with_bridge():
    """A thin slab of jelly across the lumen, with a gap: the lumen's mask is pierced."""
    mask = solid_tube()
    mask[30, 18:23, 5:35] = False
    return mask


def test_a_clean_tube_is_left_alone():
    mask = solid_tube()
    assert euler(mask) == 1
    out, repair = solid_tube_mask(mask)
    assert out is mask and repair is None


@pytest.mark.parametrize(
    "defect, what",
    [(with_handle, "opening, radius 1 voxel"), (with_tunnel, "closing"), (with_bridge, "closing")],
)
def test_a_handle_tunnel_or_bridge_is_mended_by_the_least_change(defect, what):
    mask = defect()
    assert euler(core(mask)) != 1
    out, repair = solid_tube_mask(mask)
    assert euler(out) == 1 and repair.what.startswith(what)
    assert repair.euler_before == euler(core(mask))
    assert 0 < repair.voxels == np.count_nonzero(out != core(mask))
    assert repair.voxels < 0.05 * mask.sum()
    # the tube keeps its shape: the same section away from the defect
    assert np.array_equal(out[5], solid_tube()[5]) and np.array_equal(out[-5], solid_tube()[-5])


def test_a_defect_too_large_to_mend_is_left_to_the_error():
    """A hole of 13 voxels across the tube, wider than the largest ball, stays: the
    caller refuses the frame, naming it."""
    mask = solid_tube()
    mask[25:38, 14:27, :] = False
    out, repair = solid_tube_mask(mask, max_radius=2)
    assert out is None and repair is None


def test_a_folded_lumen_a_voxel_apart_is_meshed_with_a_wider_blur():
    """The zoo's draw 101 (labels, the lumen eroded by a voxel, 7 % of boundary voxels
    flipped; frame 2): the lumen's mask is a solid tube, but its level set at the usual
    blur parts folds a voxel apart into handles, and 4 of 30 frames stopped the run.
    A blur of WIDER_BLUR voxels meshes it, and says so."""
    from pathlib import Path

    from oftimg.mesh.labels import WIDER_BLUR, MeshOptions, _mesh_or_mend, mesh_wall
    from oftimg.mesh.topology import MeshError, check_tube

    stored = np.load(Path(__file__).parent / "data" / "folded_lumen.npz")
    mask = (
        np.unpackbits(stored["packed"])[: np.prod(stored["shape"])]
        .reshape(stored["shape"])
        .astype(bool)
    )
    voxel = tuple(stored["voxel_um"])
    assert euler(core(mask)) == 1  # a solid tube in voxels
    with pytest.raises(MeshError, match="Euler characteristic"):
        mesh_wall(mask, voxel, MeshOptions())
    mesh, mended = _mesh_or_mend("lumen", mask, voxel, MeshOptions(), None)
    assert mended is None  # the voxels left as they were
    assert mesh.repair.what == f"level set blurred by {WIDER_BLUR:g} voxel"
    assert len(check_tube(mesh.V, mesh.F).loops) == 2
