import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helpers import tube_mesh
from oftimg.mesh.geodesic import GeodesicSolver, insert_path, locate_on_edges
from oftimg.mesh.grid import (
    GridOptions,
    grid_frame,
    project_towards_axis,
    seam_endpoints,
    signed_thickness,
    smooth_angles,
)
from oftimg.mesh.parameterize import (
    FlatSampler,
    FlatTube,
    count_flipped,
    intrinsic_weights,
    seam_sides,
)
from oftimg.mesh.strain import grid_strain
from oftimg.mesh.topology import MeshError, check_tube
from oftimg.synthetic.phantom import Phantom, PhantomParams

OPTS = GridOptions(n_u=40, n_v=20)


def flat_patch(seed=0, n=12):
    """A jittered planar triangulated square (z = 0)."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    P = np.stack([x, y], -1).reshape(-1, 2)
    inner = (P > 0).all(1) & (P < 1).all(1)
    P[inner] += rng.uniform(-0.3, 0.3, (inner.sum(), 2)) / n
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    F = np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )
    return np.column_stack([P, np.zeros(len(P))]), F, inner


@pytest.mark.parametrize("w", [0.0, 0.5, 1.0])
def test_weights_reproduce_linear_functions_on_a_flat_patch(w):
    V, F, inner = flat_patch()
    W = intrinsic_weights(V, F, authalic_weight=w)
    residual = W @ V - np.asarray(W.sum(axis=1)) * V
    assert np.abs(residual[inner]).max() < 1e-10


def test_weights_refuse_bad_blend():
    V, F, _ = flat_patch()
    with pytest.raises(ValueError, match="authalic_weight"):
        intrinsic_weights(V, F, authalic_weight=1.5)


def test_solve_falls_back_to_pivoting_where_the_diagonal_fails():
    """The map's LU takes the diagonal as pivots (its Laplacians have a dominant one);
    where a pivot is tiny that goes wrong, and the residual check must send the
    system to SuperLU with partial pivoting."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from oftimg.mesh.parameterize import _solve

    n = 6
    A = sp.csc_matrix(sp.diags([np.ones(n - 1), np.full(n, 1e-18), np.ones(n - 1)], [-1, 0, 1]))
    rhs = np.random.default_rng(0).standard_normal((n, 2))
    unpivoted = spla.splu(
        A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
    ).solve(rhs)
    assert np.abs(A @ unpivoted - rhs).max() > 1.0  # the fast path alone fails here
    assert np.abs(A @ _solve(A, rhs) - rhs).max() < 1e-12


def test_count_flipped():
    UV = np.array([[0, 0], [1, 0], [0, 1.0]])
    assert count_flipped(UV, np.array([[0, 1, 2]])) == 0
    assert count_flipped(UV, np.array([[0, 1, 2], [0, 2, 1]])) == 1
    flat_ear = np.array([[0, 0], [0.5, 0], [1, 0.0]])  # three corners on the border
    assert count_flipped(np.vstack([UV, flat_ear]), np.array([[0, 1, 2], [3, 4, 5]])) == 0


