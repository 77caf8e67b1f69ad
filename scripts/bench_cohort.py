"""Cohorts at scale: seconds of the cohort outputs for hundreds of embryos, and of
a real run of a small cohort by embryo.

    python scripts/bench_cohort.py [--embryos 30 100 300] [--run 0] [--jobs 2]

The cohort outputs (cohort table, group comparison with its permutation tests,
group figures, every dataset's page and the cohort's) are made from one small
analysed embryo's results, hard-linked under each name (a third of them
banded, with their summaries' numbers perturbed so that the tests have
something to compare): the analysis of an embryo does not depend on the cohort
size, these outputs do. The fitted exponent says how their time grows with the
number of embryos. ``--run N`` also times ``oftimg run`` on N small embryos
(6 frames, ~1.3k vertices each) by embryo, cached in ``--cache``.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import resource
import shutil
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

import oftimg
from oftimg.cohorts import write_cohort_outputs
from oftimg.synthetic.phantom import sample_params, write_phantom

SMALL = dict(n_frames=6, vertices_min=1200, vertices_max=1500)


def _group(k: int) -> str:
    return "banded" if k % 3 == 0 else "normal"


def _make_embryo(folder: Path, k: int) -> None:
    if not (folder / "truth.json").exists():
        shutil.rmtree(folder, ignore_errors=True)
        write_phantom(folder, sample_params(_group(k), k, **SMALL), name=folder.name)


def small_cohort(cache: Path, n: int, jobs: int) -> Path:
    """``n`` small phantom embryos in ``cache/cohort_<n>``, made in ``jobs`` processes."""
    root = cache / f"cohort_{n}"
    with ProcessPoolExecutor(jobs) as pool:
        list(pool.map(_make_embryo, [root / f"e{k}" for k in range(n)], range(n)))
    return root


def one_result(cache: Path, jobs: int) -> tuple[Path, dict]:
    """Results folder and summary of one small analysed embryo (made once)."""
    out = cache / "cohort_one_result"
    if not (out / "e0" / "summary.json").exists():
        shutil.rmtree(out, ignore_errors=True)
        oftimg.run(small_cohort(cache, 1, 1) / "e0", out, quiet=True, jobs=jobs)
    return out / "e0", json.loads((out / "e0" / "summary.json").read_text())


def cohort_outputs_seconds(result: Path, summary: dict, n: int) -> float:
    """Seconds of :func:`write_cohort_outputs` for ``n`` copies of one embryo's results."""
    rng = np.random.default_rng(n)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        summaries = []
        for k in range(n):
            name = f"e{k}"
            shutil.copytree(result, folder / name, copy_function=os.link)
            s = copy.deepcopy(summary)
            s.update(name=name, group=_group(k))
            for key, value in s.items():  # a little scatter for the tests and tables
                if isinstance(value, float) and np.isfinite(value):
                    s[key] = value * (1 + 0.05 * rng.standard_normal())
            summaries.append(s)
        tick = time.perf_counter()
        write_cohort_outputs(folder, summaries, {"oftimg_version": oftimg.__version__})
        return time.perf_counter() - tick


def main():
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--embryos", type=int, nargs="+", default=[30, 100, 300])
    ap.add_argument("--run", type=int, default=0, help="also time a real run of N embryos")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "oftimg-bench")
    args = ap.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    result, summary = one_result(args.cache, args.jobs)
    seconds = [cohort_outputs_seconds(result, summary, n) for n in args.embryos]
    for n, t in zip(args.embryos, seconds):
        print(f"cohort outputs for {n:4d} embryos: {t:6.2f} s ({1e3 * t / n:.0f} ms per embryo)")
    if len(args.embryos) > 1:
        slope = np.polyfit(np.log(args.embryos), np.log(seconds), 1)[0]
        print(f"cohort outputs: time ~ embryos^{slope:.2f}")
    if args.run:
        cohort = small_cohort(args.cache, args.run, args.jobs)
        with tempfile.TemporaryDirectory() as tmp:
            tick = time.perf_counter()
            oftimg.run(cohort, Path(tmp) / "out", quiet=True, jobs=args.jobs, parallel="embryos")
            total = time.perf_counter() - tick
        kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        print(
            f"run of {args.run} embryos x {SMALL['n_frames']} frames by embryo, jobs "
            f"{args.jobs}: {total:.1f} s ({total / args.run:.2f} s per embryo), "
            f"largest child process {kids:.0f} MB (max RSS)"
        )


if __name__ == "__main__":
    main()
