"""The gallery's data: a small cohort of phantom embryos (two normal, two banded; 24
frames, 2-2.5k vertices a wall) analysed once per documentation build."""
from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path

import oftimg

_RESULTS: Path | None = None


def cohort_results() -> Path:
    """The results folder of the gallery's cohort (made on the first call)."""
    global _RESULTS
    if _RESULTS is None:
        root = Path(tempfile.mkdtemp(prefix="oftimg-gallery-"))
        atexit.register(shutil.rmtree, root, ignore_errors=True)   # once the build ends
        for group in ("normal", "banded"):
            for seed in (0, 1):
                oftimg.make_phantom(root / "data" / f"{group}_{seed}", group=group, seed=seed,
                                    frames=24, quiet=True, vertices_min=2000,
                                    vertices_max=2500)
        _RESULTS = oftimg.run(root / "data", root / "results", quiet=True, jobs=2)
    return _RESULTS


def embryo_results(name: str = "normal_0"):
    """One embryo's results (:func:`oftimg.load_results`)."""
    return oftimg.load_results(cohort_results() / name)