@pytest.mark.parametrize("seed", [0, 1])
def test_flat_sampler_interpolates_linear_positions_exactly(seed):
    """Barycentric interpolation reproduces an affine (u, v) -> 3-D map at any
    point: inside triangles, on edges and vertices, on the square's border."""
    UV, F, _ = flat_patch(seed, n=9)
    UV = UV[:, :2]
    affine = np.array([[2.0, 0.5, -1.0], [0.3, -1.5, 0.25]])
    X = UV @ affine + [1.0, 2.0, 3.0]
    sample = FlatSampler(FlatTube(V=X, F=F, UV=UV, flipped=0))
    rng = np.random.default_rng(seed)
    u = np.concatenate([rng.uniform(0, 1, 3000), UV[:, 0], [0.0, 1.0, 0.5]])
    v = np.concatenate([rng.uniform(0, 1, 3000), UV[:, 1], [0.0, 1.0, 1.0]])  # scattered rows
    expected = np.clip(np.column_stack([u, v]), FlatSampler.EPS, 1 - FlatSampler.EPS) @ affine
    assert np.abs(sample(u, v) - expected - [1.0, 2.0, 3.0]).max() < 1e-12
    grid = sample(np.linspace(0, 1, 17)[:, None], np.linspace(0, 1, 5)[None, :])  # rows of equal v
    assert grid.shape == (17, 5, 3)
    uv = np.clip(
        np.stack(np.meshgrid(np.linspace(0, 1, 17), np.linspace(0, 1, 5), indexing="ij"), -1),
        FlatSampler.EPS,
        1 - FlatSampler.EPS,
    )
    assert np.abs(grid - uv @ affine - [1.0, 2.0, 3.0]).max() < 1e-12


def test_flat_sampler_falls_back_to_the_nearest_triangle_in_a_hole():
    UV, F, _ = flat_patch(0, n=9)
    UV = UV[:, :2]
    hole = F[40]
    sample = FlatSampler(
        FlatTube(
            V=np.column_stack([UV, np.zeros(len(UV))]), F=np.delete(F, 40, axis=0), UV=UV, flipped=0
        )
    )
    centre = UV[hole].mean(axis=0)
    X = sample(centre[0], centre[1])
    edge = np.linalg.norm(UV[hole] - np.roll(UV[hole], 1, axis=0), axis=1).max()
    assert np.isfinite(X).all() and 0 < np.linalg.norm(X[:2] - centre) < edge


def test_seam_sides_split_the_faces_along_the_seam():
    V, F = tube_mesh(0.2, n_theta=12, n_s=6)  # ring k holds vertices 12 k .. 12 k + 11
    chain = np.arange(6) * 12  # the straight line theta = 0
    high = seam_sides(F, chain)
    touching = np.isin(F, chain).any(axis=1)
    assert touching[high].all() and 0 < high.sum() < touching.sum()
    angle = np.arctan2(V[F][..., 1], V[F][..., 0]).mean(axis=1)
    assert (angle[high] < 0).all() and (angle[touching & ~high] > 0).all()  # u = 1 is at -theta
    with pytest.raises(MeshError, match="split"):
        seam_sides(F, chain[:2])  # ends inside: one side all round
    with pytest.raises(MeshError, match="joined"):
        seam_sides(F, np.array([0, 25, 48]))  # 0 -> 25 is not an edge


def cylinder_grid(radius=0.2, length=1.0, theta0=0.3, **kw):
    V, F = tube_mesh(radius, length=length, n_theta=64, n_s=40, theta0=theta0, **kw)
    topo = check_tube(V, F)
    inlet, outlet = topo.loops if V[topo.loops[0], 2].mean() < 0.5 else topo.loops[::-1]
    # seam through the vertex at theta0 on both ends
    p_in = np.array([radius * np.cos(theta0), radius * np.sin(theta0), 0.0])
    p_out = p_in + [0, 0, length]
    return grid_frame(V, topo.F, inlet, outlet, p_in, p_out, OPTS), V


def test_cylinder_grid_is_exact():
    g, _ = cylinder_grid()
    X = g.X
    assert g.flipped == 0
    theta = np.arctan2(X[..., 1], X[..., 0])
    expect = 0.3 + 2 * np.pi * np.arange(40) / 40  # u increases clockwise seen from the inlet
    # u runs along e_v x n: at the seam n = (cos, sin, 0), e_v = z -> e_u = (-sin, cos, 0)
    dtheta = np.angle(np.exp(1j * (theta - expect[:, None])))
    assert np.abs(dtheta).max() < 0.01
    assert np.allclose(X[..., 2], np.linspace(0, 1, 20)[None, :], atol=2e-3)
    assert np.allclose(np.linalg.norm(X[..., :2], axis=-1), 0.2, atol=1e-3)
    assert g.seam_length_mm == pytest.approx(1.0, rel=1e-3)


