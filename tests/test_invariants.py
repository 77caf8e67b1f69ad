"""Invariants: what must not change when nothing physical changes, and what must
change with it.

A mesh's pose, vertex numbering, face order, corner order and per-face
orientation; where a periodic map's cycle starts (hypothesis); a whole embryo
moved, in other units, starting elsewhere in the cycle, played backwards,
entered from its other end, or 25 times larger.
"""

import json
import shutil

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from oftimg.image.kymograph import ridge_times, wave_speeds
from oftimg.image.masks import expanded_75, expanded_sigma
from oftimg.io.dataset import list_frames, load_dataset
from oftimg.io.meshfile import read_mesh_file, write_ply
from oftimg.mesh.grid import GridOptions, grid_frame, seam_endpoints
from oftimg.mesh.sections import section_planes, sections_of_mesh
from oftimg.mesh.topology import capped_signed_volume, check_tube
from oftimg.synthetic.phantom import Phantom, PhantomParams, sample_params, write_phantom
from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset

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
    assert not sections[3].any()  # every row cut from the mesh itself
    return V, topo.F, X, origins, normals, sections


@settings(max_examples=5, deadline=None)
@given(
    angles=st.tuples(*[st.floats(-np.pi, np.pi)] * 3),
    shift=st.tuples(*[st.floats(-5, 5)] * 3),
    seed=st.integers(0, 2**16),
)
def test_sections_do_not_depend_on_pose_numbering_or_face_order(bent_frame, angles, shift, seed):
    V, F, X, origins, normals, (area, centroid, contour, _) = bent_frame
    R, t = Rotation.from_euler("xyz", angles).as_matrix(), np.array(shift)
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(V))  # new vertex k is old vertex perm[k]
    new_index = np.argsort(perm)
    F2 = new_index[F][rng.permutation(len(F))]
    F2 = np.roll(F2, rng.integers(3), axis=1)  # same orientation, other first corner
    area2, centroid2, contour2, from_ring2 = sections_of_mesh(
        V[perm] @ R.T + t, F2, origins @ R.T + t, normals @ R.T, X @ R.T + t, N_C
    )
    assert not from_ring2.any()
    assert np.allclose(area2, area, rtol=1e-9)
    assert np.allclose(centroid2, centroid @ R.T + t, atol=1e-9)
    assert np.allclose(contour2, contour @ R.T + t, atol=1e-9)


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 2**16), share=st.floats(0.0, 1.0))
def test_check_tube_turns_any_mix_of_face_orientations_outward(bent_frame, seed, share):
    V, F = bent_frame[:2]
    rng = np.random.default_rng(seed)
    reversed_ = rng.random(len(F)) < share
    order = rng.permutation(len(F))
    F2 = np.where(reversed_[:, None], F[:, ::-1], F)[order]
    topo = check_tube(V, F2)
    assert topo.flipped_faces == int(reversed_.sum())  # exactly the faces turned inwards
    assert np.array_equal(topo.F, F[order])  # each face back as it was
    volume = capped_signed_volume(V, topo.F, list(topo.loops))
    assert volume > 0
    assert volume == pytest.approx(
        capped_signed_volume(V, F, list(check_tube(V, F).loops)), rel=1e-12
    )


PERIOD_MS, N_T = 100.0, 100


@settings(max_examples=20, deadline=None)
@given(
    speed=st.floats(3.0, 40.0),
    start_ms=st.floats(0.0, 100.0),
    width_ms=st.floats(4.0, 12.0),
    roll=st.integers(-2 * N_T, 2 * N_T),
)
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
    assert np.allclose(np.diff(ridge2), np.diff(ridge), atol=1e-9)  # unwrapped alike
    a, b = wave_speeds(s_mm, ridge), wave_speeds(s_mm, ridge2)
    assert np.allclose(b["local"], a["local"], rtol=1e-9)
    assert b["summary"] == pytest.approx(a["summary"], rel=1e-9)
    for key in ("knee_mm", "speed_proximal_mm_s", "speed_distal_mm_s"):
        assert getattr(b["knee"], key) == pytest.approx(getattr(a["knee"], key), rel=1e-9)
    assert np.allclose(expanded_75(rolled)[0], expanded_75(area)[0], atol=1e-12)
    assert np.allclose(expanded_sigma(rolled)[0], expanded_sigma(area)[0], rtol=1e-6)


