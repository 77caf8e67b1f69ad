"""Seconds to generate one paper-sized phantom embryo (195 frames x 3 walls).

    python scripts/bench_phantom.py [--frames 195] [--group normal]

Target: under 30 s on a 2-core machine. Prints meshing+writing and truth time.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from oftimg.synthetic.phantom import Phantom, sample_params, write_phantom


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--frames", type=int, default=195)
    ap.add_argument("--group", default="normal", choices=["normal", "banded"])
    args = ap.parse_args()
    params = sample_params(args.group, 0, n_frames=args.frames)
    with tempfile.TemporaryDirectory() as tmp:
        tick = time.perf_counter()
        write_phantom(Path(tmp) / "emb", params)
        total = time.perf_counter() - tick
        size = sum(p.stat().st_size for p in Path(tmp).rglob("*")) / 2**20
    tick = time.perf_counter()
    Phantom(params).truth()
    truth = time.perf_counter() - tick
    print(
        f"{args.frames} frames x 3 walls ({params.vertices_min}-{params.vertices_max} vertices "
        f"per mesh): {total:.1f} s in all (truth.json {truth:.1f} s), {size:.0f} MiB written; "
        f"target < 30 s"
    )


if __name__ == "__main__":
    main()