def inner_cylinder(radius, length=1.0, n_theta=37, theta0=1.0):
    """An inner wall meshed on its own: other resolution and start angle than the outer."""
    V, F = tube_mesh(radius, length=length, n_theta=n_theta, n_s=23, theta0=theta0)
    topo = check_tube(V, F)
    inlet, outlet = topo.loops if V[topo.loops[0], 2].mean() < length / 2 else topo.loops[::-1]
    return V, topo.F, inlet, outlet


def test_inner_wall_takes_the_outer_grid_towards_the_axis():
    """Concentric cylinders widening uniformly, the inner one meshed anew in each
    frame: each inner node at its outer node's angle and height (the end rows on
    the inner loops), and the inner grid's strain the analytic (r(t) / r(0) - 1)^2.
    Closest points on the facets put nodes up to 0.034 rad off, piled onto the
    edges nearest the outer wall, differently in each frame."""
    grids, scales, meshings = [], (1.0, 1.1, 1.25), ((37, 1.0), (41, 0.2), (33, 2.0))
    for scale, (n_theta, theta0) in zip(scales, meshings):
        X = cylinder_grid(radius=0.2 * scale)[0].X
        Xi, at_closest = project_towards_axis(
            *inner_cylinder(0.12 * scale, n_theta=n_theta, theta0=theta0), X
        )
        assert at_closest == 0
        angle = np.angle(
            np.exp(1j * (np.arctan2(Xi[..., 1], Xi[..., 0]) - np.arctan2(X[..., 1], X[..., 0])))
        )
        assert np.abs(angle).max() < 1e-4
        assert np.allclose(Xi[..., 2], X[..., 2], atol=1e-6)
        r = np.linalg.norm(Xi[..., :2], axis=-1) / (0.12 * scale)
        assert r.max() < 1 + 1e-6 and r.min() > np.cos(np.pi / n_theta) - 1e-6  # on facets
        grids.append(Xi)
    energy, stretch = grid_strain(np.stack(grids, axis=2))
    expected = (np.array(scales) - 1) ** 2
    # within the facets' sag (1 - cos(pi / 33) = 0.45 %); closest points: 0.31 and 0.36 off
    assert np.allclose(energy, expected, atol=4e-3)
    assert np.allclose(stretch[..., 0], np.array(scales), atol=0.01)  # around
    assert np.allclose(stretch[..., 1], 1, atol=1e-6)  # along


def test_the_inner_grid_goes_on_to_the_lumen_along_the_same_lines():
    """Three concentric cylinders (r = 0.2, 0.12, 0.07), each meshed on its own: the
    inner grid carried on towards the outer rows' centres meets the lumen at the
    same angle and height, 0.05 from the inner wall (within the facets' sag);
    towards any other centre, on the line from each inner node to it."""
    X = cylinder_grid(radius=0.2)[0].X
    Xi, _ = project_towards_axis(*inner_cylinder(0.12), X)
    lumen = inner_cylinder(0.07, n_theta=29, theta0=2.5)
    Xj, at_closest = project_towards_axis(*lumen, Xi, centre=X.mean(axis=0))
    assert at_closest == 0
    angle = np.angle(
        np.exp(1j * (np.arctan2(Xj[..., 1], Xj[..., 0]) - np.arctan2(X[..., 1], X[..., 0])))
    )
    assert np.abs(angle).max() < 1e-4 and np.allclose(Xj[..., 2], X[..., 2], atol=1e-6)
    jelly = np.linalg.norm(Xi - Xj, axis=-1)
    sag = 0.07 * (1 - np.cos(np.pi / 29)) + 0.12 * (1 - np.cos(np.pi / 37))
    assert np.all(np.abs(jelly - 0.05) <= sag + 1e-6) and np.abs(jelly - 0.05).max() > 1e-4
    centre = X.mean(axis=0) + np.array([0.03, -0.02, 0.0])
    Xj, _ = project_towards_axis(*lumen, Xi, centre=centre)
    towards, went = centre[None, 1:-1] - Xi[:, 1:-1], Xj[:, 1:-1] - Xi[:, 1:-1]
    off_line = np.linalg.norm(np.cross(towards, went), axis=-1) / np.linalg.norm(towards, axis=-1)
    assert off_line.max() < 1e-5 and np.einsum("...k,...k", towards, went).min() > 0


