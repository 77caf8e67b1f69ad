"""The Python API behind the command line: run, demo, make_phantom.

File access happens here and in :mod:`oftimg.io` / :mod:`oftimg.export`; the
science lives in :mod:`oftimg.pipeline` and the ``mesh``/``image`` modules.
"""
from __future__ import annotations

import platform
import sys
import time
from pathlib import Path

from . import __version__
from .export import check_output_location, staged_output, write_dataset_results, write_json
from .io import Dataset, find_datasets, load_dataset, validate_dataset
from .phantom import sample_params, write_phantom
from .progress import Progress


def _as_dataset_paths(source) -> list[Path]:
    if isinstance(source, Dataset):
        return [source.path]
    return find_datasets(source)


def run(source, out, *, overwrite: bool = False, quiet: bool = False,
        options: dict | None = None) -> Path:
    """Process a dataset or cohort folder (or a :class:`Dataset`) into ``out``.

    Every frame of every dataset is validated before any work. Results are
    written to a temporary folder and moved to ``out`` at the end; a failed
    run leaves ``out`` as it was. Returns ``out``.
    """
    from .pipeline import PipelineOptions, analyse_dataset

    out = Path(out)
    paths = _as_dataset_paths(source)
    check_output_location(out, paths, overwrite=overwrite)
    opts = PipelineOptions(**(options or {}))
    datasets = [load_dataset(p) for p in paths]
    names = [d.meta.name for d in datasets]
    if len(set(names)) != len(names):
        raise ValueError(f"dataset names are not unique: {names}")
    reports = {}
    for ds in datasets:
        reports[ds.meta.name] = validate_dataset(ds)
    started = time.time()
    with staged_output(out, overwrite=overwrite) as tmp:
        summaries = []
        for ds in datasets:
            folder = tmp / ds.meta.name
            folder.mkdir()
            result = analyse_dataset(ds, opts, quiet=quiet)
            summary = result["summary"]
            summary["validation"] = reports[ds.meta.name]
            write_dataset_results(folder, result)
            summaries.append(summary)
        from .report import write_cohort_table

        write_cohort_table(tmp, summaries)
        write_json(tmp / "run.json", {
            "oftimg_version": __version__, "python": sys.version.split()[0],
            "platform": platform.platform(), "inputs": [str(p) for p in paths],
            "options": opts.as_dict(), "seconds": round(time.time() - started, 2)})
    return out


def make_phantom(out, *, group: str = "normal", seed: int = 0, frames: int = 195,
                 quiet: bool = False, **overrides) -> Path:
    """Write one phantom dataset (see :mod:`oftimg.phantom`) to ``out``."""
    params = sample_params(group, seed, n_frames=frames, **overrides)
    bar = Progress(frames, f"phantom {Path(out).name}", quiet=quiet)
    with staged_output(out) as tmp:
        write_phantom(tmp, params, name=Path(out).name, progress=bar.update)
    bar.close()
    return Path(out)


def demo(out, *, full: bool = False, overwrite: bool = False, quiet: bool = False) -> Path:
    """Generate the built-in phantom cohort and run the whole pipeline on it.

    Small (default): one normal and one banded embryo, 40 frames, smaller
    meshes. ``full``: 4 normal + 4 banded, 195 frames, the paper's size.
    Returns ``out``; the generated data are in ``out/data``.
    """
    out = Path(out)
    check_output_location(out, [], overwrite=overwrite)
    if full:
        specs = [("normal", s) for s in range(4)] + [("banded", s) for s in range(4)]
        kwargs = {"frames": 195}
    else:
        specs = [("normal", 0), ("banded", 0)]
        kwargs = {"frames": 40, "vertices_min": 2500, "vertices_max": 4000}
    with staged_output(out, overwrite=overwrite) as tmp:
        data = tmp / "data"
        data.mkdir()
        for group, seed in specs:
            make_phantom(data / f"{group}_{seed}", group=group, seed=seed, quiet=quiet, **kwargs)
        run(data, tmp / "results", quiet=quiet)
    return out
