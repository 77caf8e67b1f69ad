"""Texture tracking's own check on its match (issues 72, 86): the forward-backward gap
that predicted the grid's drift over the accuracy zoo, each node's support and the
share that fell back to the shape, and the warnings they give."""

import numpy as np
from scipy.ndimage import gaussian_filter

from oftimg.analysis.texture_tracking import (
    FALLBACK_WARN_SHARE,
    GAP_WARN_STEPS,
    fallback_note,
    texture_match_note,
    texture_pathlines,
)

N_U, N_V, FACTOR, N_T = 20, 12, 4, 6


def frames(moving_texture: bool, seed: int = 0) -> np.ndarray:
    """Pullbacks ``(n_u f, (n_v - 1) f + 1, n_t)``: one texture carried 1.5 fine pixels
    along the tube a frame, or a new random pattern every frame (nothing to follow)."""
    rng = np.random.default_rng(seed)
    shape = (N_U * FACTOR, (N_V - 1) * FACTOR + 1)
    base = gaussian_filter(rng.normal(size=(shape[0], shape[1] + 40)), 2.0, mode="wrap")
    out = []
    for t in range(N_T):
        if moving_texture:
            shift = 1.5 * t
            cols = np.arange(shape[1]) + 20 - shift
            left = np.floor(cols).astype(int)
            w = cols - left
            out.append((1 - w) * base[:, left] + w * base[:, left + 1])
        else:
            out.append(gaussian_filter(rng.normal(size=shape), 2.0, mode="wrap"))
    return np.stack(out, axis=-1).astype(np.float32)


def still() -> np.ndarray:
    """The shape's pathlines ``(N_U, N_V, N_T, 2)`` of a grid that does not turn."""
    nodes = np.stack(
        np.meshgrid(np.arange(N_U, dtype=float), np.arange(N_V, dtype=float), indexing="ij"),
        axis=-1,
    )
    return np.repeat(nodes[:, :, None], N_T, axis=2)


def test_a_texture_that_moves_is_matched_and_noise_is_not():
    """A texture carried along: the gap stays far under the warning's threshold and
    the nodes follow it (1.5 fine pixels a frame = 0.375 steps); a new pattern each
    frame: the gap over it, and the warning names it."""
    coords, found = texture_pathlines(frames(True), (FACTOR, FACTOR), still())
    gap = found["forward_backward_gap_steps"]["median"]
    assert gap < GAP_WARN_STEPS / 3 and texture_match_note(gap) is None
    middle = coords[5:15, 3:9]
    moved = middle[:, :, -1, 1] - middle[:, :, 0, 1]
    assert abs(np.median(moved) - 1.5 * (N_T - 1) / FACTOR) < 0.15
    assert found["fallback_share"] == 0 and fallback_note(found["fallback_share"]) is None
    assert np.median(found["support"]) > 0.9
    _, lost = texture_pathlines(frames(False), (FACTOR, FACTOR), still())
    gap = lost["forward_backward_gap_steps"]["median"]
    assert gap > GAP_WARN_STEPS
    assert "the texture matched poorly from frame to frame" in texture_match_note(gap)
    assert lost["fallback_share"] > FALLBACK_WARN_SHARE and np.median(lost["support"]) < 0.3
    assert "follow the shape alone" in fallback_note(lost["fallback_share"])