def test_where_the_walls_cross_the_node_goes_outwards_and_the_thickness_is_negative():
    """An inner wall (r = 0.12) bulging out to r = 0.23 through the outer one (0.2) on
    a patch: its nodes there are on the same lines, 0.03 outside the outer nodes
    (within the facets' sags): thickness -0.03; elsewhere 0.08 as before."""
    X = cylinder_grid(radius=0.2)[0].X  # 40 x 20 nodes, z = j / 19
    V, F, inlet, outlet = inner_cylinder(0.12, n_theta=73)
    theta = np.arctan2(V[:, 1], V[:, 0])
    patch = (np.abs(np.angle(np.exp(1j * (theta - 2.0)))) < 0.6) & (np.abs(V[:, 2] - 0.5) < 0.2)
    V[patch, :2] *= 0.23 / 0.12
    Xi, at_closest = project_towards_axis(V, F, inlet, outlet, X)
    assert at_closest == 0
    thickness = signed_thickness(X, Xi, X.mean(axis=0))
    node_theta = np.arctan2(X[..., 1], X[..., 0])
    inside = (np.abs(np.angle(np.exp(1j * (node_theta - 2.0)))) < 0.4) & (
        np.abs(X[..., 2] - 0.5) < 0.12
    )
    away = (np.abs(np.angle(np.exp(1j * (node_theta - 2.0)))) > 0.9) | (
        np.abs(X[..., 2] - 0.5) > 0.3
    )
    sag = 0.2 * (1 - np.cos(np.pi / 64)) + 0.23 * (1 - np.cos(np.pi / 73)) + 1e-5
    assert inside.sum() >= 12 and away.sum() > 400
    assert np.allclose(thickness[inside], -0.03, atol=sag)
    assert np.allclose(thickness[away], 0.08, atol=sag)
    angle = np.angle(np.exp(1j * (np.arctan2(Xi[..., 1], Xi[..., 0]) - node_theta)))
    assert np.abs(angle).max() < 1e-4 and np.allclose(Xi[..., 2], X[..., 2], atol=1e-6)
    # the distance's sign, on its own: towards the centre positive, away negative
    centre = np.zeros((1, 3))
    out, far = np.array([[[1.0, 0, 0]]]), np.array([[[1.5, 0, 0]]])
    assert signed_thickness(out, far, centre) == pytest.approx(-0.5)
    assert signed_thickness(far, out, centre) == pytest.approx(0.5)


def test_inner_nodes_with_no_wall_on_the_way_take_the_closest_point():
    """An inner wall half as long as the outer one: the rows beyond its end meet no
    wall towards the axis and take its closest point, on its outlet rim; the
    last row goes onto its outlet loop all the same."""
    X = cylinder_grid()[0].X  # 40 x 20 nodes, z = j / 19
    Xi, at_closest = project_towards_axis(*inner_cylinder(0.12, length=0.5), X)
    beyond = np.nonzero(X[0, 1:-1, 2] > 0.5)[0] + 1
    assert at_closest == 40 * len(beyond) > 0
    assert np.allclose(Xi[:, beyond, 2], 0.5, atol=1e-6)
    assert np.allclose(Xi[:, : beyond[0], 2], X[:, : beyond[0], 2], atol=1e-6)
    assert np.allclose(Xi[:, -1, 2], 0.5, atol=1e-6)


