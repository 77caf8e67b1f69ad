"""Material tracking (issue 51): rows turned with the tissue, against known turns and
against the truth of a real shape animated with a twist and a shortening."""

import json
from pathlib import Path

import numpy as np
import pytest

from oftimg.synthetic.animate import (
    Animation,
    grid_material_points,
    tissue_positions,
    write_animation,
)
from oftimg.analysis.tracking import follow, ring_turns, row_turns, sample, track_grid
from oftimg.io.dataset import load_dataset
from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset


def _bumpy_tube(n_u=80, n_v=30, n_t=12, turns=None):
    """An elliptic, bent tube's grid ``(n_u, n_v, n_t, 3)`` whose rows breathe in and out
    (the wave) and are turned against the tissue by ``turns (n_v, n_t)`` grid steps."""
    u = np.arange(n_u) / n_u
    v = np.linspace(0, 1, n_v)
    t = np.arange(n_t) / n_t
    U, Vv, T = np.meshgrid(u, v, t, indexing="ij")
    if turns is not None:
        U = U + turns[None] / n_u
    r = 0.2 * (1 + 0.3 * np.sin(np.pi * (T - 0.5 * Vv)) ** 4) * (1 + 0.15 * np.cos(4 * np.pi * U))
    bend = 0.6
    angle = Vv * 1.5
    centre = np.stack([bend * np.cos(angle), bend * np.sin(angle), 0 * angle], axis=-1)
    normal = np.stack([np.cos(angle), np.sin(angle), 0 * angle], axis=-1)
    binormal = np.array([0.0, 0.0, 1.0])
    phi = 2 * np.pi * U
    return centre + r[..., None] * (
        np.cos(phi)[..., None] * normal + np.sin(phi)[..., None] * binormal
    )


def test_ring_turns_find_a_known_turn_to_a_small_part_of_a_step():
    G = _bumpy_tube(n_t=1)[:, :, 0]
    shift = np.linspace(-30.0, 25.0, G.shape[1])  # steps, sub-step, both ways
    turned = _bumpy_tube(n_t=1, turns=shift[:, None])[:, :, 0]
    found, rms = ring_turns(G, turned)
    # turned(i + s) = G(i) where turned was made at u + shift: s = -shift
    assert np.abs(found + shift).max() < 0.02
    assert rms.max() < 0.01 * 0.2  # what is left: the rings sampled between nodes


def test_row_turns_take_out_the_grids_turns_and_jumps_but_not_the_wave():
    n_v, n_t = 30, 12
    rng = np.random.default_rng(0)
    turns = np.cumsum(rng.normal(0, 1.5, (n_v, n_t)), axis=1)
    turns[:, 0] = 0.0
    turns[n_v // 2 :, 5:8] += 20.0  # a seam that jumps
    G = _bumpy_tube(n_t=n_t, turns=turns)
    coords, info = track_grid(G)
    truth = _bumpy_tube(n_t=n_t)  # every node the same tissue
    tracked = follow(G, coords)
    assert np.abs(tracked - truth).max() < 2e-3 * 0.2
    assert info["closure_deg"]["max"] < 0.1
    assert info["ring_rms_mm"] < 0.5 * info["ring_rms_unturned_mm"]  # the rest: the wave


def test_a_round_still_tube_is_not_turned():
    G = np.repeat(_bumpy_tube(n_t=1)[:, :, :1], 6, axis=2)
    turn, info = row_turns(G)
    assert np.abs(turn).max() < 1e-9 and info["closure_deg"]["max"] < 1e-6


def test_sample_is_periodic_around_and_exact_at_the_nodes():
    rng = np.random.default_rng(1)
    field = rng.normal(size=(20, 8))
    i, j = np.meshgrid(np.arange(20.0), np.arange(8.0), indexing="ij")
    assert np.allclose(sample(field, np.stack([i, j], -1)), field, atol=1e-6)
    assert np.allclose(sample(field, np.stack([i + 20, j], -1)), field, atol=1e-6)


@pytest.fixture(scope="module")
def twisted_midgut(tmp_path_factory):
    """The 8k midgut animated over 40 remeshed frames: the wave, a twist of 20 degrees
    and a shortening of 15 %, each vertex traced to the static mesh."""
    mesh = Path(__file__).parent / "data" / "midgut_8k.ply"
    anim = Animation(
        speed_mm_s=1.5, amplitude=0.3, period_ms=360.0, n_frames=40, twist_deg=20.0, shortening=0.15
    )
    return write_animation(
        mesh,
        tmp_path_factory.mktemp("twist") / "midgut",
        anim,
        scale_to_mm=0.2619e-3,
        do_remesh=True,
        seed=0,
    )


def _drift(dataset, tracking):
    """Median drift of the grid's nodes from their tissue (% of the length), and over
    the tissue's own median displacement."""
    with pytest.warns(Warning):
        result = analyse_dataset(
            load_dataset(dataset), PipelineOptions(tracking=tracking), quiet=True
        )
    G, t0 = result["grids"]["outer"], result["summary"]["t0_frame"]
    S = grid_material_points(dataset, G, t0)
    drift = np.linalg.norm(S - S[:, :, :1], axis=-1)[:, :, 1:]
    P = tissue_positions(dataset, S[:, :, 0].reshape(-1, 3), t0)
    moved = np.linalg.norm(P - P[:, :1], axis=-1)[:, 1:]
    return (
        100 * np.median(drift) / result["summary"]["tube_length_mm"],
        np.median(drift) / np.median(moved),
        result["summary"],
    )


@pytest.mark.slow
def test_the_grid_follows_a_twisted_shortening_gut(twisted_midgut):
    """Measured: 0.55 % of the length and 0.22 x the tissue's motion (per-frame grid:
    1.01 % and 0.41 x); the issue's target, 0.2 x, is not reached (docs/accuracy.md)."""
    tracked, tracked_share, summary = _drift(twisted_midgut, "material")
    own, own_share, _ = _drift(twisted_midgut, "none")
    assert tracked < 0.7 and tracked_share < 0.25
    assert tracked < 0.65 * own and tracked_share < 0.65 * own_share
    assert summary["tracking"]["grid"] == "tracked"
    truth = json.loads((twisted_midgut / "truth.json").read_text())
    assert truth["animation"]["twist_deg"] == 20.0


def test_a_field_with_nan_rows_is_followed_with_nan_only_beside_them():
    """A closed lumen's rows are NaN in its curvature: following the field along the
    pathlines keeps them to their neighbours (the cubic spline's prefilter is global:
    unguarded, one NaN made the whole frame NaN)."""
    from oftimg.analysis.tracking import sample

    rng = np.random.default_rng(3)
    field = rng.random((80, 50))
    shut = field.copy()
    shut[:, 20:25] = np.nan
    at = np.stack(np.meshgrid(np.arange(80) + 0.3, np.arange(50) + 0.2, indexing="ij"), -1)
    read = sample(shut, at)
    assert np.flatnonzero(np.isnan(read).any(axis=0)).tolist() == [19, 20, 21, 22, 23, 24]
    far = np.r_[0:12, 33:50]  # 8 rows on: the spline feels them 0.27^8 as much
    assert np.allclose(read[:, far], sample(field, at)[:, far], atol=1e-3)
