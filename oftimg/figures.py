"""Figures of one dataset's results (matplotlib, no display needed).

Each function takes the arrays it draws and a path, and writes one PNG.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

WALL_COLOURS = {"outer": "#c0392b", "inner": "#e59866", "lumen": "#2e86c1",
                "myocardium": "#6c3483"}


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def volume_over_cycle(t_ms: np.ndarray, volumes_mm3: dict[str, np.ndarray], path: Path,
                      *, title: str = "") -> Path:
    """Volumes of each wall and the myocardium over the aligned cycle."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    for name, v in volumes_mm3.items():
        ax = axes[1] if name == "myocardium" else axes[0]
        ax.plot(t_ms, v, color=WALL_COLOURS.get(name, "k"), label=name, lw=1.6)
    for ax, what in zip(axes, ("volume inside each wall", "myocardial volume (outer - inner)")):
        ax.set_xlabel("time since minimum volume (ms)")
        ax.set_ylabel("volume (mm$^3$)")
        ax.set_title(what, fontsize=9)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def trim_over_cycle(t_ms: np.ndarray, trim_percent: np.ndarray, myocardial_mm3: np.ndarray,
                    path: Path, *, title: str = "") -> Path:
    """The paper's volume-normalisation figure: myocardial volume and trim distance."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    axes[0].plot(t_ms, myocardial_mm3, color=WALL_COLOURS["myocardium"])
    axes[0].set_ylabel("myocardial volume (mm$^3$)")
    axes[0].set_title("between outer and inner myocardium", fontsize=9)
    axes[1].plot(t_ms, trim_percent, color="k")
    axes[1].set_ylabel("trim distance (% of length)")
    axes[1].set_title("clipping for constant myocardial volume", fontsize=9)
    for ax in axes:
        ax.set_xlabel("time since minimum volume (ms)")
        ax.grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def frame_with_contours(grid_mm: np.ndarray, contours_mm: dict[str, np.ndarray], path: Path,
                        *, rows=(0.1, 0.5, 0.9), title: str = "") -> Path:
    """3-D view of one frame's outer grid with a few section contours of each wall.

    ``grid_mm (n_u, n_v, 3)``, ``contours_mm[wall] (n_c, n_v, 3)``.
    """
    fig = plt.figure(figsize=(6, 4.5))
    ax = fig.add_subplot(projection="3d")
    n_u, n_v, _ = grid_mm.shape
    for i in range(0, n_u, 4):
        ax.plot(*grid_mm[i].T, color="#bbb", lw=0.5)
    ax.plot(*grid_mm[0].T, color="#1f4e9c", lw=2, label="seam (u = 0)")
    for frac in rows:
        j = int(round(frac * (n_v - 1)))
        for wall, C in contours_mm.items():
            ring = np.concatenate([C[:, j], C[:1, j]])
            ax.plot(*ring.T, color=WALL_COLOURS[wall], lw=1.5,
                    label=wall if frac == rows[0] else None)
    ax.set_box_aspect(np.ptp(grid_mm.reshape(-1, 3), axis=0))  # true proportions
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title(title, fontsize=9)
    return _save(fig, path)


def dataset_figures(folder: Path, summary: dict, arrays: dict, grids: dict) -> list[Path]:
    """All per-dataset figures into ``folder`` (``figures/``)."""
    name = summary["name"]
    t_ms = arrays["t_ms"]
    written = []
    volumes = {w: arrays[f"volume_{w}_mm3"] for w in ("outer", "inner", "lumen")
               if f"volume_{w}_mm3" in arrays}
    if "volume_myocardium_mm3" in arrays:
        volumes["myocardium"] = arrays["volume_myocardium_mm3"]
    written.append(volume_over_cycle(t_ms, volumes, folder / "volume_over_cycle.png",
                                     title=name))
    if "trim_percent" in arrays:
        written.append(trim_over_cycle(t_ms, arrays["trim_percent"],
                                       arrays["volume_myocardium_mm3"],
                                       folder / "trim_over_cycle.png", title=name))
    contours = {w: arrays[f"contour_{w}_mm"][:, :, 0] for w in ("outer", "inner", "lumen")
                if f"contour_{w}_mm" in arrays}
    written.append(frame_with_contours(grids["outer"][:, :, 0], contours,
                                       folder / "frame_t0_contours.png",
                                       title=f"{name}: t = 0 (minimum volume)"))
    return written
