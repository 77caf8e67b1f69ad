"""What a run reads: dataset folders found and opened as what they hold (meshes, or label
or probability volumes meshed frame by frame, :func:`validate_labels`, :func:`mesh`)."""

from __future__ import annotations

import dataclasses
import shutil
import warnings
from pathlib import Path

from .cohorts import _check_names
from .errors import DatasetError, OftimgWarning
from .io.dataset import (
    Dataset,
    check_enough_frames,
    find_datasets,
    load_dataset,
    validate_dataset,
    with_period,
)
from .io.label_dataset import (
    LabelDataset,
    is_label_dataset,
    load_label_dataset,
    mesh_label_dataset,
    meshing_notes,
)
from .io.labelfile import describe_format
from .output.export import check_output_location, staged_output, write_json
from .progress import Progress
from .workers import closing_executor, make_executor


def _as_dataset_paths(source) -> list[Path]:
    if isinstance(source, (Dataset, LabelDataset)):
        return [source.path]
    return find_datasets(source)


def _load(path: Path) -> Dataset | LabelDataset:
    """A dataset folder opened as what it holds: label volumes or meshes."""
    return load_label_dataset(path) if is_label_dataset(path) else load_dataset(path)


def _meshed(lds: LabelDataset, folder: Path, options, executor, quiet: bool) -> Dataset:
    """A label dataset meshed frame by frame in the workers into ``folder`` (beside
    the kept results, removed with them), opened as the mesh dataset it becomes;
    its ``labels`` record the label files and the meshing."""
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    record = _mesh_with_bar(lds, folder, options, executor, quiet)
    with warnings.catch_warnings():  # said of the label dataset already
        warnings.simplefilter("ignore", OftimgWarning)
        ds = load_dataset(folder)
    ds.path, ds.labels, ds.intensity = lds.path, record, lds.intensity
    ds.meta = dataclasses.replace(
        ds.meta,
        period_ms=lds.meta.period_ms,  # --period-ms too
        period_assumed=lds.meta.period_assumed,
        period_from=lds.meta.period_from,
    )
    return ds


def _mesh_with_bar(lds: LabelDataset, folder: Path, options, executor, quiet: bool) -> dict:
    """:func:`mesh_label_dataset` into ``folder`` with a progress bar over the frames."""
    bar = Progress(lds.n_frames, f"{lds.meta.name}: meshing labels", quiet=quiet, unit="frame")
    try:
        return mesh_label_dataset(lds, folder, options, executor=executor, progress=bar.advance)
    finally:
        bar.close()


def _lumens_joined(ds: Dataset, folder: Path, options, executor, quiet: bool) -> Dataset:
    """A mesh dataset whose lumen the cushions close in some frames with those frames'
    lumens joined into ``folder`` (:func:`~oftimg.io.lumen_closures.bridged_dataset`,
    beside the kept results, removed with them); ``ds`` when none is closed."""
    from .io.lumen_closures import bridged_dataset, closed_frames

    closed = closed_frames(ds, executor)
    if not closed:
        return ds
    bar = Progress(len(closed), f"{ds.meta.name}: joining closed lumens", quiet=quiet, unit="frame")
    try:
        return bridged_dataset(ds, folder, options, executor, progress=bar.advance, closed=closed)
    finally:
        bar.close()


def validate_labels(path, *, quiet: bool = False, period_ms: float | None = None) -> dict:
    """Check a label dataset as a run would: its headers and period (``period_ms`` as
    :func:`run` takes it), then every frame meshed (here, into a temporary folder) and
    the meshes validated. Returns the validation report of the meshes
    (:func:`validate_dataset`) for ``path``, with the volumes' shape, voxel size and
    labels."""
    import tempfile

    from .mesh.labels import MeshOptions

    lds = with_period([load_label_dataset(path)], period_ms)[0]
    check_enough_frames(lds)
    with tempfile.TemporaryDirectory(prefix="oftimg-validate-") as tmp:
        ds = _meshed(lds, Path(tmp) / "meshes", MeshOptions(), None, quiet)
        report = validate_dataset(ds)
    assert ds.labels is not None  # meshed from the label volumes
    report["labels"] = {
        k: ds.labels["meshing"][k]
        for k in (
            "shape_zyx",
            "voxel_size",
            "length_unit",
            "labels",
            "label_repairs",
            "kind",
            "ends_squared",
        )
    }
    first = lds.sources[0]
    first = first.layers[0][1] if hasattr(first, "layers") else first
    described = describe_format(first)
    carried = described.pop("file_voxel_size")
    described.pop("file_time_step")  # said by the period's source
    if "channels" in lds.raw_meta:
        described["channels"] = lds.raw_meta["channels"]
    report["labels"] |= described | {
        "voxel_size_from": (
            "meta.json, the files' own agreeing"
            if lds.meta.voxel_size is not None and carried
            else "meta.json"
            if lds.meta.voxel_size is not None
            else "the files' headers"
        )
    }
    if lds.intensity is not None:
        seen = describe_format(lds.intensity.sources[0])
        report["labels"]["intensity_format"] = f"{seen['format']}; axes {seen['axes']}"
    return report


def mesh(
    source, out, *, options: dict | None = None, jobs: int | None = None, quiet: bool = False
) -> Path:
    """Mesh a label dataset (or each of a cohort's) into a mesh dataset in ``out``
    (``out/<name>`` for a cohort): ``outer/``, ``inner/``, ``lumen/`` PLY files in
    the volumes' length unit and meta.json carried over, to look at in ParaView or
    MeshLab. ``options``: :class:`~oftimg.mesh.labels.MeshOptions` fields. Nothing
    is written when a frame cannot be meshed."""
    from .mesh.labels import MeshOptions

    meshing = MeshOptions(**(options or {}))
    out = Path(out)
    paths = [p for p in _as_dataset_paths(source) if is_label_dataset(p)]
    if not paths:
        raise DatasetError(f"{source}: no label dataset (a folder with labels/) to mesh")
    check_output_location(out, paths, overwrite=False)
    datasets = [load_label_dataset(p) for p in paths]
    _check_names([(d.meta.name, d.path) for d in datasets], 'set another "name" in its meta.json')
    single = len(paths) == 1 and paths[0] == Path(source)
    executor = make_executor(jobs, None)
    with closing_executor(executor), staged_output(out) as tmp:
        for lds in datasets:
            folder = tmp if single else tmp / lds.meta.name
            folder.mkdir(parents=True, exist_ok=True)
            record = _mesh_with_bar(lds, folder, meshing, executor, quiet)
            write_json(folder / "meshing.json", record)
            for note in meshing_notes(lds.path, record["meshing"]):
                warnings.warn(note, OftimgWarning, stacklevel=2)
    return out