@pytest.mark.parametrize("shift", [0.0, 0.4])
def test_grid_values_interpolate_like_the_positions(shift):
    """A linear function of position, given per vertex, comes back at the grid nodes
    as that function of the nodes (the inserted loop points and seam crossings
    included: with ``shift`` the seam ends fall between loop vertices)."""
    V, F = tube_mesh(0.2, radius_out=0.12, n_theta=48, n_s=30, ellipse=0.7)
    topo = check_tube(V, F)
    inlet, outlet = topo.loops if V[topo.loops[0], 2].mean() < 0.5 else topo.loops[::-1]
    step = 2 * np.pi / 48
    p_in = 0.2 * np.array([np.cos(shift * step), 0.7 * np.sin(shift * step), 0.0])
    p_out = np.array([0.1, 0.05, 1.0])
    values = 3 * V[:, 0] - V[:, 1] + 0.5 * V[:, 2]
    g = grid_frame(V, topo.F, inlet, outlet, p_in, p_out, OPTS, values=values)
    assert g.values.shape == g.X.shape[:2]
    expect = 3 * g.X[..., 0] - g.X[..., 1] + 0.5 * g.X[..., 2]
    assert np.abs(g.values - expect).max() < 1e-12
    assert grid_frame(V, topo.F, inlet, outlet, p_in, p_out, OPTS).values is None


def test_cone_and_ellipse_grids_have_even_spacing():
    for kw in ({"radius_out": 0.1}, {"ellipse": 0.6}):
        V, F = tube_mesh(0.2, length=1.0, n_theta=64, n_s=40, **kw)
        topo = check_tube(V, F)
        inlet, outlet = topo.loops if V[topo.loops[0], 2].mean() < 0.5 else topo.loops[::-1]
        p_in, p_out, _ = seam_endpoints(V, topo.F, inlet, outlet)
        g = grid_frame(V, topo.F, inlet, outlet, p_in, p_out, OPTS)
        assert g.flipped == 0
        X = np.concatenate([g.X, g.X[:1]])
        du = np.linalg.norm(np.diff(X, axis=0), axis=-1)
        dv = np.linalg.norm(np.diff(g.X, axis=1), axis=-1)
        assert (du.max(0) / du.min(0)).max() < 1.1
        assert (dv.max(1) / dv.min(1)).max() < 1.3


def test_seam_is_a_surface_geodesic_not_an_edge_path():
    """On the bent phantom the seam hugs the inside of the bend and is as short as
    the analytic inside line (an edge path would be several % longer)."""
    ph = Phantom(
        PhantomParams(
            n_frames=4,
            contraction=0.0,
            corner_contracted=0.0,
            corner_expanded=0.0,
            ellipse_contracted=0.0,
            radius_inlet_mm=0.15,
            radius_outlet_mm=0.15,
        )
    )
    V, F = ph.mesh("outer", 0.0, np.random.default_rng(1))
    topo = check_tube(V, F)
    s0, _ = ph.window_coordinates(V[topo.loops[0]])
    inlet, outlet = topo.loops if s0.mean() < 0.5 else topo.loops[::-1]
    p_in, p_out, heat_length = seam_endpoints(V, topo.F, inlet, outlet)
    # inside line of a torus section: (R - r) * angle
    expected = (ph.p.bend_radius_mm - 0.15) * ph.p.length_mm / ph.p.bend_radius_mm
    assert heat_length == pytest.approx(expected, rel=0.02)  # heat distances run long
    ex_in, ex_out, length = seam_endpoints(V, topo.F, inlet, outlet, method="exact")
    assert length == pytest.approx(expected, rel=0.01)
    edge = np.median(np.linalg.norm(V[topo.F[:, 0]] - V[topo.F[:, 1]], axis=1))
    assert np.linalg.norm(ex_in - p_in) < 2 * edge and np.linalg.norm(ex_out - p_out) < 2 * edge
    _, th = ph.window_coordinates(np.array([p_in, p_out]))
    assert np.abs(th).max() < 0.2
    solver = GeodesicSolver(V, topo.F)
    a = int(np.argmin(np.linalg.norm(V - p_in, axis=1)))
    b = int(np.argmin(np.linalg.norm(V - p_out, axis=1)))
    path = solver.path(a, b)
    V2, F2, chain = insert_path(V, topo.F, locate_on_edges(V, topo.F, path, a, b))
    chain_len = np.linalg.norm(np.diff(V2[chain], axis=0), axis=1).sum()
    assert chain_len == pytest.approx(
        np.linalg.norm(np.diff(path, axis=0), axis=1).sum(), rel=1e-3
    )  # 2 % end snapping
    assert chain_len == pytest.approx(expected, rel=0.01)
    check_tube(V2, F2)  # still a valid, consistently oriented tube


