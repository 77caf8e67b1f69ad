"""MP4 videos of (u, v, t) fields and (v, t) maps (H.264, yuv420p: plays in browsers).

Frames are drawn with NumPy and OpenCV (colour map with an explicit range,
nearest-neighbour upscaling, a colour bar and the frame time in a corner) and
encoded by imageio-ffmpeg's bundled ffmpeg. This is the one place where arrays
in (u, v, t) order become video order (frames, rows, cols, 3): v runs up the
picture (inlet at the bottom), u to the right.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np
from matplotlib import colormaps


def to_rgb(values: np.ndarray, vmin: float, vmax: float, cmap: str = "jet") -> np.ndarray:
    """Colour-map ``values`` with the explicit range [vmin, vmax] to uint8 RGB
    (NaN: grey)."""
    span = vmax - vmin if vmax > vmin else 1.0
    x = np.clip((values - vmin) / span, 0.0, 1.0)
    rgb = colormaps[cmap](np.nan_to_num(x, nan=0.0))[..., :3]
    rgb[~np.isfinite(values)] = 0.5
    return np.round(rgb * 255).astype(np.uint8)


def _colour_bar(height: int, vmin: float, vmax: float, cmap: str, label: str) -> np.ndarray:
    bar = to_rgb(np.linspace(vmax, vmin, height)[:, None] * np.ones((1, 16)), vmin, vmax, cmap)
    panel = np.full((height, 112, 3), 255, np.uint8)
    panel[:, 4:20] = bar
    for text, y in ((f"{vmax:.3g}", 12), (f"{vmin:.3g}", height - 4)):
        cv2.putText(panel, text, (24, y), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 0, 0), 1, cv2.LINE_AA)
    for k, word in enumerate(label.split()[:4]):
        cv2.putText(panel, word, (24, height // 2 - 10 + 13 * k), cv2.FONT_HERSHEY_SIMPLEX, 0.36,
                    (0, 0, 0), 1, cv2.LINE_AA)
    return panel


def _even(img: np.ndarray, multiple: int = 16) -> np.ndarray:
    """Pad to a multiple of ``multiple`` pixels (H.264 macro blocks, even sizes)."""
    h, w = img.shape[:2]
    H, W = -(-h // multiple) * multiple, -(-w // multiple) * multiple
    out = np.full((H, W, 3), 255, np.uint8)
    out[:h, :w] = img
    return out


def field_frames(field: np.ndarray, t_ms: np.ndarray, *, vmin=None, vmax=None, cmap="jet",
                 label="", scale: int = 6, per_frame: bool = False):
    """Video frames ``(n_t, rows, cols, 3)`` uint8 of a ``(n_u, n_v, n_t)`` field.

    One colour range for the whole cycle (``vmin``/``vmax``, default the
    field's 1st and 99th percentiles), or with ``per_frame`` each frame's own.
    """
    finite = field[np.isfinite(field)]
    lo = np.percentile(finite, 1) if vmin is None else vmin
    hi = np.percentile(finite, 99) if vmax is None else vmax
    frames = []
    for t in range(field.shape[2]):
        img = field[:, :, t].T[::-1]  # rows: v (inlet at the bottom), cols: u
        if per_frame:
            f = img[np.isfinite(img)]
            lo, hi = (f.min(), f.max()) if f.size else (0.0, 1.0)
        rgb = cv2.resize(to_rgb(img, lo, hi, cmap), None, fx=scale, fy=scale,
                         interpolation=cv2.INTER_NEAREST)
        rgb = np.concatenate([rgb, _colour_bar(rgb.shape[0], lo, hi, cmap, label)], axis=1)
        cv2.putText(rgb, f"t = {t_ms[t]:.0f} ms", (6, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (255, 255, 255), 1, cv2.LINE_AA)
        frames.append(_even(rgb))
    return np.stack(frames)


def map_cursor_frames(area: np.ndarray, t_ms: np.ndarray, *, scale: int = 4, cmap="jet"):
    """Frames of a ``(n_v, n_t)`` map with a moving time cursor."""
    base = cv2.resize(to_rgb(area[::-1], np.nanmin(area), np.nanmax(area), cmap), None,
                      fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    base = np.concatenate([base, _colour_bar(base.shape[0], np.nanmin(area), np.nanmax(area),
                                             cmap, "area mm^2")], axis=1)
    frames = []
    for t in range(area.shape[1]):
        img = base.copy()
        x = int((t + 0.5) * scale)
        img[:, max(0, x - 1):x + 1] = 255
        cv2.putText(img, f"t = {t_ms[t]:.0f} ms", (6, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (255, 255, 255), 1, cv2.LINE_AA)
        frames.append(_even(img))
    return np.stack(frames)


def write_mp4(path: Path, frames: np.ndarray, *, fps: float = 30.0) -> Path:
    """Encode ``frames (n, rows, cols, 3) uint8`` as H.264/yuv420p MP4."""
    writer = imageio.get_writer(str(path), fps=fps, codec="libx264", pixelformat="yuv420p",
                                macro_block_size=16, quality=8, ffmpeg_log_level="error")
    try:
        for frame in frames:
            writer.append_data(frame)
    finally:
        writer.close()
    return path


def dataset_videos(folder: Path, arrays: dict, *, fps: float = 30.0) -> list[Path]:
    """All per-dataset videos into ``folder`` (``videos/``)."""
    from .image.normalize import per_pixel_normalize

    t_ms = arrays["t_ms"]
    out = []
    k = arrays.get("radial_curvature_outer_per_mm")
    if k is not None:
        out.append(write_mp4(folder / "radial_curvature_outer.mp4",
                             field_frames(k, t_ms, cmap="coolwarm", label="curvature 1/mm"),
                             fps=fps))
        out.append(write_mp4(folder / "radial_curvature_outer_normalized.mp4",
                             field_frames(per_pixel_normalize(k), t_ms, vmin=0, vmax=1,
                                          cmap="gray", label="per-pixel normalized"), fps=fps))
    e = arrays.get("strain_energy_outer")
    if e is not None:
        out.append(write_mp4(folder / "strain_energy_outer.mp4",
                             field_frames(e, t_ms, cmap="RdYlGn_r", label="strain energy"),
                             fps=fps))
        out.append(write_mp4(folder / "strain_energy_outer_per_frame.mp4",
                             field_frames(e, t_ms, cmap="RdYlGn_r", per_frame=True,
                                          label="strain energy (frame)"), fps=fps))
    h = arrays.get("mean_curvature_lumen_per_mm")
    if h is not None:
        out.append(write_mp4(folder / "mean_curvature_lumen.mp4",
                             field_frames(h, t_ms, cmap="coolwarm", label="mean curv. 1/mm"),
                             fps=fps))
    out.append(write_mp4(folder / "area_map_cursor.mp4",
                         map_cursor_frames(arrays["area_outer_mm2"], t_ms), fps=fps))
    return out