def analyse(path):
    return analyse_dataset(load_dataset(path), PipelineOptions(), quiet=True)


@pytest.fixture(scope="module")
def embryo(tmp_path_factory):
    """A small phantom embryo (8 frames) and its analysis."""
    path = write_phantom(
        tmp_path_factory.mktemp("inv") / "first",
        sample_params("normal", 3, n_frames=8, vertices_min=2000, vertices_max=2500),
    )
    return path, analyse(path)


@pytest.mark.slow
@pytest.mark.parametrize("voxel_um", [None, (7.8, 7.8, 3.9)])
def test_an_embryo_moved_in_micrometres_starting_elsewhere_gives_the_same_numbers(
    embryo, tmp_path, voxel_um
):
    """The same beating tube, its frames starting two frames later in the cycle,
    turned and moved in space and written in micrometres (or in the indices of
    anisotropic voxels, as marching cubes on an OCT stack gives), gives every map,
    volume, speed and shape mode of the original (time is aligned to the minimum
    volume)."""
    first, a = embryo
    moved, later = tmp_path / "moved", 2
    R = Rotation.from_euler("xyz", (0.4, -1.1, 2.5)).as_matrix()
    shift = np.array([3.0, -7.0, 1.5])
    per_um = 1.0 / np.asarray(voxel_um or 1.0)
    for wall in ("outer", "inner", "lumen"):
        files = list_frames(first / wall)
        (moved / wall).mkdir(parents=True)
        for t in range(len(files)):
            V, F = read_mesh_file(files[(t + later) % len(files)])
            write_ply(moved / wall / f"f{t}.ply", 1e3 * (V @ R.T + shift) * per_um, F)
    meta = json.loads((first / "meta.json").read_text())
    meta.update(
        length_unit="um", inlet=(1e3 * (np.array(meta["inlet"]) @ R.T + shift) * per_um).tolist()
    )
    if voxel_um:
        meta["voxel_size"] = list(voxel_um)
    (moved / "meta.json").write_text(json.dumps(meta))

    b = analyse(moved)
    assert b["summary"]["t0_frame"] == (a["summary"]["t0_frame"] - later) % 8
    for key, x in a["arrays"].items():
        y = b["arrays"][key]
        if key.startswith(("centroid_", "plane_origin_", "contour_")):
            x = x.astype(float) @ R.T + shift
        elif key == "plane_normal":
            x = x @ R.T
        if not np.issubdtype(np.asarray(x).dtype, np.floating):
            assert np.array_equal(y, x), key
            continue
        assert np.array_equal(np.isnan(y), np.isnan(x)), key
        # time of each pixel's maximum on 8 frames: within 2 ms of a 300 ms cycle; the
        # lumen's mean curvature, from a cotangent Laplacian, to 1e-3 of its range
        # (all but 1 in 1000 pixels; those next to a sliver triangle, which amplifies the
        # files' float32 rounding, to 1e-2: measured 2e-3 once in 32000 in voxels)
        # the wave's velocity (the inverse of the activation times' gradient) and the times'
        # noise SD (over their first harmonic's amplitude): the
        # files' float32 rounding moves by up to 1.5e-4 of the largest where it is small
        tol = (
            2.0
            if key.startswith("phase_") and key.endswith("_ms")
            else 1e-3
            if key.startswith(("mean_curv", "wave_velocity_", "activation_"))
            else 1e-4
        )
        finite = np.isfinite(x)  # (a spread on 8 frames is NaN throughout)
        if not finite.any():  # (and a band: its noise needs 10 frames)
            continue
        error = np.abs(y - x)[finite] / max(1.0, np.abs(x[finite]).max(initial=0))
        if key.startswith("phase_") and not key.endswith("_ms"):  # radians: circular
            error = np.abs(np.angle(np.exp(1j * (y - x))))[finite] / np.pi
        if key.endswith("axis_deg"):  # an axis' direction: modulo 180 deg
            error = np.abs((y - x + 90) % 180 - 90)[finite] / 180
        if key.startswith(("mean_curv", "wave_velocity_", "activation_")):
            assert np.percentile(error, 99.9) <= tol and error.max() <= 10 * tol, key
        else:
            assert error.max(initial=0) <= tol, key
    for key, x in a["pca"].items():  # in each section's own plane: moves with it
        y = b["pca"][key]
        if key.endswith(("_scores", "_displacement_mm")):
            # the first mode; the others of 5 contours can have all but equal variances
            # (0.023 and 0.022 here), whose modes any rounding turns within their plane
            x, y = (x[:, 0], y[:, 0]) if key.endswith("_scores") else (x[0], y[0])
        assert np.allclose(y, x, atol=1e-4 * np.abs(x).max()), key
    numbers = (
        "wave_speed_mm_s",
        "tube_length_mm",
        "myocardial_volume_change",
        "expand_fraction",
        "section_volume_error",
    )
    for key in numbers:
        assert b["summary"][key] == pytest.approx(a["summary"][key], rel=1e-4, abs=1e-6), key
    for wall, X in a["grids"].items():
        assert np.allclose(b["grids"][wall], X @ R.T + shift, atol=1e-4), wall


