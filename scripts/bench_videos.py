"""Seconds to render and encode all videos of one 195-frame embryo.

    python scripts/bench_videos.py [--frames 195] [--jobs 2]

Uses the phantom model's analytic walls on an 80 x 50 grid (no meshing) and
synthetic fields of the real shapes. Target: under 20 s.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from oftimg.synthetic.phantom import Phantom, PhantomParams
from oftimg.workers import make_executor
from oftimg.output.video import dataset_videos


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--frames", type=int, default=195)
    ap.add_argument("--profile", action="store_true", help="print where the time goes")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (as oftimg run)")
    args = ap.parse_args()
    ph = Phantom(PhantomParams(n_frames=args.frames))
    n_u, n_v, n_t = 80, 50, args.frames
    t_ms = ph.frame_times_ms()
    s = np.linspace(0, ph.p.length_mm, n_v)[None, :, None]
    th = (2 * np.pi * np.arange(n_u) / n_u)[:, None, None]
    grids = {w: ph.point(w, s, th, t_ms[None, None, :]) for w in ("outer", "lumen")}
    # smooth fields like real ones: five corners around, a wave along, 2 % noise
    rng = np.random.default_rng(0)
    phase = 2 * np.pi * (t_ms[None, None, :] / ph.p.period_ms - s / ph.p.length_mm / 4)
    field = (
        np.cos(5 * th) * (1 + 0.5 * np.sin(phase)) + 0.02 * rng.normal(size=(n_u, n_v, n_t))
    ).astype(np.float32)
    arrays = {
        "t_ms": t_ms,
        "area_outer_mm2": ph.area_mm2("outer", s[0], t_ms[None, :]),
        "radial_curvature_outer_per_mm": field,
        "strain_energy_outer": field**2,
        "mean_curvature_lumen_per_mm": field,
    }
    executor = make_executor(args.jobs)
    if executor is not None:  # start the workers before the clock does
        list(executor.map(abs, range(2 * args.jobs)))
    with tempfile.TemporaryDirectory() as tmp:
        import cProfile
        import pstats

        tick = time.perf_counter()
        prof = cProfile.Profile()
        prof.enable()
        written = dataset_videos(Path(tmp), arrays, grids, executor=executor)
        prof.disable()
        seconds = time.perf_counter() - tick
        if args.profile:
            pstats.Stats(prof).sort_stats("cumtime").print_stats(15)
        size = sum(p.stat().st_size for p in written) / 2**20
    if executor is not None:
        executor.shutdown()
    print(
        f"{len(written)} videos of {n_t} frames, jobs {args.jobs}: {seconds:.1f} s, "
        f"{size:.1f} MiB (target < 20 s)"
    )


if __name__ == "__main__":
    main()