def two_basin_tube(seed, n_theta=40, n_s=40):
    """A tube whose outlet loop has two dips (z = 1 - 0.05 cos 2theta - 0.004 cos theta):
    the shortest inlet-outlet geodesic is near theta = 0, 0.6 % shorter than the one
    near theta = pi. Near theta = 0 the rows are sheared by half a column, so that
    edge paths run several % longer there than near pi (jittered vertices)."""
    V, F = tube_mesh(radius_in=0.2, length=1.0, n_theta=n_theta, n_s=n_s)
    th, z = np.arctan2(V[:, 1], V[:, 0]), V[:, 2]
    rng = np.random.default_rng(seed)
    row = np.round(z * (n_s - 1)).astype(int)
    inner = (row > 0) & (row < n_s - 1)
    th = (
        th
        + (row % 2) * 0.5 * (2 * np.pi / n_theta) * np.clip(np.cos(th), 0, None) ** 2
        + inner * rng.uniform(-0.35, 0.35, len(th)) * 2 * np.pi / n_theta
    )
    z = (z + inner * rng.uniform(-0.35, 0.35, len(z)) / (n_s - 1)) * (
        1 - 0.05 * np.cos(2 * th) - 0.004 * np.cos(th)
    )
    V = np.column_stack([0.2 * np.cos(th), 0.2 * np.sin(th), z])
    topo = check_tube(V, F)
    inlet, outlet = sorted(topo.loops, key=lambda lp: V[lp, 2].mean())
    return V, topo.F, inlet, outlet


@pytest.mark.parametrize("seed", [0, 1, 3])
def test_seam_search_finds_the_shorter_of_two_basins(seed):
    """The Dijkstra arg-min alone lands in the wrong dip (near pi) on these meshes;
    every edge-path minimum within 10 % is polished, which finds the right one."""
    V, F, inlet, outlet = two_basin_tube(seed)
    exact = GeodesicSolver(V, F, method="exact").shortest_between(inlet, outlet)
    found = GeodesicSolver(V, F).shortest_between(inlet, outlet)
    theta = np.arctan2(V[list(found[:2]), 1], V[list(found[:2]), 0])
    assert np.abs(theta).max() < np.pi / 4
    assert found[2] == pytest.approx(exact[2], rel=0.005)


@pytest.mark.parametrize("rings", [8, 1])
def test_band_path_is_the_whole_mesh_path(rings, monkeypatch):
    """The edge-flip path on a band around the edge path is the whole mesh's path;
    with a band too thin to hold it (1 ring), the fallback gives it too."""
    import potpourri3d as pp3d

    import oftimg.mesh.geodesic as geodesic

    monkeypatch.setattr(geodesic, "BAND_RINGS", rings)
    _, V, F, inlet, outlet = phantom_frame()
    whole = pp3d.EdgeFlipGeodesicSolver(V, F)
    for a, b in [(inlet[0], outlet[0]), (inlet[7], outlet[20]), (inlet[3], inlet[9])]:
        expected = np.asarray(whole.find_geodesic_path(int(a), int(b)))
        if np.linalg.norm(expected[0] - V[a]) > np.linalg.norm(expected[-1] - V[a]):
            expected = expected[::-1]
        got = GeodesicSolver(V, F).path(a, b)
        assert got.shape == expected.shape and np.abs(got - expected).max() < 1e-12


