"""Per-frame milliseconds of each parameterization step.

    python scripts/bench_param.py [--vertices 5500] [--frames 5]
    python scripts/bench_param.py --mesh ../shared/data/drosophila_midgut/*.ply [--frames 3]

Prints the median over frames (each run ``--repeats`` times, the best run
counting: a shared VM only ever adds time) of: reading + validation, seam end
points (Dijkstra candidates + exact polish), seam path, seam insertion, cut +
Desbrun map, resampling the 80 x 50 grid. Phantom target: seam + map + resample < 60 ms
per ~5.5k-vertex frame; real 32k midgut target: < 0.5 s per frame. One core
(the steps are single-threaded; run with OMP_NUM_THREADS=1 to be sure).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from oftimg.io.dataset import load_dataset
from oftimg.io.tube import load_tube
from oftimg.mesh.geodesic import GeodesicSolver, insert_boundary_point, insert_path, locate_on_edges
from oftimg.mesh.grid import GridOptions, seam_endpoints
from oftimg.mesh.parameterize import FlatSampler, cut_and_map, even_grid
from oftimg.synthetic.phantom import sample_params, write_phantom


class _Clock:
    """Wall and CPU seconds of consecutive steps (CPU time is steadier on a shared VM)."""

    def __init__(self):
        self.wall, self.cpu = {}, {}
        self._last = (time.perf_counter(), time.process_time())

    def lap(self, step: str) -> None:
        now = (time.perf_counter(), time.process_time())
        self.wall[step] = now[0] - self._last[0]
        self.cpu[step] = now[1] - self._last[1]
        self._last = (time.perf_counter(), time.process_time())


def time_steps(read, opts: GridOptions) -> _Clock:
    """Seconds of each step for the tube returned by ``read()``."""
    clock = _Clock()
    tb = read()
    clock.lap("read+validate")
    p_in, p_out, _ = seam_endpoints(tb.V, tb.F, tb.inlet, tb.outlet, method=opts.seam_method)
    clock.lap("seam end points")
    V, F, inlet, a = insert_boundary_point(tb.V, tb.F, tb.inlet, p_in)
    V, F, outlet, b = insert_boundary_point(V, F, tb.outlet, p_out)
    path = GeodesicSolver(V, F).path(a, b)
    clock.lap("seam path")
    V2, F2, chain = insert_path(V, F, locate_on_edges(V, F, path, a, b))
    clock.lap("seam insertion")
    flat = cut_and_map(V2, F2, inlet, outlet, chain, authalic_weight=opts.authalic_weight)
    clock.lap("cut + map")
    even_grid(FlatSampler(flat), opts.n_u, opts.n_v, respace=opts.respace)
    clock.lap("resample")
    clock.n_vertices = len(tb.V)
    return clock


def best_of(clocks: list[_Clock]) -> _Clock:
    """Per step, the least time over repeated runs of one frame (a shared VM only
    ever adds time)."""
    best = clocks[0]
    for c in clocks[1:]:
        for step in best.wall:
            best.wall[step] = min(best.wall[step], c.wall[step])
            best.cpu[step] = min(best.cpu[step], c.cpu[step])
    return best


def report(clocks, target_ms: float, repeats: int) -> None:
    print(
        f"{clocks[-1].n_vertices} vertices (last frame), {len(clocks)} frames, "
        f"median over frames of the best of {repeats} runs (ms):\n"
        "  step                  wall      CPU"
    )
    totals = {"wall": 0.0, "cpu": 0.0}
    for step in clocks[0].wall:
        wall = 1e3 * float(np.median([c.wall[step] for c in clocks]))
        cpu = 1e3 * float(np.median([c.cpu[step] for c in clocks]))
        if step != "read+validate":
            totals["wall"] += wall
            totals["cpu"] += cpu
        print(f"  {step:18s} {wall:8.1f} {cpu:8.1f}")
    print(
        f"  {'seam+map+resample':18s} {totals['wall']:8.1f} {totals['cpu']:8.1f} "
        f"per frame (target < {target_ms:g})"
    )


def main():
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--vertices", type=int, default=5500)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--mesh", type=Path, help="time this static tube instead of a phantom")
    ap.add_argument("--seam-method", default="graph", choices=("graph", "heat", "exact"))
    ap.add_argument("--repeats", type=int, default=3, help="runs per frame (the best counts)")
    args = ap.parse_args()
    opts = GridOptions(seam_method=args.seam_method)

    def timed(read):
        return best_of([time_steps(read, opts) for _ in range(max(args.repeats, 1))])

    if args.mesh:
        rows = [timed(lambda: load_tube(args.mesh)) for _ in range(args.frames)]
        report(rows, 500, args.repeats)
        return
    with tempfile.TemporaryDirectory() as tmp:
        params = sample_params(
            "normal",
            0,
            n_frames=max(args.frames, 3),
            vertices_min=args.vertices,
            vertices_max=args.vertices,
        )
        write_phantom(Path(tmp) / "bench", params, walls=("outer",))
        ds = load_dataset(Path(tmp) / "bench")
        rows = [timed(lambda: ds.tube("outer", t)) for t in range(args.frames)]
    report(rows, 60, args.repeats)


if __name__ == "__main__":
    main()
