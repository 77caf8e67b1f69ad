"""Invariants (hypothesis): what must not change when nothing physical changes.

A mesh's pose, vertex numbering, face order, corner order and per-face
orientation; where a periodic map's cycle starts.
"""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from oftimg.image.kymograph import ridge_times, wave_speeds
from oftimg.image.masks import expanded_75, expanded_sigma
from oftimg.mesh.grid import GridOptions, grid_frame, seam_endpoints
from oftimg.mesh.sections import section_planes, sections_of_mesh
from oftimg.mesh.topology import capped_signed_volume, check_tube
from oftimg.phantom import Phantom, PhantomParams

N_C = 60


@pytest.fixture(scope="module")
def bent_frame():
    """A phantom outer wall (bent, tapering, irregular triangles), its grid and
    section planes, and its sections in the pose it was made in."""
    ph = Phantom(PhantomParams(n_frames=4, vertices_min=2500, vertices_max=2500))
    V, F = ph.mesh("outer", 30.0, np.random.default_rng(3))
    topo = check_tube(V, F)
    s0, _ = ph.window_coordinates(V[topo.loops[0]])
    inlet, outlet = topo.loops if s0.mean() < 0.5 else topo.loops[::-1]
    p_in, p_out, _ = seam_endpoints(V, topo.F, inlet, outlet)
    X = grid_frame(V, topo.F, inlet, outlet, p_in, p_out, GridOptions(n_u=60, n_v=25)).X
    origins, normals = section_planes(X)
    sections = sections_of_mesh(V, topo.F, origins, normals, X, N_C)
    assert not sections[3].any()                       # every row cut from the mesh itself
    return V, topo.F, X, origins, normals, sections


@settings(max_examples=5, deadline=None)
@given(angles=st.tuples(*[st.floats(-np.pi, np.pi)] * 3),
       shift=st.tuples(*[st.floats(-5, 5)] * 3), seed=st.integers(0, 2 ** 16))
def test_sections_do_not_depend_on_pose_numbering_or_face_order(bent_frame, angles, shift,
                                                                seed):
    V, F, X, origins, normals, (area, centroid, contour, _) = bent_frame
    R, t = Rotation.from_euler("xyz", angles).as_matrix(), np.array(shift)
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(V))                     # new vertex k is old vertex perm[k]
    new_index = np.argsort(perm)
    F2 = new_index[F][rng.permutation(len(F))]
    F2 = np.roll(F2, rng.integers(3), axis=1)          # same orientation, other first corner
    area2, centroid2, contour2, from_ring2 = sections_of_mesh(
        V[perm] @ R.T + t, F2, origins @ R.T + t, normals @ R.T, X @ R.T + t, N_C)
    assert not from_ring2.any()
    assert np.allclose(area2, area, rtol=1e-9)
    assert np.allclose(centroid2, centroid @ R.T + t, atol=1e-9)
    assert np.allclose(contour2, contour @ R.T + t, atol=1e-9)


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 2 ** 16), share=st.floats(0.0, 1.0))
def test_check_tube_turns_any_mix_of_face_orientations_outward(bent_frame, seed, share):
    V, F = bent_frame[:2]
    rng = np.random.default_rng(seed)
    reversed_ = rng.random(len(F)) < share
    order = rng.permutation(len(F))
    F2 = np.where(reversed_[:, None], F[:, ::-1], F)[order]
    topo = check_tube(V, F2)
    assert topo.flipped_faces == int(reversed_.sum())  # exactly the faces turned inwards
    assert np.array_equal(topo.F, F[order])             # each face back as it was
    volume = capped_signed_volume(V, topo.F, list(topo.loops))
    assert volume > 0
    assert volume == pytest.approx(capped_signed_volume(V, F, list(check_tube(V, F).loops)),
                                   rel=1e-12)


PERIOD_MS, N_T = 100.0, 100


@settings(max_examples=20, deadline=None)
@given(speed=st.floats(3.0, 40.0), start_ms=st.floats(0.0, 100.0),
       width_ms=st.floats(4.0, 12.0), roll=st.integers(-2 * N_T, 2 * N_T))
def test_ridge_and_speeds_move_with_the_start_of_the_cycle(speed, start_ms, width_ms, roll):
    """Where the frames start in the cycle moves the ridge by that much, modulo a
    period, and changes no speed and no expansion share. The wave slows to half
    its speed beyond 0.3 mm, and swells along the tube."""
    s_mm = np.linspace(0.0, 0.6, 40)
    t = np.arange(N_T) * PERIOD_MS / N_T
    arrival = start_ms + 1e3 * (s_mm + np.maximum(0.0, s_mm - 0.3)) / speed
    dt = (t[None, :] - arrival[:, None] + PERIOD_MS / 2) % PERIOD_MS - PERIOD_MS / 2
    area = 1.0 + np.exp(-0.5 * (dt / width_ms) ** 2) * (1 + 0.3 * s_mm[:, None])
    rolled = np.roll(area, roll, axis=1)
    ridge, ridge2 = ridge_times(area, PERIOD_MS), ridge_times(rolled, PERIOD_MS)
    moved = ridge2 - ridge - roll * PERIOD_MS / N_T
    assert np.allclose(moved - PERIOD_MS * np.round(moved / PERIOD_MS), 0, atol=1e-9)
    assert np.allclose(np.diff(ridge2), np.diff(ridge), atol=1e-9)   # unwrapped alike
    a, b = wave_speeds(s_mm, ridge), wave_speeds(s_mm, ridge2)
    assert np.allclose(b["local"], a["local"], rtol=1e-9)
    assert b["summary"] == pytest.approx(a["summary"], rel=1e-9)
    for key in ("knee_mm", "speed_proximal_mm_s", "speed_distal_mm_s"):
        assert getattr(b["knee"], key) == pytest.approx(getattr(a["knee"], key), rel=1e-9)
    assert np.allclose(expanded_75(rolled)[0], expanded_75(area)[0], atol=1e-12)
    assert np.allclose(expanded_sigma(rolled)[0], expanded_sigma(area)[0], rtol=1e-6)
