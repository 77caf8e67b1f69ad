"""Pictures for the README (docs/*.png), from the phantom and a demo run.

    python scripts/readme_figures.py [RESULTS_DIR] [--midgut MIDGUT_RESULTS]

``phantom_frame.png``: one phantom frame, all three walls, cut open to show
the nesting. ``grid_frame.png``: the outer wall's 80 x 50 grid of a demo
result (if RESULTS_DIR, a ``run`` output folder, is given).
``midgut.png``: grid and normalized area map of the animated Drosophila midgut::

    oftimg animate tests/data/midgut_8k.ply /tmp/mg --speed-mm-s 1.5 --frames 40 \
        --unit um --scale 0.2619 --remesh
    oftimg run /tmp/mg --out /tmp/mg_out
    python scripts/readme_figures.py --midgut /tmp/mg_out
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from oftimg.output.figures import WALL_COLOURS as COLOURS  # noqa: E402  (one per wall)
from oftimg.synthetic.phantom import Phantom, PhantomParams  # noqa: E402

DOCS = Path(__file__).resolve().parent.parent / "docs"


def phantom_frame(path: Path) -> None:
    ph = Phantom(PhantomParams(n_frames=10))
    t = 0.3 * ph.p.period_ms
    fig = plt.figure(figsize=(9, 3.8), dpi=100)
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    s = np.linspace(0, ph.p.length_mm, 60)
    th = np.linspace(0, 2 * np.pi, 90)
    S, T = np.meshgrid(s, th, indexing="ij")
    X = ph.point("outer", S, T, t)
    ax.plot_surface(
        X[..., 0], X[..., 1], X[..., 2], color=COLOURS["outer"], alpha=0.55, linewidth=0, shade=True
    )
    L = ph.point("lumen", S, T, t)
    ax.plot_surface(
        L[..., 0], L[..., 1], L[..., 2], color=COLOURS["lumen"], linewidth=0, shade=True
    )
    ax.set_box_aspect((1, 1, 0.45))
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.view_init(elev=35, azim=-60)
    ax.set_title(f"outer wall (translucent) and lumen, t = {t:.0f} ms", fontsize=9)
    ax2 = fig.add_subplot(1, 2, 2)
    s0 = 0.3 * ph.p.length_mm
    th = np.linspace(0, 2 * np.pi, 400)
    t_min = ph.arrival_ms(s0)
    for t_, style, label in (
        (t_min, "-", "contracted"),
        (t_min + ph.p.expand_fraction * ph.p.period_ms, "--", "expanded"),
    ):
        for wall in ("outer", "inner", "lumen"):
            r = ph.radius(wall, s0, th, t_)
            ax2.plot(
                r * np.sin(th), r * np.cos(th), style, color=COLOURS[wall], label=f"{wall}, {label}"
            )
    ax2.set_aspect("equal")
    ax2.set_xlabel("mm")
    ax2.set_ylabel("mm (theta = 0, inside of the bend, up)")
    ax2.set_title(f"cross-section at s = {s0:.2f} mm", fontsize=9)
    ax2.legend(fontsize=6, loc="center left", bbox_to_anchor=(1.0, 0.5))
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def grid_frame(results: Path, path: Path) -> None:
    name = sorted(p for p in results.iterdir() if (p / "grids.npz").exists())[0]
    X = np.load(name / "grids.npz")["outer"][:, :, 0].astype(float)
    fig = plt.figure(figsize=(6, 4), dpi=110)
    ax = fig.add_subplot(projection="3d")
    for i in range(0, X.shape[0], 2):
        ax.plot(*X[i].T, color="#888", lw=0.5)
    for j in range(0, X.shape[1], 2):
        ring = np.concatenate([X[:, j], X[:1, j]])
        ax.plot(*ring.T, color="#333", lw=0.5)
    ax.plot(*X[0].T, color="#1f4e9c", lw=2.5, label="seam u = 0 (shortest geodesic)")
    ax.set_box_aspect((1, 1, 0.45))
    for axis, letter in zip((ax.set_xlabel, ax.set_ylabel, ax.set_zlabel), "xyz"):
        axis(f"{letter} (mm)", fontsize=8)
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(f"{name.name}: 80 x 50 grid of the outer wall, frame t = 0", fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def midgut(results: Path, path: Path) -> None:
    """Grid of frame 0 and the area map normalized per row (chambers differ 100x in area)."""
    name = sorted(p for p in results.iterdir() if (p / "grids.npz").exists())[0]
    X = np.load(name / "grids.npz")["outer"][:, :, 0].astype(float) * 1e3  # um
    arr = np.load(name / "arrays.npz")
    fig = plt.figure(figsize=(10, 4), dpi=110)
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    for j in range(X.shape[1]):
        ring = np.concatenate([X[:, j], X[:1, j]])
        ax.plot(*ring.T, color="#333", lw=0.4)
    for i in range(0, X.shape[0], 4):
        ax.plot(*X[i].T, color="#999", lw=0.4)
    ax.plot(*X[0].T, color="#0072B2", lw=2.0, label="seam u = 0")
    ax.set_box_aspect(np.ptp(X.reshape(-1, 3), axis=0))
    ax.set_axis_off()
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0.02), fontsize=8, frameon=False)
    ax.set_title(
        "Drosophila midgut (Mitchell et al. 2022, CC BY 4.0):\n80 x 50 grid, frame 0", fontsize=9
    )
    ax2 = fig.add_subplot(1, 2, 2)
    area, s, t = arr["area_outer_mm2"], arr["s_mm"], arr["t_ms"]
    norm = area / np.nanmax(area, axis=1, keepdims=True)
    dt = t[1] - t[0]
    im = ax2.imshow(
        norm,
        origin="lower",
        aspect="auto",
        cmap="viridis",
        extent=(t[0] - dt / 2, t[-1] + dt / 2, s[0], s[-1]),
        interpolation="nearest",
    )
    fig.colorbar(im, ax=ax2, label="area / row maximum (0-1)")
    period = t[-1] + dt
    ax2.plot(
        np.mod(arr["ridge_t_ms"], period),
        s,
        "o",
        ms=2.5,
        mfc="w",
        mec="k",
        mew=0.4,
        label="maximum area",
    )
    ax2.set_xlabel("time since minimum volume (ms)")
    ax2.set_ylabel("position along the tube s (mm)")
    summary = __import__("json").loads((name / "summary.json").read_text())
    ax2.set_title(
        f"animated wave 1.5 mm/s; recovered {summary['wave_speed_mm_s']['cycle']:.2f} mm/s",
        fontsize=9,
    )
    ax2.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


if __name__ == "__main__":
    DOCS.mkdir(exist_ok=True)
    args = sys.argv[1:]
    if "--midgut" in args:
        k = args.index("--midgut")
        midgut(Path(args[k + 1]), DOCS / "midgut.png")
        del args[k : k + 2]
    phantom_frame(DOCS / "phantom_frame.png")
    if args:
        grid_frame(Path(args[0]), DOCS / "grid_frame.png")
