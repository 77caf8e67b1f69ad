"""Rigid tubes meshed anew in every frame: nothing moves, so nothing may be measured
to move (issue 51's null test), and a tube that breathes all at once has no wave."""

import json

import numpy as np
import pytest

from helpers import retriangulated_tube, write_series
from oftimg.io.dataset import load_dataset
from oftimg.mesh.grid import SeamCandidates, continuous_seam_ends
from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset

N_FRAMES = 40


def _dataset(folder, meshes):
    write_series(folder, meshes)
    (folder / "meta.json").write_text(
        json.dumps(
            {"name": folder.name, "period_ms": 400.0, "length_unit": "mm", "inlet": [0, 0, 0]}
        )
    )
    return load_dataset(folder)


@pytest.fixture(scope="module", params=[2.0, 1.6], ids=["cylinder", "tapered"])
def still_tube(tmp_path_factory, request):
    rng = np.random.default_rng(1)
    meshes = [
        retriangulated_tube(rng, radius_in=2.0, radius_out=request.param) for _ in range(N_FRAMES)
    ]
    ds = _dataset(tmp_path_factory.mktemp("still") / "still", meshes)
    with pytest.warns(Warning):  # no ridge, fields all noise: said
        return analyse_dataset(ds, PipelineOptions(), quiet=True)


@pytest.mark.slow
def test_a_still_tube_keeps_its_seam_and_has_no_strain(still_tube):
    G = still_tube["grids"]["outer"]  # (n_u, n_v, n_t, 3), axis along z
    seam_angle = np.arctan2(G[0, :, :, 1], G[0, :, :, 0])
    spread = np.degrees(np.unwrap(seam_angle, axis=1).std(axis=1))
    assert np.median(spread) < 1.0 and spread.max() < 2.0
    assert still_tube["summary"]["seam_frames_continued"] >= N_FRAMES - 1
    energy = still_tube["arrays"]["strain_energy_outer"]
    assert np.nanmedian(energy) < 1e-3 and np.nanpercentile(energy, 99) < 1e-2
    speeds = dict(still_tube["summary"]["wave_speed_mm_s"])
    assert speeds.pop("rows_used") == 0 and all(np.isnan(v) for v in speeds.values())
    noise = still_tube["summary"]["field_noise"]["radial_curvature_outer_per_mm"]
    assert noise["noise_share"] > 0.8  # what varies over time is noise only


@pytest.mark.slow
def test_a_tube_breathing_at_once_has_no_wave(tmp_path):
    rng = np.random.default_rng(3)
    meshes = [
        retriangulated_tube(rng, radius_in=2.0 * (1 + 0.2 * np.sin(np.pi * k / N_FRAMES) ** 4))
        for k in range(N_FRAMES)
    ]
    ds = _dataset(tmp_path / "breathing", meshes)
    with pytest.warns(Warning, match="synchronous within noise"):
        result = analyse_dataset(ds, PipelineOptions(), quiet=True)
    summary = result["summary"]
    assert summary["wave_synchronous_within_noise"] is True
    speeds = dict(summary["wave_speed_mm_s"])
    assert speeds.pop("rows_used") == 0 and all(np.isnan(v) for v in speeds.values())
    assert np.isnan(summary["wave_two_segment"]["speed_proximal_mm_s"])
    assert np.isnan(result["arrays"]["local_speed_mm_s"]).all()


def _candidates(best_deg, lengths):
    """Seam candidates on unit loops around z (inlet at z = 0, outlet at z = 1): the
    shortest seam's ends at ``best_deg`` and every loop point's ``lengths``."""
    phi = np.radians(np.arange(0, 360, 5.0))
    loop = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=1)
    best = np.radians(best_deg)
    ends = np.array([[np.cos(best), np.sin(best), 0.0], [np.cos(best), np.sin(best), 1.0]])
    return SeamCandidates(best=ends, loops=(loop, loop + [0, 0, 1]), lengths=(lengths, lengths))


def test_a_flat_loop_continues_the_seam_of_frames_with_one_shortest():
    phi = np.radians(np.arange(0, 360, 5.0))
    bent = 1.0 + 0.3 * (1 - np.cos(phi - np.radians(40)))  # one shortest side, at 40 deg
    flat = np.ones_like(phi)  # every side ties
    frames = [_candidates(40, bent)] + [_candidates(b, flat) for b in (200, 10, 290)]
    p_in, p_out, chosen = continuous_seam_ends(frames, 0.0)
    angle = np.degrees(np.arctan2(p_in[:, 1], p_in[:, 0]))
    assert np.allclose(angle, 40, atol=0.5)
    assert chosen.tolist() == [False, True, True, True]
    assert np.allclose(p_out[:, 2], 1.0)


def test_two_equally_short_sides_are_ties_too():
    phi = np.radians(np.arange(0, 360, 5.0))
    bent = 1.0 + 0.3 * (1 - np.cos(phi - np.radians(40)))
    two = 1.0 + 0.3 * (1 - np.cos(2 * (phi - np.radians(40))))  # at 40 and 220 deg
    frames = [_candidates(40, bent), _candidates(220, two), _candidates(40, bent)]
    p_in, _, chosen = continuous_seam_ends(frames, 0.0)
    assert np.allclose(np.degrees(np.arctan2(p_in[:, 1], p_in[:, 0])), 40, atol=1.0)
    assert chosen.tolist() == [False, True, False]
