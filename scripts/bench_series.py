"""What a one-file 4-D series costs against files per frame (issue 83, point 5).

    python scripts/bench_series.py [--frames 195] [--repeats 2] [--cache DIR]

The label phantom (seed 0, 24 frames of 4 x 4 x 8 um, cycled to ``--frames``) written
twice: one 4-D OME-TIFF (``labels/labels.ome.tif``, zlib, axes TZYX and the voxel size
in its OME-XML) and one OME-TIFF per frame; each validated as ``oftimg validate`` does
(every frame's header checked, every frame meshed in this process), alternating (each
first in turn) ``--repeats`` times, back to back in this process. Prints each one's
seconds and the series' over the files' (the target: at most 1.3; opened afresh for
each frame, the series file was parsed whole again each time: 48 s to check 195
frames of 54 planes).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
import tifffile

from oftimg.inputs import validate_labels
from oftimg.synthetic.labels import write_label_phantom
from oftimg.synthetic.phantom import sample_params

VOXEL_UM = (4.0, 4.0, 8.0)


def write_both(root: Path, frames: int) -> tuple[Path, Path]:
    """The phantom's frames, cycled to ``frames``, as one OME-TIFF and as one per frame."""
    source = root / "phantom"
    if not source.is_dir():
        write_label_phantom(source, sample_params("normal", 0, n_frames=24), VOXEL_UM)
    volumes = [tifffile.imread(p) for p in sorted((source / "labels").iterdir())]
    meta = json.loads((source / "meta.json").read_text())
    meta = {k: v for k, v in meta.items() if k not in ("voxel_size", "axes", "period_ms")}
    meta["period_ms"] = 360.0 * frames / 24
    ome = {
        "PhysicalSizeX": VOXEL_UM[0],
        "PhysicalSizeY": VOXEL_UM[1],
        "PhysicalSizeZ": VOXEL_UM[2],
        **{f"PhysicalSize{a}Unit": "µm" for a in "XYZ"},
    }
    series, files = root / f"series_{frames}", root / f"files_{frames}"
    for folder in (series, files):
        (folder / "labels").mkdir(parents=True, exist_ok=True)
        (folder / "meta.json").write_text(json.dumps(meta))
    cycled = [volumes[k % len(volumes)] for k in range(frames)]
    if not (series / "labels" / "labels.ome.tif").is_file():
        tifffile.imwrite(
            series / "labels" / "labels.ome.tif",
            np.stack(cycled),
            ome=True,
            compression="zlib",
            metadata={"axes": "TZYX", **ome},
        )
    width = len(str(frames - 1))
    for k, volume in enumerate(cycled):
        path = files / "labels" / f"f{k:0{width}d}.ome.tif"
        if not path.is_file():
            tifffile.imwrite(
                path, volume, ome=True, compression="zlib", metadata={"axes": "ZYX", **ome}
            )
    return series, files


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=195)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--cache", type=Path, default=None, help="keep the datasets here")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = args.cache or Path(tmp)
        series, files = write_both(root, args.frames)
        seconds = {"series": [], "files": []}
        pair = [("series", series), ("files", files)]
        for repeat in range(args.repeats):
            for name, folder in pair[::-1] if repeat % 2 else pair:  # each first in turn
                tick = time.perf_counter()
                validate_labels(folder, quiet=True)
                seconds[name].append(time.perf_counter() - tick)
                print(f"{name}: {seconds[name][-1]:.1f} s", flush=True)
    ratio = np.median(np.array(seconds["series"]) / np.array(seconds["files"]))
    print(
        f"{args.frames} frames: one 4-D OME-TIFF {np.median(seconds['series']):.1f} s, "
        f"a file per frame {np.median(seconds['files']):.1f} s: {ratio:.2f} times"
    )


if __name__ == "__main__":
    main()
