"""What starting from label volumes costs: meshing time and memory (issue 53).

    python scripts/bench_labels.py [--frames 195] [--jobs 2] [--cache DIR] [--repeats N]
                                   [--big] [--intensity]

1. The bench embryo (the normal phantom, seed 0, 195 frames) as label volumes of
   4 x 4 x 8 um with segmentation noise, and the same phantom as meshes (5.5k
   vertices a wall; the labels meshed to as many): `oftimg.run` on each, back to back
   in this process; prints the
   wall seconds of each, the meshing's own seconds and what the labels add (the
   target: at most +30 %, issue 64; with --repeats N, meshes and labels alternate N
   times and the median ratio is given), and the peak memory of all processes together; and the
   labels again with the lumen's curvature taken from its mesh (``lumen_curvature_blur``
   0), to say what reading it from the level sets costs (target: at most +30 %).
2. With --big: 195 frames of 256 x 256 x 256 uint8 volumes (the phantom at 4.1 um
   isotropic, padded to 256 along z), run as labels; prints the peak memory of all
   processes together (target: under 2.5 GB) and the seconds.
3. With --intensity: the same label embryo with intensity volumes (the textured
   phantom: `oftimg phantom --labels --intensity`), run with its default texture
   tracking, against the labels alone (material tracking); prints what the pullbacks
   and the texture tracking add (target: at most +40 %) and the peak memory of all
   processes together (target: under 2 GB).
Peak memory is the sum of every process's proportional set size (scripts/bench.py).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import oftimg
from oftimg.synthetic.labels import LABEL_VALUES, LabelGrid, label_params, write_label_phantom
from oftimg.synthetic.phantom import Phantom, sample_params, write_phantom

sys.path.insert(0, str(Path(__file__).parent))
from bench import TreeMemory  # noqa: E402

BIG = 256
VERTICES = 5500  # a wall's vertices in the bench embryo


def bench_embryo(cache: Path, frames: int) -> tuple[Path, Path]:
    """The bench embryo as labels (4 x 4 x 8 um) and as meshes, the same phantom."""
    params = sample_params(
        "normal",
        0,
        n_frames=frames,
        vertices_min=int(0.9 * VERTICES),
        vertices_max=int(1.1 * VERTICES),
    )
    labels, meshes = cache / f"labels_{frames}f", cache / f"meshes_{frames}f"
    if not (labels / "truth.json").exists():
        write_label_phantom(labels, params, (4.0, 4.0, 8.0), noise=0.05)
    if not (meshes / "truth.json").exists():
        write_phantom(meshes, label_params(params))
    return labels, meshes


def textured_embryo(cache: Path, frames: int) -> Path:
    """The bench embryo as labels with intensity volumes (its tissue twisted as the
    textured phantom's is)."""
    from oftimg.synthetic.texture import TWIST_DEG

    path = cache / f"textured_{frames}f"
    if not (path / "truth.json").exists():
        params = sample_params("normal", 0, n_frames=frames, twist_deg=TWIST_DEG)
        write_label_phantom(path, params, (4.0, 4.0, 8.0), noise=0.05, intensity=True)
    return path


def big_series(cache: Path, frames: int) -> Path:
    """``frames`` volumes of 256^3 uint8 (zlib TIFF), the phantom at 4.1 um."""
    import tifffile

    path = cache / f"big_{frames}f"
    if (path / "meta.json").exists():
        return path
    ph = Phantom(label_params(sample_params("normal", 0, n_frames=frames)))
    grid = LabelGrid(ph, (4.1, 4.1, 4.1))
    nz, ny, nx = grid.shape
    if ny > BIG or nx > BIG or nz > BIG:
        raise SystemExit(f"the phantom's volume {grid.shape} does not fit {BIG}^3")
    below = (BIG - nz) // 2
    (path / "labels").mkdir(parents=True, exist_ok=True)
    for k, t in enumerate(ph.frame_times_ms()):
        volume = np.zeros((BIG, BIG, BIG), np.uint8)
        volume[below : below + nz, :ny, :nx] = grid.labels(t)
        tifffile.imwrite(path / "labels" / f"f{k:03d}.tif", volume, compression="zlib")
    inlet = (ph.frame_axes(0.0)[0] @ grid.turn + grid.shift) * 1e3 + [0, 0, below * 4.1]
    (path / "meta.json").write_text(
        json.dumps(
            {
                "period_ms": ph.p.period_ms,
                "length_unit": "um",
                "voxel_size": [4.1] * 3,
                "labels": LABEL_VALUES,
                "inlet": inlet.tolist(),
            }
        )
    )
    return path


def timed_run(path: Path, jobs: int, options: dict | None = None) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        tick = time.perf_counter()
        with TreeMemory() as tree:
            out = oftimg.run(path, Path(tmp) / "out", quiet=True, jobs=jobs, options=options)
        total = time.perf_counter() - tick
        summary = json.loads(next(out.glob("*/summary.json")).read_text())
    meshing = summary["provenance"].get("meshing")
    return {
        "total_s": total,
        "peak_all_processes_mb": tree.peak_mb,
        "meshing_s": meshing["seconds"] if meshing else 0.0,
        "vertices_median": (
            {w: int(np.median(v)) for w, v in meshing["vertices"].items()} if meshing else None
        ),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=195)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cache", type=Path, default=None)
    ap.add_argument(
        "--repeats",
        type=int,
        default=1,
        help="meshes and labels run alternately this many times each",
    )
    ap.add_argument("--big", action="store_true", help="also the 256^3 x 195 series")
    ap.add_argument(
        "--intensity",
        action="store_true",
        help="only what intensity volumes and texture tracking add",
    )
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        cache = args.cache or Path(tmp)
        cache.mkdir(parents=True, exist_ok=True)
        labels, meshes = bench_embryo(cache, args.frames)
        if args.intensity:
            return bench_intensity(labels, textured_embryo(cache, args.frames), args)
        # meshes and labels alternated, repeated: the machine's drift (30 % from hour to
        # hour) is seen in each, and the ratio is taken pair by pair
        pairs = []
        for _ in range(args.repeats):
            as_meshes = timed_run(meshes, args.jobs)
            # meshed to the meshes' size, so that the difference is the meshing's
            as_labels = timed_run(labels, args.jobs, {"meshing": {"target_vertices": VERTICES}})
            pairs.append((as_meshes, as_labels))
        # the lumen's curvature from its mesh, as before the level sets (issue 60)
        from_mesh = timed_run(
            labels,
            args.jobs,
            {"meshing": {"target_vertices": VERTICES, "lumen_curvature_blur": 0.0}},
        )
        print(f"bench embryo, {args.frames} frames, {args.jobs} jobs:")
        for as_meshes, as_labels in pairs:
            print(
                f"  as meshes: {as_meshes['total_s']:.1f} s, peak "
                f"{as_meshes['peak_all_processes_mb']:.0f} MB (all processes); as labels (4 x 4 "
                f"x 8 um): {as_labels['total_s']:.1f} s, of which meshing "
                f"{as_labels['meshing_s']:.1f} s; peak {as_labels['peak_all_processes_mb']:.0f} "
                f"MB: {100 * (as_labels['total_s'] / as_meshes['total_s'] - 1):+.0f} %"
            )
        added = [a["total_s"] / m["total_s"] - 1 for m, a in pairs]
        print(
            f"  labels add {100 * np.median(added):+.0f} % (median of {len(pairs)}; target: at "
            f"most +30 %); vertices per wall (median) {as_labels['vertices_median']}"
        )
        print(
            f"  as labels, the lumen's curvature from its mesh: {from_mesh['total_s']:.1f} s "
            f"(meshing {from_mesh['meshing_s']:.1f} s); the level sets add "
            f"{100 * (as_labels['total_s'] / from_mesh['total_s'] - 1):+.0f} % "
            "(target: at most +30 %)"
        )
        if args.big:
            big = timed_run(big_series(cache, args.frames), args.jobs)
            print(
                f"{args.frames} frames of {BIG}^3 uint8: {big['total_s']:.1f} s, of which meshing "
                f"{big['meshing_s']:.1f} s; peak {big['peak_all_processes_mb']:.0f} MB, all "
                "processes together (target: under 2500 MB)"
            )


def bench_intensity(labels: Path, textured: Path, args) -> None:
    """Part 3 of the module text: the labels alone against the labels with intensity."""
    options = {"meshing": {"target_vertices": VERTICES}}
    alone = timed_run(labels, args.jobs, options)
    textured_run = timed_run(textured, args.jobs, options)
    print(f"bench embryo, {args.frames} frames, {args.jobs} jobs, as labels (4 x 4 x 8 um):")
    print(
        f"  labels alone (material tracking): {alone['total_s']:.1f} s, peak "
        f"{alone['peak_all_processes_mb']:.0f} MB"
    )
    print(
        f"  with intensity volumes (pullbacks, texture tracking): {textured_run['total_s']:.1f} s, "
        f"peak {textured_run['peak_all_processes_mb']:.0f} MB (all processes)"
    )
    print(
        f"  intensity adds {100 * (textured_run['total_s'] / alone['total_s'] - 1):+.0f} % "
        "(target: at most +40 %)"
    )


if __name__ == "__main__":
    main()