@pytest.mark.slow
def test_an_embryo_played_backwards_has_its_wave_run_the_other_way(embryo, tmp_path):
    """The frames in reverse order: the same maps reversed in time, every wave speed
    of the same size and the other sign, expansion and contraction swapped, the
    expansion shares unchanged."""
    first, a = embryo
    backwards = tmp_path / "backwards"
    for wall in ("outer", "inner", "lumen"):
        files = list_frames(first / wall)
        (backwards / wall).mkdir(parents=True)
        for t, name in enumerate(files):
            shutil.copy(files[-1 - t], backwards / wall / name.name)
    shutil.copy(first / "meta.json", backwards / "meta.json")
    b = analyse(backwards)
    back = (-np.arange(8)) % 8
    for wall in ("outer", "inner", "lumen"):
        for key in (f"area_{wall}_mm2", f"volume_{wall}_mm3"):
            assert np.array_equal(b["arrays"][key][..., back], a["arrays"][key]), key
        for key in (f"expanded_fraction_75_{wall}", f"expanded_fraction_sigma_{wall}"):
            assert np.allclose(b["arrays"][key], a["arrays"][key], atol=1e-7), key
    period = a["summary"]["period_ms"]
    assert np.allclose(b["arrays"]["ridge_t_ms"], period - a["arrays"]["ridge_t_ms"], atol=1e-9)
    assert np.allclose(b["arrays"]["local_speed_mm_s"], -a["arrays"]["local_speed_mm_s"])
    speed, speed_back = a["summary"]["wave_speed_mm_s"], b["summary"]["wave_speed_mm_s"]
    assert speed_back["min"] == pytest.approx(-speed["max"])
    assert speed_back["max"] == pytest.approx(-speed["min"])
    for key in ("mean", "median", "cycle"):
        assert speed_back[key] == pytest.approx(-speed[key]), key
    assert speed_back["std"] == pytest.approx(speed["std"])
    knee, knee_back = a["summary"]["wave_two_segment"], b["summary"]["wave_two_segment"]
    for key in ("speed_proximal_mm_s", "speed_distal_mm_s"):
        assert knee_back[key] == pytest.approx(-knee[key]), key
    assert knee_back["knee_mm"] == pytest.approx(knee["knee_mm"])
    assert b["summary"]["expand_fraction"] == pytest.approx(a["summary"]["contract_fraction"])
    assert b["summary"]["t0_frame"] == 7 - a["summary"]["t0_frame"]


