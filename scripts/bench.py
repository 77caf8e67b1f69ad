"""End-to-end benchmark of one embryo: seconds per stage, share, peak memory.

    python scripts/bench.py [--frames 195] [--vertices 5500] [--jobs 2] [--json]
    python scripts/bench.py --tracking none material   # each grid, one after the other
    python scripts/bench.py --sweep          # 49/98/195 frames and 2k/5.5k/20k vertices
                                             # (49 frames), fitted exponents

Generates (or reuses, in --cache) a phantom of 3 walls, runs the whole pipeline
(`oftimg.run`), and prints each stage's wall seconds (per-frame stages: CPU
seconds summed over the workers, scaled to wall time), the time merely to read
all meshes (the floor no pipeline can beat: the median of 3 passes before the
run and 3 after, so that the mesh reader's one-off import, ~1 s, is not counted
and the machine's drift is seen; both medians are printed) and total / read-only, where
the total leaves out the PCA, as the targets do; also that ratio to open3d's read, the
floor as first measured (oftimg reads binary .ply files with NumPy since, ~7x faster). It also prints the CPU seconds
of all processes (this one, the workers, the video encoders): wall time cannot
fall below them divided by the cores; the CPU milliseconds per frame of the
per-frame pass (all walls); and the peak memory of the largest process and of
all of them together. The sweep fits exponents to the total and to the
per-frame work alone (validation, seam end points, per-frame stages), without
the fixed costs (figures, videos, start-up).
Targets (issue 9): 195 frames x 3 walls x 5.5k vertices in < 60 s with 2 jobs,
< 25 x the read-only time, peak memory < 2 GB.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

import oftimg
from oftimg.io.dataset import load_dataset
from oftimg.io.meshfile import read_mesh_file
from oftimg.synthetic.phantom import sample_params, write_phantom


def phantom(cache: Path, frames: int, vertices: int) -> Path:
    path = cache / f"bench_{frames}f_{vertices}v"
    if not (path / "truth.json").exists():
        shutil.rmtree(path, ignore_errors=True)
        lo, hi = int(vertices * 0.9), int(vertices * 1.1)
        write_phantom(
            path, sample_params("normal", 0, n_frames=frames, vertices_min=lo, vertices_max=hi)
        )
    return path


def read_only_seconds(path: Path, repeats: int = 3, read=read_mesh_file) -> list[float]:
    """Seconds of reading every mesh once with ``read`` (oftimg's reader), ``repeats``
    times (a single pass varies by ~30 %)."""
    ds = load_dataset(path)
    times = []
    for _ in range(repeats):
        tick = time.perf_counter()
        for files in ds.frames.values():
            for f in files:
                read(f)
        times.append(time.perf_counter() - tick)
    return times


def open3d_read(path) -> None:
    """A mesh read as oftimg read every .ply up to session 21 (open3d: ~1.4 ms for
    5.5k vertices against ~0.2 ms with NumPy), for the ratio as it was first measured."""
    import open3d

    open3d.io.read_triangle_mesh(str(path), enable_post_processing=False)


def peak_mb() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return max(own, kids) / 1024


class TreeMemory:
    """Peak memory (MB) of this process and its descendants together (the workers
    and their video encoders), sampled every ``interval`` s from /proc (Linux; None
    elsewhere): the sum of their proportional set sizes (PSS: a page shared by k
    processes counts 1/k in each), so shared libraries count once."""

    def __init__(self, interval: float = 0.25):
        self.interval, self.peak_mb, self.at_peak, self.peak_s = interval, None, [], None
        self.started = time.perf_counter()

    def _sample(self) -> float:
        tree, todo = set(), [os.getpid()]
        while todo:  # descendants, from each thread's list of children
            pid = todo.pop()
            tree.add(pid)
            for children in Path(f"/proc/{pid}/task").glob("*/children"):
                try:
                    todo += [int(c) for c in children.read_text().split()]
                except OSError:  # ended meanwhile
                    pass
        each = {}
        for pid in tree:
            try:
                rollup = Path(f"/proc/{pid}/smaps_rollup").read_text()
            except OSError:
                continue
            each[pid] = (
                sum(int(line.split()[1]) for line in rollup.splitlines() if line.startswith("Pss:"))
                / 1024
            )
        total = sum(each.values())
        if total > (self.peak_mb or 0):  # who held what at the peak: this process first
            self.at_peak = [round(each.pop(os.getpid(), 0.0))] + sorted(
                (round(mb) for mb in each.values()), reverse=True
            )
            self.peak_s = time.perf_counter() - self.started
        return total

    def __enter__(self):
        if not Path("/proc/self/smaps_rollup").exists():
            return self
        self._stop = threading.Event()
        self.peak_mb = 0.0

        def watch():
            while not self._stop.wait(self.interval):
                self.peak_mb = max(self.peak_mb, self._sample())

        self._thread = threading.Thread(target=watch, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        if self.peak_mb is not None:
            self._stop.set()
            self._thread.join()


def cpu_seconds() -> float:
    """User + system CPU seconds of this process and of every finished descendant
    (the workers once their pool has shut down, and the video encoders they ran)."""
    own, kids = (
        resource.getrusage(who) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
    )
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def bench(path: Path, jobs: int, tracking: str = "material") -> dict:
    read_before = read_only_seconds(path)
    with tempfile.TemporaryDirectory() as tmp:
        cpu_before = cpu_seconds()
        tick = time.perf_counter()
        with TreeMemory() as tree:
            out = oftimg.run(
                path, Path(tmp) / "out", quiet=True, jobs=jobs, options={"tracking": tracking}
            )
        total = time.perf_counter() - tick
        cpu_s = cpu_seconds() - cpu_before
        summary = json.loads(next(out.glob("*/summary.json")).read_text())
    # read again after the run: this machine's speed drifts within minutes, and the
    # ratio is taken to the median of all six passes
    read_after = read_only_seconds(path)
    read_s = float(np.median(read_before + read_after))
    read_open3d_s = float(np.median(read_only_seconds(path, read=open3d_read)))
    tm = summary["timings_s"]
    frames_wall = tm["frames_s"]
    cpu = tm["frames_cpu_s"]
    scale = frames_wall / max(sum(cpu.values()), 1e-9)
    stages = {
        "validate (read+check)": summary["validation"]["seconds"],
        "seam end points": tm["seam_end_points_s"],
    }
    stages.update({f"per-frame: {k}": v * scale for k, v in cpu.items()})
    stages.update(
        {
            "tracking": tm.get("tracking_s", 0.0),
            "fields": tm["fields_s"],
            "image analysis": tm["image_analysis_s"],
            "write arrays": tm["write_arrays_s"],
            "figures": tm["figures_s"],
            "videos (beyond the figures)": tm["videos_s"],
            "PCA": tm["pca_s"],
        }
    )
    stages["other (start-up, alignment, clipping, reports)"] = total - sum(stages.values())
    per_frame = stages["validate (read+check)"] + stages["seam end points"] + frames_wall
    target = total - stages["PCA"]  # the targets exclude the PCA
    return {
        "frames": summary["n_frames"],
        "jobs": jobs,
        "tracking": tracking,
        "total_s": total,
        "total_without_pca_s": target,
        "read_only_s": read_s,
        "ratio": target / read_s,
        "read_only_before_s": float(np.median(read_before)),
        "read_only_after_s": float(np.median(read_after)),
        "read_open3d_s": read_open3d_s,
        "ratio_open3d": target / read_open3d_s,
        "peak_mb": peak_mb(),
        "peak_all_processes_mb": tree.peak_mb,
        "cpu_s": cpu_s,
        "at_peak_mb": tree.at_peak,
        "peak_at_s": tree.peak_s,
        "per_frame_work_s": per_frame,
        "frame_cpu_ms": 1e3 * sum(cpu.values()) / summary["n_frames"],
        "stages_s": stages,
    }


def print_table(r: dict) -> None:
    print(
        f"{r['frames']} frames, jobs {r['jobs']}, tracking {r['tracking']}: total "
        f"{r['total_s']:.1f} s, "
        f"{r['total_without_pca_s']:.1f} s without PCA (targets: < 60 s and < 25 x read-only), "
        f"read-only {r['read_only_s']:.2f} s (x{r['ratio']:.0f}; {r['read_only_before_s']:.2f} "
        f"before the run, {r['read_only_after_s']:.2f} after; open3d's read "
        f"{r['read_open3d_s']:.2f} s, x{r['ratio_open3d']:.0f}), peak memory "
        f"{r['peak_mb']:.0f} MB (largest process)"
    )
    if r["peak_all_processes_mb"] is not None:
        print(
            f"peak memory of all processes together {r['peak_all_processes_mb']:.0f} MB "
            f"(PSS, sampled every 0.25 s), {r['peak_at_s']:.0f} s into the run: this "
            f"process {r['at_peak_mb'][0]} MB, the others (workers, encoders) "
            f"{r['at_peak_mb'][1:]} MB"
        )
    print(
        f"CPU {r['cpu_s']:.1f} s in all processes: {r['cpu_s'] / r['total_s']:.2f} cores busy "
        f"on average (of {r['jobs']} jobs); the per-frame pass (all walls of a frame: grids, "
        f"sections, volumes, curvature) {r['frame_cpu_ms']:.0f} ms CPU per frame"
    )
    for k, v in r["stages_s"].items():
        print(f"  {k:28s} {v:7.2f} s  {100 * v / r['total_s']:5.1f} %")


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--frames", type=int, default=195)
    ap.add_argument("--vertices", type=int, default=5500)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "oftimg-bench")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--sweep", action="store_true")
    ap.add_argument(
        "--tracking",
        nargs="+",
        default=["material"],
        choices=("material", "none"),
        help="the grid(s) to run with, one run each in this process",
    )
    args = ap.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    if args.sweep:
        rows = []
        for f in (49, 98, 195):
            rows.append(("frames", f, bench(phantom(args.cache, f, args.vertices), args.jobs)))
        for v in (2000, 5500, 20000):
            rows.append(("vertices", v, bench(phantom(args.cache, 49, v), args.jobs)))
        for kind in ("frames", "vertices"):
            x = np.array([n for k, n, _ in rows if k == kind], float)
            for key, what in (("total_s", "total"), ("per_frame_work_s", "per-frame work")):
                y = np.array([r[key] for k, _, r in rows if k == kind])
                slope = np.polyfit(np.log(x), np.log(y), 1)[0]
                print(
                    f"{what}: "
                    + ", ".join(f"{n:.0f} {kind}: {t:.1f} s" for n, t in zip(x, y))
                    + f"; time ~ {kind}^{slope:.2f}"
                )
        if args.json:
            print(json.dumps([{"kind": k, "n": n, **r} for k, n, r in rows], indent=2))
        return
    for tracking in args.tracking:
        r = bench(phantom(args.cache, args.frames, args.vertices), args.jobs, tracking)
        print(json.dumps(r, indent=2) if args.json else "", end="")
        if not args.json:
            print_table(r)


if __name__ == "__main__":
    main()
