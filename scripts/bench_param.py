"""Per-frame milliseconds of each parameterization step on a ~5.5k-vertex frame.

    python scripts/bench_param.py [--vertices 5500] [--frames 5]

Prints the median over frames of: reading + validation, seam end points
(heat method + exact polish), seam path + insertion, cut + Desbrun map,
resampling the 80 x 50 grid. Target: seam + map + resample < 60 ms per frame.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from oftimg.io import load_dataset
from oftimg.mesh.geodesic import GeodesicSolver, insert_boundary_point, insert_path, locate_on_edges
from oftimg.mesh.grid import GridOptions, seam_endpoints
from oftimg.mesh.parameterize import FlatSampler, cut_and_map, even_grid
from oftimg.phantom import sample_params, write_phantom


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--vertices", type=int, default=5500)
    ap.add_argument("--frames", type=int, default=5)
    args = ap.parse_args()
    opts = GridOptions()
    with tempfile.TemporaryDirectory() as tmp:
        params = sample_params("normal", 0, n_frames=args.frames, vertices_min=args.vertices,
                               vertices_max=args.vertices)
        write_phantom(Path(tmp) / "bench", params, walls=("outer",))
        ds = load_dataset(Path(tmp) / "bench")
        rows = []
        for t in range(ds.n_frames):
            tick = time.perf_counter()
            tb = ds.tube("outer", t)
            times = {"read+validate": time.perf_counter() - tick}
            tick = time.perf_counter()
            p_in, p_out, _ = seam_endpoints(tb.V, tb.F, tb.inlet, tb.outlet)
            times["seam end points"] = time.perf_counter() - tick
            tick = time.perf_counter()
            V, F, inlet, a = insert_boundary_point(tb.V, tb.F, tb.inlet, p_in)
            V, F, outlet, b = insert_boundary_point(V, F, tb.outlet, p_out)
            path = GeodesicSolver(V, F).path(a, b)
            times["seam path"] = time.perf_counter() - tick
            tick = time.perf_counter()
            events = locate_on_edges(V, F, path, a, b)
            V2, F2, chain = insert_path(V, F, events)
            times["seam insertion"] = time.perf_counter() - tick
            tick = time.perf_counter()
            flat = cut_and_map(V2, F2, inlet, outlet, chain, authalic_weight=opts.authalic_weight)
            times["cut + map"] = time.perf_counter() - tick
            tick = time.perf_counter()
            even_grid(FlatSampler(flat), opts.n_u, opts.n_v, respace=opts.respace)
            times["resample"] = time.perf_counter() - tick
            rows.append(times)
        print(f"{len(tb.V)} vertices (last frame), {ds.n_frames} frames, medians:")
        total = 0.0
        for key in rows[0]:
            ms = 1e3 * float(np.median([r[key] for r in rows]))
            if key != "read+validate":
                total += ms
            print(f"  {key:18s} {ms:8.1f} ms")
        print(f"  {'seam+map+resample':18s} {total:8.1f} ms per frame (target < 60)")


if __name__ == "__main__":
    main()