@pytest.mark.slow
def test_an_embryo_entered_from_its_other_end_is_the_same_tube_reversed(embryo, tmp_path):
    """meta.json's inlet at the other end: the grids run the other way along the tube
    and, to keep u clockwise seen from the inlet, around it (the seam stays at u = 0);
    the maps' rows come in reverse order, the volumes and length are the same, and
    every wave speed changes sign (the wave now runs towards the inlet)."""
    from oftimg.mesh.topology import loop_centroid

    first, a = embryo
    other = tmp_path / "other_end"
    shutil.copytree(first, other)
    meta = json.loads((first / "meta.json").read_text())
    tube = load_dataset(first).tube("outer", 0)
    meta["inlet"] = loop_centroid(tube.V[tube.outlet]).tolist()
    (other / "meta.json").write_text(json.dumps(meta))
    b = analyse(other)
    for wall in ("outer", "inner", "lumen"):
        G = b["grids"][wall]
        assert np.allclose(np.roll(G[::-1, ::-1], 1, axis=0), a["grids"][wall], atol=1e-6), wall
        assert np.allclose(
            b["arrays"][f"area_{wall}_mm2"][::-1], a["arrays"][f"area_{wall}_mm2"], rtol=1e-8
        ), wall
        assert np.allclose(
            b["arrays"][f"volume_{wall}_mm3"], a["arrays"][f"volume_{wall}_mm3"], rtol=1e-12
        ), wall
    assert b["summary"]["tube_length_mm"] == pytest.approx(a["summary"]["tube_length_mm"])
    speed, reversed_ = a["summary"]["wave_speed_mm_s"], b["summary"]["wave_speed_mm_s"]
    assert reversed_["min"] == pytest.approx(-speed["max"], rel=1e-6)
    assert reversed_["max"] == pytest.approx(-speed["min"], rel=1e-6)
    for key in ("mean", "median", "cycle"):
        assert reversed_[key] == pytest.approx(-speed[key], rel=1e-6), key


@pytest.mark.slow
def test_a_tube_25_times_larger_gives_every_number_in_proportion(embryo, tmp_path):
    """The same embryo 25 times larger (a vessel rather than an OFT): lengths x25,
    areas x625, volumes x25^3, speeds x25, curvatures / 25; strain, shares, times and
    counts unchanged. No tolerance of oftimg's is an absolute length."""
    first, a = embryo
    k, larger = 25.0, tmp_path / "larger"
    for wall in ("outer", "inner", "lumen"):
        (larger / wall).mkdir(parents=True)
        for name in list_frames(first / wall):
            V, F = read_mesh_file(name)
            write_ply(larger / wall / name.name, k * V, F)
    meta = json.loads((first / "meta.json").read_text())
    meta["inlet"] = [k * x for x in meta["inlet"]]
    (larger / "meta.json").write_text(json.dumps(meta))
    b = analyse(larger)
    units = (("_mm2", 2), ("_mm3", 3), ("_per_mm", -1), ("_mm_s", 1), ("_mm", 1))
    for key, x in a["arrays"].items():
        y = b["arrays"][key]
        if not np.issubdtype(np.asarray(x).dtype, np.floating):
            assert np.array_equal(y, x), key
            continue
        power = (
            0
            if key.startswith("phase_")
            else next((p for unit, p in units if key.endswith(unit) or unit + "_" in key), 0)
        )
        expected = x.astype(float) * k**power
        assert np.array_equal(np.isnan(y), np.isnan(expected)), key
        bound = 1e-3 * max(np.nanmax(np.abs(expected), initial=0), 1e-12)
        if key.startswith("phase_") and np.isfinite(expected).any():
            # a pixel whose field has two all but equal extrema over the beat may take either
            # (the lumen's mean curvature from its sections: 1 pixel in 4000 moved 200 ms)
            assert np.nanpercentile(np.abs(y - expected), 99.9) <= bound, key
            continue
        assert np.nanmax(np.abs(y - expected), initial=0) <= bound, key
    for key in ("mean", "median", "cycle"):
        assert b["summary"]["wave_speed_mm_s"][key] == pytest.approx(
            k * a["summary"]["wave_speed_mm_s"][key], rel=1e-5
        )
    assert b["summary"]["corner_count"] == a["summary"]["corner_count"]
