"""Results exported for other tools: ParaView time series, TIFF stacks and OME-Zarr
(:func:`paraview`, :func:`tiff`, :func:`ome_zarr`)."""

from __future__ import annotations

from pathlib import Path

from .cohorts import _check_names
from .errors import DatasetError, InputError
from .output.export import check_output_location, require_new_folder, staged_output
from .output.results import read_summary, result_folders, source_paths
from .progress import Progress
from .workers import closing_executor, make_executor


def paraview(sources, out, *, quiet: bool = False, jobs: int | None = None) -> Path:
    """Every dataset's results among ``sources`` (as :func:`cohort` takes them) as
    ParaView time series in ``out/<name>/`` (:mod:`oftimg.output.paraview`): the
    grids with their node fields, and the section contours; each series in one of
    ``jobs`` worker processes (default: all cores). ``out`` must be new or empty;
    it appears only when complete. Returns ``out``."""
    from .analysis.per_frame import run_tasks
    from .output.paraview import series_names, write_series

    out = Path(out)
    names, folders = _exported(
        sources,
        out,
        (
            ("grids.npz", "the grids are what ParaView shows"),
            ("arrays.json", "it says which arrays lie on the grids"),
        ),
    )
    with staged_output(out) as tmp:
        tasks = [
            (f, series, tmp / name) for name, f in zip(names, folders) for series in series_names(f)
        ]
        bar = Progress(len(tasks), "ParaView series", quiet=quiet, unit="series")
        with closing_executor(make_executor(jobs)) as executor:
            run_tasks(write_series, tasks, executor=executor, progress=bar.advance)
        bar.close()
    return out


def tiff(sources, out, *, quiet: bool = False) -> Path:
    """Every dataset's maps and fields among ``sources`` (as :func:`cohort` takes
    them) as TIFF images that Fiji / ImageJ open, in ``out/<name>/``, and the cohort
    maps of a run's ``--out`` among them in ``out/cohort_maps/`` (with several runs,
    ``cohort_maps_<its folder name>/``; :mod:`oftimg.output.tiff`). ``out`` must be new
    or empty; it appears only when complete. Returns ``out``."""
    from .output.tiff import write_cohort_map_images, write_tiff_images

    out = Path(out)
    names, folders = _exported(sources, out, (("arrays.json", "it says which arrays are images"),))
    runs = [s for s in source_paths(sources) if (s / "cohort_maps.json").is_file()]
    with staged_output(out) as tmp:
        bar = Progress(len(folders) + len(runs), "TIFF images", quiet=quiet, unit="folder")
        for name, folder in zip(names, folders):
            write_tiff_images(folder, tmp / name)
            bar.advance()
        for run in runs:
            write_cohort_map_images(
                run, tmp / ("cohort_maps" if len(runs) == 1 else f"cohort_maps_{run.name}")
            )
            bar.advance()
        bar.close()
    return out


def ome_zarr(sources, out, *, quiet: bool = False) -> Path:
    """Every dataset's fields, phase maps and pullbacks among ``sources`` (as
    :func:`cohort` takes them) as OME-Zarr images with their axes and units, in
    ``out/<name>/<array>.ome.zarr`` (:mod:`oftimg.output.omezarr`; the (v, t) maps
    :func:`tiff` writes). ``out`` must be new or empty; it appears only when complete.
    Returns ``out``."""
    from .output.omezarr import write_ome_zarr_images

    try:
        import zarr  # noqa: F401
    except ImportError:
        raise InputError("writing OME-Zarr needs zarr: pip install 'oftimg[ome]'") from None
    out = Path(out)
    names, folders = _exported(sources, out, (("arrays.json", "it says which arrays are images"),))
    with staged_output(out) as tmp:
        bar = Progress(len(folders), "OME-Zarr images", quiet=quiet, unit="folder")
        for name, folder in zip(names, folders):
            write_ome_zarr_images(folder, tmp / name)
            bar.advance()
        bar.close()
    return out


def _exported(
    sources, out: Path, needed: tuple[tuple[str, str], ...]
) -> tuple[list[str], list[Path]]:
    """The names and folders of the datasets' results among ``sources`` to export
    into ``out``; refused where two share a name, one lacks a file of ``needed``
    ((file, why it is needed) each), or ``out`` is not new and empty or lies inside
    one of them."""
    folders = result_folders(sources)
    names = [read_summary(f)["name"] for f in folders]
    _check_names(list(zip(names, folders)), "export them one at a time")
    for f in folders:
        for file, why in needed:
            if not (f / file).is_file():
                raise DatasetError(f"{f}: has no {file} ({why})")
    require_new_folder(out)
    check_output_location(out, folders, overwrite=False)
    return names, folders
