"""Arrays on named axes (u, v, t, then components) in image order, the one place
where oftimg turns them round for a file that shows them as pictures (videos, TIFF).

As the paper draws them: v runs up the image (inlet at the bottom row), and across
it u for a frame of a field, or t for a (v, t) map; time becomes the frames and a
component axis the channels."""

from __future__ import annotations

import numpy as np


def in_image_order(values: np.ndarray, dims: list[str]) -> tuple[np.ndarray, str]:
    """``values`` on axes ``dims`` (v and one of u or t, in the order u, v, t, then at
    most one component axis) as ``(image, axes)``: the axes of ``"TCYX"`` it has,
    as ImageJ names them; rows v from the outlet (top) to the inlet (bottom),
    columns u, or t when there is no u. A view of ``values``."""
    dims = list(dims)
    values = np.asarray(values)
    across = "u" if "u" in dims else "t"
    components = [d for d in dims if d not in ("u", "v", "t")]
    frames = ["t"] if "t" in dims and across == "u" else []
    names = frames + components + ["v", across]
    if values.ndim != len(dims) or sorted(names) != sorted(dims) or len(components) > 1:
        raise ValueError(
            f"no image has the axes {dims} (shape {values.shape}): it needs v, "
            "u or t, and at most one more"
        )
    image = np.transpose(values, [dims.index(name) for name in names])
    axes = "T" * len(frames) + "C" * len(components) + "YX"
    return np.flip(image, axis=-2), axes