def test_seam_angle_smoothing_is_periodic_and_wraps():
    theta = np.zeros(10)
    theta[0] = 0.3
    S = smooth_angles(theta, 1.0)
    assert S[9] == pytest.approx(S[1]) and S[9] > 0
    assert S.sum() == pytest.approx(0.3, rel=0.01)  # small angles: as numbers smooth
    near_pi = np.where(np.arange(10) % 2, np.pi - 0.05, -np.pi + 0.05)  # across +-pi
    assert np.abs(np.abs(smooth_angles(near_pi, 1.0)) - np.pi).max() < 0.05


def test_seam_angle_smoothing_never_crosses_a_jump():
    theta = np.where(np.arange(20) < 10, 0.0, 2.0)  # two runs, 2 rad apart
    S = smooth_angles(theta, 2.0)
    assert np.abs(S - theta).max() < 1e-9


# ----------------------------------------------------------- invariance properties
def phantom_frame(seed=2):
    ph = Phantom(PhantomParams(n_frames=4, vertices_min=2500, vertices_max=2500))
    V, F = ph.mesh("outer", 100.0, np.random.default_rng(seed))
    topo = check_tube(V, F)
    s0, _ = ph.window_coordinates(V[topo.loops[0]])
    inlet, outlet = topo.loops if s0.mean() < 0.5 else topo.loops[::-1]
    return ph, V, topo.F, inlet, outlet


def frame_grid(V, F, inlet, outlet):
    p_in, p_out, _ = seam_endpoints(V, F, inlet, outlet)
    return grid_frame(V, F, inlet, outlet, p_in, p_out, OPTS).X


@settings(max_examples=3, deadline=None)
@given(seed=st.integers(0, 2**16))
def test_grid_does_not_depend_on_vertex_order(seed):
    ph, V, F, inlet, outlet = phantom_frame()
    X0 = frame_grid(V, F, inlet, outlet)
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(V))
    inv = np.argsort(perm)
    X1 = frame_grid(V[perm], inv[F][rng.permutation(len(F))], inv[inlet], inv[outlet])
    assert np.abs(X1 - X0).max() < 1e-6


@settings(max_examples=3, deadline=None)
@given(angles=st.tuples(*[st.floats(-np.pi, np.pi)] * 3), shift=st.tuples(*[st.floats(-5, 5)] * 3))
def test_grid_moves_with_a_rigid_motion(angles, shift):
    from scipy.spatial.transform import Rotation

    ph, V, F, inlet, outlet = phantom_frame()
    X0 = frame_grid(V, F, inlet, outlet)
    R = Rotation.from_euler("xyz", angles).as_matrix()
    X1 = frame_grid(V @ R.T + shift, F, inlet, outlet)
    assert np.abs(X1 - (X0 @ R.T + shift)).max() < 1e-5


def test_grid_is_stable_under_refinement():
    ph = Phantom(PhantomParams(n_frames=4))
    grids = []
    for n in (3000, 9000):
        p = PhantomParams(n_frames=4, vertices_min=n, vertices_max=n)
        V, F = Phantom(p).mesh("outer", 100.0, np.random.default_rng(5))
        topo = check_tube(V, F)
        s0, _ = ph.window_coordinates(V[topo.loops[0]])
        inlet, outlet = topo.loops if s0.mean() < 0.5 else topo.loops[::-1]
        grids.append(frame_grid(V, topo.F, inlet, outlet))
    spacing = np.linalg.norm(np.diff(grids[1], axis=1), axis=-1).mean()
    assert np.abs(grids[0] - grids[1]).max() < 0.3 * spacing
