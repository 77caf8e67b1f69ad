"""Seconds for the cross-section shape PCA of one embryo, and a comparison with fdasrsf.

    python scripts/bench_pca.py [--frames 195] [--fdasrsf]

Builds the outer grid rings of an analytic phantom (80 points, 3 rows, expansion
and contraction phases) and times oftimg's PCA. With --fdasrsf (if installed),
times fdasrsf's Karcher mean (closed curves, rotation, its elastic
re-parameterisation) on the same contours of one row and phase. Target: three
rows x two phases in under 60 s on 2 cores.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from oftimg.image.pca import contour_pca, ring_to_plane
from oftimg.synthetic.phantom import Phantom, PhantomParams


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--frames", type=int, default=195)
    ap.add_argument("--fdasrsf", action="store_true")
    args = ap.parse_args()
    ph = Phantom(PhantomParams(n_frames=args.frames))
    t = ph.frame_times_ms()
    s = np.linspace(0, ph.p.length_mm, 50)[None, :, None]
    th = (2 * np.pi * np.arange(80) / 80)[:, None, None]
    grid = ph.point("outer", s, th, t[None, None, :])  # (80, 50, n_t, 3)
    vol = ph.volume_mm3("outer", t)
    t0 = int(np.argmin(vol))
    grid = np.roll(grid, -t0, axis=2)
    t_max = int((np.argmax(vol) - t0) % args.frames)
    tick = time.perf_counter()
    res = contour_pca(grid, t_max)
    ours = time.perf_counter() - tick
    conv = all(
        r[p]["converged"] for r in res["summary"]["rows"] for p in ("expansion", "contraction")
    )
    print(
        f"oftimg shape PCA, 3 rows x 2 phases, {args.frames} frames: {ours:.2f} s "
        f"(converged: {conv}; target < 60 s)"
    )
    if args.fdasrsf:
        from fdasrsf import fdacurve

        curves = ring_to_plane(np.moveaxis(grid[:, 25, : t_max + 1], 1, 0))  # (n, 80, 2)
        beta = np.transpose(curves, (2, 1, 0))  # (2, 80, n)
        tick = time.perf_counter()
        obj = fdacurve(beta, mode="C", N=80, scale=True)
        obj.karcher_mean(rotation=True, parallel=False)
        fda = time.perf_counter() - tick
        print(f"fdasrsf Karcher mean, one row and phase ({curves.shape[0]} contours): {fda:.1f} s")


if __name__ == "__main__":
    main()
