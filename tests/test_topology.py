import numpy as np
import pytest

from helpers import tube_mesh
from oftimg.mesh.topology import edge_incidence


def test_edge_incidence_of_a_tube():
    V, F = tube_mesh(n_theta=12, n_s=5)
    edges, face_edge, counts, across = edge_incidence(F, faces=True)
    assert len(edges) == len(V) + len(F)  # Euler characteristic 0
    assert (counts == 1).sum() == 2 * 12  # the two end loops
    assert set(counts.tolist()) == {1, 2}
    assert np.all(edges[:, 0] < edges[:, 1])
    # face corner pair k -> k+1 is the edge named for it
    pairs = np.sort(np.stack([F, np.roll(F, -1, axis=1)], axis=2), axis=2)
    assert np.array_equal(edges[face_edge], pairs)
    # the faces of every edge use it, the first one has the lower index
    for e in (0, 7, len(edges) - 1):
        used = [f for f in across[e] if f >= 0]
        assert len(used) == counts[e]
        assert all(e in face_edge[f] for f in used)
        assert used == sorted(used)


def test_edge_incidence_with_huge_vertex_numbers_takes_the_stable_sort():
    """Vertex numbers so large that (key, half-edge) no longer fits one int64."""
    V, F = tube_mesh(n_theta=12, n_s=5)
    big = F * 15_000_000 + 12345  # n^2 < 2^63 <= n^2 x 3 n_face
    n = int(big.max()) + 1
    assert n**2 < 2**63 <= n**2 * F.size
    small, large = edge_incidence(F, faces=True), edge_incidence(big, faces=True)
    assert np.array_equal(large[0], small[0] * 15_000_000 + 12345)
    for a, b in zip(small[1:], large[1:]):
        assert np.array_equal(a, b)


def test_only_mend_drops_debris_and_fills_pinholes():
    from oftimg.mesh.topology import MeshError, check_tube, loop_centroid

    V, F = tube_mesh(0.2, 0.12, n_theta=48, n_s=40)  # faces of a hole: 10 % of an end
    blob = np.array([[1.0, 1, 1], [1.01, 1, 1], [1, 1.01, 1], [1, 1, 1.01]])
    V2 = np.concatenate([V, blob])
    debris = np.concatenate([F, len(V) + np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])])
    holed = np.delete(F, [100], axis=0)
    with pytest.raises(
        MeshError,
        match=rf"has 2 connected components \({len(F)}, 4 faces\); "
        "a tube has 1$",
    ):
        check_tube(V2, debris)
    with pytest.raises(MeshError, match="has 3 boundary loops; a tube has 2$"):
        check_tube(V, holed)
    assert check_tube(V, F).V is None  # nothing to mend: nothing new
    mended = check_tube(V2, debris, mend=True)
    assert (mended.islands, mended.island_faces, len(mended.V)) == (1, 4, len(V))
    assert np.array_equal(mended.F, F)
    filled = check_tube(V, holed, mend=True)
    assert (filled.holes, filled.hole_edges) == (1, 3)
    assert np.allclose(filled.V[-1], loop_centroid(V[F[100]]))  # the fan's centre
    assert check_tube(filled.V, filled.F).flipped_faces == 0  # one consistent orientation
    centre = V[F].mean(axis=1)
    wider = F[np.linalg.norm(centre - [0.16, 0, 0.5], axis=1) > 0.03]  # 46 % of an end
    used = np.unique(wider)
    with pytest.raises(
        MeshError,
        match=r"1 of the 1 beyond its ends is too large to fill as a "
        r"hole \(perimeter 0\.344 mm, 46% of the shorter end's "
        r"0\.753 mm",
    ):
        check_tube(V[used], np.searchsorted(used, wider), mend=True)
    with pytest.raises(
        MeshError,
        match=r"\(perimeter 344 µm, 46% of the shorter end's "
        r"753 µm",
    ):  # a label dataset's unit
        check_tube(1000 * V[used], np.searchsorted(used, wider), mend=True, length_unit="um")
    debris = np.concatenate([F, len(V) + F[:40]])  # a strip of wall apart: 1.1 %
    with pytest.raises(
        MeshError,
        match="parts apart from the largest are dropped while together under 1% of the faces",
    ):
        check_tube(np.concatenate([V, V + 1.0]), debris, mend=True)
