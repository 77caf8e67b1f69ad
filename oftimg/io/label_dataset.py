"""Label datasets: one folder per embryo holding a label volume per frame, checked
from the files' headers before any frame is meshed; and one frame meshed into its
walls' mesh files (the work of one worker, one volume in memory).

Layout::

    DATASET/
      meta.json   {"length_unit": "um", "voxel_size": [dx, dy, dz], "period_ms": ...,
                   "labels": {"myocardium": 1, "jelly": 2, "lumen": 3},
                   "ends": [{"point": [x, y, z], "normal": [x, y, z]}, {...}],
                   "channels": {"intensity": 0, "labels": 1}}
      labels/     one 3-D volume per frame (.tif/.tiff, .nii/.nii.gz, .npy, .h5,
                  .ome.zarr), or one 4-D labels.tif / labels.ome.tif / labels.ome.zarr /
                  labels.zarr / labels.h5 with axes (t, z, y, x); a file with a channel
                  axis (intensity and labels in one stack) with meta.json's "channels"

The voxel size and time step may come from the files (OME, ImageJ, NIfTI headers);
where meta.json gives them too, they must agree (``period_ms`` is the time step times
the frames).

A voxel ``(k, j, i)`` sits at ``x = i dx, y = j dy, z = k dz`` in ``length_unit``;
``ends`` and ``inlet`` are points in those coordinates.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import DatasetError, InputError
from ..mesh.ends import MARGIN_STEPS, cut_by_plane, largest_piece, section_aspects, square_ends
from ..mesh.labels import (
    CLOSED_PROPERTY,
    CURVATURE_PROPERTY,
    MeshOptions,
    WallMesh,
    closed_lumen_mesh,
    frame_masks,
    mesh_wall,
    mesh_walls,
)
from ..mesh.topology import MeshError, boundary_loops
from .dataset import (
    META_KEYS,
    UNIT_TO_MM,
    Meta,
    check_period,
    check_voxel_size,
    is_number,
    natural_key,
    read_meta,
    read_meta_json,
)
from .intensity import IntensitySeries, load_intensity
from .labelfile import (
    AXIS_NAMES,
    PER_FRAME_SUFFIXES,
    LabelSource,
    channel_count,
    file_names_axes,
    label_suffix,
    list_label_sources,
    read_header,
    read_volume,
    series_file,
)
from .meshfile import read_mesh_file, read_vertex_values, write_ply

LABEL_META_KEYS = {
    **META_KEYS,
    "labels": dict,
    "ends": list,
    "classes": dict,
    "channels": dict,
    "axes": str,
}
# voxels whose longest side is over this times their shortest: a volume read in the wrong
# order of its axes is then stretched (this squared along one axis against another)
CUBE_TOLERANCE = 1.02
CHANNEL_ROLES = ("labels", "intensity")  # what a stack's channels may hold
# relative: a file's time step times the frames and meta.json's period_ms agree (a
# step rounded to 3 digits is within it; a wrong one is not)
TIME_TOLERANCE = 5e-3
# a probability map's stored types, and the value that means 1
PROBABILITY_SCALE = {
    "float16": 1.0,
    "float32": 1.0,
    "float64": 1.0,
    "uint8": 255.0,
    "uint16": 65535.0,
}
LAYER_NAMES = ("myocardium", "jelly", "lumen")
DEFAULT_LABEL_IDS = {"myocardium": 1, "jelly": 2, "lumen": 3}
SPACING_TOLERANCE = 1e-3  # relative: a file's voxel size and meta.json's agree
MAX_VOXELS = 2**30  # a frame of over a billion voxels is a damaged header
CARRIED_META = ("name", "group", "period_ms", "length_unit", "inlet")
FILLED_SHARE = 0.05  # of the frames: at most so many may have a wall filled from others


@dataclass(frozen=True)
class ProbabilitySource:
    """One frame of a probabilities dataset: each layer's volume, ``(layer,
    source)`` in the layers' order; ``path`` and ``index`` are the first layer's."""

    layers: tuple[tuple[str, LabelSource], ...]

    @property
    def path(self) -> str:
        return self.layers[0][1].path

    @property
    def index(self) -> int | None:
        return self.layers[0][1].index

    def __str__(self) -> str:  # probabilities/*/f003.tif
        path = Path(self.path)
        at = "" if self.index is None else f" (frame {self.index})"
        return f"{path.parent.parent / '*' / path.name}{at}"


def read_frame(source: LabelSource | ProbabilitySource) -> np.ndarray | dict:
    """One frame's volume: labels ``(z, y, x)`` as stored, or for a probabilities
    frame each layer's probability ``(z, y, x)`` float32 in [0, 1] (layer -> array).
    Raises :class:`DatasetError` naming the file for values outside [0, 1]."""
    if not isinstance(source, ProbabilitySource):
        return read_volume(source)
    out = {}
    for layer, part in source.layers:
        raw = read_volume(part)
        values = raw.astype(np.float32) / np.float32(PROBABILITY_SCALE[raw.dtype.name])
        if raw.dtype.kind == "f":
            low, high = float(np.min(values)), float(np.max(values))
            if not (np.isfinite(low) and np.isfinite(high) and low >= -1e-3 and high <= 1 + 1e-3):
                raise DatasetError(
                    f"{part}: probabilities from {low:.6g} to {high:.6g}; a "
                    "probability map holds values in [0, 1] (uint8 or uint16 "
                    "scaled to their largest value)"
                )
            values = np.clip(values, 0.0, 1.0)
        out[layer] = values
    return out


@dataclass(frozen=True)
class LabelDataset:
    """A label dataset folder: its metadata, its frames' sources, and what every
    frame shares: ``shape (z, y, x)``, ``voxel_size (dx, dy, dz)`` in the meta's
    length unit, the layers' label values, the ``ends`` planes (two ``(point,
    normal)``, or None)."""

    path: Path
    meta: Meta
    raw_meta: dict
    sources: tuple[LabelSource, ...]
    shape: tuple[int, int, int]
    voxel_size: tuple[float, float, float]
    label_ids: dict
    ends: tuple | None
    kind: str = "labels"  # or "probabilities": a folder per layer
    intensity: IntensitySeries | None = None  # intensity/, on the labels' voxels

    @property
    def n_frames(self) -> int:
        return len(self.sources)

    @property
    def folder(self) -> Path:
        """``labels/`` or ``probabilities/``."""
        return self.path / self.kind

    def inputs_by_kind(self) -> dict[str, list[Path]]:
        """The files the dataset is made of, each once, by kind: ``labels`` or
        ``probabilities``, and ``intensity`` when it has intensity volumes."""
        parts = [
            part
            for s in self.sources
            for _, part in (s.layers if isinstance(s, ProbabilitySource) else [("", s)])
        ]
        inputs = {self.kind: list(dict.fromkeys(Path(s.path) for s in parts))}
        if self.intensity is not None:
            inputs["intensity"] = list(dict.fromkeys(Path(s.path) for s in self.intensity.sources))
        return inputs

    def input_files(self) -> list[Path]:
        """The files the dataset is made of (each once), meta.json with them."""
        files = [p for paths in self.inputs_by_kind().values() for p in paths]
        return files + [p for p in [self.path / "meta.json"] if p.is_file()]

    def mesh_names(self) -> list[str]:
        """Each frame's mesh file name: its label file's stem, or ``t000.ply``."""
        if self.sources[0].index is not None:
            width = len(str(self.n_frames - 1))
            return [f"t{s.index:0{width}d}.ply" for s in self.sources]
        return [
            Path(s.path).name[: -len(label_suffix(Path(s.path)))] + ".ply" for s in self.sources
        ]


def is_label_dataset(path: Path) -> bool:
    """A folder with ``labels/`` or ``probabilities/``: meshed before the analysis."""
    return (Path(path) / "labels").is_dir() or (Path(path) / "probabilities").is_dir()


def load_label_dataset(path: str | Path) -> LabelDataset:
    """Open a label dataset: its meta.json, and every frame's header (shape, whole-
    number labels, the file's own voxel size against meta.json's). Reads the first
    frame's voxels only when meta.json names no labels (one label value: the outer
    wall alone; else myocardium 1, jelly 2, lumen 3)."""
    path = Path(path)
    if (path / "probabilities").is_dir():
        return _load_probabilities(path)
    raw = read_meta_json(path, LABEL_META_KEYS)
    sources = list_label_sources(path / "labels", natural_key, axes=_axes(path, raw))
    meta = read_meta(path, LABEL_META_KEYS)
    channels = _channels(path, raw)
    if channels:
        sources = [replace(s, channel=channels["labels"]) for s in sources]
    headers = [read_header(s) for s in sources]
    first = _check_headers(sources, headers)
    for source, header in zip(sources, headers):
        if not (np.issubdtype(header.dtype, np.integer) or header.dtype == bool):
            raise DatasetError(
                f"{source}: {header.dtype} labels; a label volume holds whole "
                "numbers (0 background), as segmentation tools export it"
            )
    voxel = _voxel_size(path / "labels", meta, raw, sources, headers)
    check_axis_order(sources[0], voxel, meta.length_unit, raw)
    label_ids = _label_ids(path, raw, sources[0], first.dtype)
    label_ids = check_nesting(path / "labels", sources, label_ids, given="labels" in raw)
    ends = _ends(path, raw, first.shape, voxel)
    stacked = (
        [replace(s, channel=channels["intensity"]) for s in sources]
        if "intensity" in channels
        else None
    )
    intensity = load_intensity(
        path, len(sources), meta.length_unit, raw, labels_grid=(first.shape, voxel), sources=stacked
    )
    meta = _with_time_step(meta, sources, headers, intensity)
    return LabelDataset(
        path, meta, raw, tuple(sources), first.shape, voxel, label_ids, ends, intensity=intensity
    )


def _axes(path: Path, raw: dict) -> str | None:
    """meta.json's ``axes``: the order of the volume files' axes where the files name
    none (letters of t, c, z, y, x, each once, z, y and x among them), or None."""
    axes = raw.get("axes")
    if axes is None:
        return None
    if not (set("zyx") <= set(axes) <= set(AXIS_NAMES) and len(set(axes)) == len(axes)):
        raise DatasetError(
            f'{path / "meta.json"}: "axes" {axes[:20]!r}; it gives the order '
            "of the volume files' axes as stored, each of z, y, x once (and t, c "
            'for a series or a stack), e.g. "zyx" or "xyz"'
        )
    return axes


def check_axis_order(source, voxel_size, length_unit: str, raw: dict) -> None:
    """Refuse volumes whose voxels are not cubes in files that name no order of their
    axes (a plain TIFF, npy, a zarr array, HDF5 without axistags), unless meta.json's
    ``axes`` says it: read as (z, y, x), a volume saved (x, y, z) is a tube stretched by
    the voxels' ratio squared along one axis against another, every area, length and
    speed off, and no other sign (issue 83: a speed 85 % high, a tube twice as long).
    ``source``: the first frame's (a probabilities frame: its first layer's)."""
    source = source.layers[0][1] if isinstance(source, ProbabilitySource) else source
    ratio = max(voxel_size) / min(voxel_size)
    if "axes" in raw or ratio <= CUBE_TOLERANCE or file_names_axes(source):
        return
    sides = " x ".join(f"{d:g}" for d in voxel_size)
    raise DatasetError(
        f"{source.path}: its file names no order of its axes and the voxels are not cubes "
        f"({sides} {length_unit}, x y z): oftimg reads (z, y, x), as napari, scikit-image and "
        f"tifffile save; a volume saved in another order (x, y, z from MATLAB or ITK) would be "
        f"a tube stretched {ratio**2:.3g} times along one axis against another with no "
        'error; say the order stored in meta.json: "axes": "zyx" (or "xyz", ...; a '
        'series file "tzyx")'
    )


def _channels(path: Path, raw: dict) -> dict:
    """meta.json's ``channels`` (role -> channel of the labels/ files: ``labels``, and
    ``intensity`` when the stack holds it), checked; {} when it gives none."""
    channels = raw.get("channels")
    if channels is None:
        return {}
    where = f'{path / "meta.json"}: "channels"'
    unknown = sorted(set(channels) - set(CHANNEL_ROLES))
    if unknown or "labels" not in channels:
        raise DatasetError(
            f"{where} names {', '.join(unknown) or 'no labels'}; it says which "
            "channel of the labels/ files holds the labels (and the intensity),"
            ' e.g. {"intensity": 0, "labels": 1}'
        )
    for role, channel in channels.items():
        if not (isinstance(channel, int) and not isinstance(channel, bool) and channel >= 0):
            raise DatasetError(
                f"{where} gives {role} channel {str(channel)[:20]}; a channel is "
                "a whole number from 0"
            )
    if len(set(channels.values())) < len(channels):
        raise DatasetError(
            f"{where} gives two roles one channel ({channels}); each role has its own"
        )
    if "intensity" in channels and (path / "intensity").is_dir():
        raise DatasetError(
            f"{where} takes the intensity from the labels' stack, and the "
            "dataset has intensity/ too; keep one"
        )
    return channels


def _with_time_step(meta: Meta, sources, headers, intensity) -> Meta:
    """``meta`` once the series files' own time steps (OME, ImageJ) agree with its
    period (``period_ms`` = step x frames); a period from the file where meta.json
    gives none. Raises one line naming both where they disagree."""
    n = len(sources)
    given = [(sources[0], headers[0].time_step_ms)]
    if intensity is not None:
        given.append((intensity.sources[0], read_header(intensity.sources[0]).time_step_ms))
    for source, step in given:
        if step is None:
            continue
        period = step * n
        if meta.period_assumed:
            check_period(f"{source.path} (its time step {step:g} ms x {n} frames)", period)
            meta = replace(
                meta,
                period_ms=period,
                period_assumed=False,
                period_from=f"{Path(source.path).name}'s time step {step:g} ms x {n} frames",
            )
        elif not np.isclose(period, meta.period_ms, rtol=TIME_TOLERANCE, atol=0):
            said = (
                "meta.json's period_ms"
                if meta.period_from == "meta.json"
                else f"the period from {meta.period_from}"
            )
            raise DatasetError(
                f"{source.path}: its time step {step:g} ms x {n} frames = "
                f"{period:g} ms disagrees with {said} {meta.period_ms:g} ms; "
                "correct one of them"
            )
    return meta


def _load_probabilities(path: Path) -> LabelDataset:
    """:func:`load_label_dataset` for ``probabilities/``: a folder per layer
    (myocardium/ at least, jelly/, lumen/), each with a volume per frame as labels/
    has them, every frame the same shape; float in [0, 1], or uint8 / uint16."""
    folder = path / "probabilities"
    if (path / "labels").is_dir():
        raise DatasetError(f"{path}: holds both labels/ and probabilities/; keep the one to mesh")
    layers = [layer for layer in LAYER_NAMES if (folder / layer).is_dir()]
    exported = _class_export(folder)
    if exported and not layers:
        return _load_class_probabilities(path, folder, exported)
    if "myocardium" not in layers:
        raise DatasetError(
            f"{folder}: no myocardium/ folder; probabilities/ holds a folder "
            f"per layer ({', '.join(f'{n}/' for n in LAYER_NAMES)}; myocardium/ "
            "at least), each with one volume per frame"
        )
    raw = read_meta_json(path, LABEL_META_KEYS)
    for key in ("labels", "channels"):
        if key in raw:
            raise DatasetError(
                f'{path / "meta.json"}: "{key}" is for labels/; a '
                "probabilities dataset names its layers by its folders (remove "
                "it)"
            )
    meta = read_meta(path, LABEL_META_KEYS)
    axes = _axes(path, raw)
    per_layer = {
        layer: list_label_sources(folder / layer, natural_key, axes=axes) for layer in layers
    }
    counts = {layer: len(s) for layer, s in per_layer.items()}
    if len(set(counts.values())) > 1:
        raise DatasetError(
            f"{folder}: its layers have different numbers of frames ("
            + ", ".join(f"{layer}/ {n}" for layer, n in counts.items())
            + ")"
        )
    flat, headers, first = _probability_headers(per_layer)
    n = counts["myocardium"]
    voxel = _voxel_size(folder / "myocardium", meta, raw, flat[:n], headers[:n])
    check_axis_order(flat[0], voxel, meta.length_unit, raw)
    return _probability_dataset(path, folder, meta, raw, per_layer, first, voxel)


def _probability_dataset(path, folder, meta, raw, per_layer: dict, first, voxel) -> LabelDataset:
    """A probabilities dataset from each layer's frames (layer -> sources), once their
    headers are checked: nesting, ends and intensity as every label dataset has them."""
    layers = list(per_layer)
    n = len(per_layer["myocardium"])
    sources = tuple(
        ProbabilitySource(tuple((layer, per_layer[layer][t]) for layer in layers)) for t in range(n)
    )
    ends = _ends(path, raw, first.shape, voxel)
    label_ids = {layer: DEFAULT_LABEL_IDS[layer] for layer in layers}
    check_nesting(folder, sources, label_ids, given=True)
    intensity = load_intensity(path, n, meta.length_unit, raw, labels_grid=(first.shape, voxel))
    myocardium = per_layer["myocardium"]
    meta = _with_time_step(meta, myocardium, [read_header(myocardium[0])], intensity)
    return LabelDataset(
        path,
        meta,
        raw,
        sources,
        first.shape,
        voxel,
        label_ids,
        ends,
        kind="probabilities",
        intensity=intensity,
    )


def _class_export(folder: Path) -> list[Path]:
    """The files of an export with a channel per class in ``folder`` (ilastik's HDF5,
    an OME-Zarr or OME-TIFF with a c axis): its series file (``probabilities.h5``) or
    one file per frame; [] when there are none."""
    series = series_file(folder)
    if series is not None:
        return [series]
    return sorted(
        (
            p
            for p in folder.iterdir()
            if label_suffix(p) in PER_FRAME_SUFFIXES and not p.name.startswith(".")
        ),
        key=lambda p: natural_key(p.name),
    )


def _load_class_probabilities(path: Path, folder: Path, files: list[Path]) -> LabelDataset:
    """A probabilities dataset from an export with a channel per class (ilastik's
    Pixel Classification, ``exported_data`` with its axistags; an OME-Zarr or OME-TIFF
    with a c axis): one 4-D series file or one file per frame; meta.json's ``classes``
    names the layers' channels (channel 0 the background), by default myocardium 1,
    jelly 2, lumen 3 of four channels, the myocardium 1 of two."""
    raw = read_meta_json(path, LABEL_META_KEYS)
    meta = read_meta(path, LABEL_META_KEYS)
    axes = _axes(path, raw)
    frames = (
        list_label_sources(folder, natural_key, "probability volumes", axes=axes)
        if len(files) == 1 and files[0] == series_file(folder)
        else [LabelSource(str(p), axes=axes) for p in files]
    )
    channels = channel_count(frames[0])
    classes = raw.get("classes") or {4: DEFAULT_LABEL_IDS, 2: {"myocardium": 1}}.get(channels)
    where = f'{path / "meta.json"}: "classes"'
    if classes is None:
        raise DatasetError(
            f'{frames[0].path}: {channels} channels; meta.json\'s "classes" '
            'says which is which, e.g. {"myocardium": 1, "jelly": 2, '
            '"lumen": 3} (channel 0 the background)'
        )
    unknown = sorted(set(classes) - set(LAYER_NAMES))
    if unknown or "myocardium" not in classes:
        raise DatasetError(
            f"{where} names {', '.join(unknown) or 'no myocardium'}; its "
            f"layers are {', '.join(LAYER_NAMES)} (myocardium at least)"
        )
    for layer, channel in classes.items():
        if not (
            isinstance(channel, int) and not isinstance(channel, bool) and 0 <= channel < channels
        ):
            raise DatasetError(
                f"{where} gives {layer} channel {channel!r}; the file has channels 0-{channels - 1}"
            )
    layers = [layer for layer in LAYER_NAMES if layer in classes]
    per_layer = {layer: [replace(f, channel=classes[layer]) for f in frames] for layer in layers}
    flat, headers, first = _probability_headers(per_layer)
    n = len(frames)
    voxel = _voxel_size(folder, meta, raw, flat[:n], headers[:n])
    check_axis_order(flat[0], voxel, meta.length_unit, raw)
    return _probability_dataset(path, folder, meta, raw, per_layer, first, voxel)


def _probability_headers(per_layer: dict) -> tuple[list, list, object]:
    """Every layer's frames in one list (layer after layer), their headers, and the
    first header, once each has a probability map's type and every frame one shape."""
    flat = [s for sources in per_layer.values() for s in sources]
    headers = [read_header(s) for s in flat]
    first = _check_headers(flat, headers)
    for source, header in zip(flat, headers):
        if header.dtype.name not in PROBABILITY_SCALE:
            raise DatasetError(
                f"{source}: {header.dtype} voxels; a probability map is float "
                "(values in [0, 1]), uint8 or uint16 (scaled to its largest "
                "value)"
            )
    return flat, headers, first


def _check_headers(sources, headers):
    """The first header, once every frame's shape is sane and the same as it."""
    first = headers[0]
    for source, header in zip(sources, headers):
        if min(header.shape) < 2 or np.prod(header.shape, dtype=float) > MAX_VOXELS:
            raise DatasetError(
                f"{source}: a volume of shape (z, y, x) {header.shape}; a frame "
                f"has at least 2 voxels along each axis and at most "
                f"{MAX_VOXELS:,} in all (is its header damaged?)"
            )
        if header.shape != first.shape:
            raise DatasetError(
                f"{source}: a volume of shape (z, y, x) {header.shape}, but the "
                f"first frame's is {first.shape}; every frame has one shape"
            )
    return first


def _voxel_size(folder: Path, meta: Meta, raw: dict, sources, headers) -> tuple:
    """The voxel size in the meta's length unit: meta.json's, which each file in
    ``folder`` that carries one must agree with, or the files' own."""
    path = folder.parent if folder.name in ("labels", "probabilities") else folder.parent.parent
    to_unit = 1.0 / UNIT_TO_MM[meta.length_unit]
    given = meta.voxel_size
    if series_file(folder) is not None:
        sources, headers = sources[:1], headers[:1]
    for source, header in zip(sources, headers):
        if header.voxel_size_mm is None:
            continue
        own = tuple(d * to_unit for d in header.voxel_size_mm)
        if given is None:
            given = own
        elif not np.allclose(own, given, rtol=SPACING_TOLERANCE, atol=0):
            ref = (
                "meta.json's voxel_size"
                if meta.voxel_size is not None
                else f"the first frame's ({sources[0]})"
            )
            raise DatasetError(
                f"{source}: its voxel size {_fmt(own)} {meta.length_unit} disagrees with "
                f"{ref} {_fmt(given)}; correct one of them"
            )
    if given is None:
        raise DatasetError(
            f"{path / 'meta.json'}: no voxel_size, and {sources[0]} carries "
            f'none; give "voxel_size": [dx, dy, dz] in length_unit '
            f"({meta.length_unit})"
        )
    if meta.voxel_size is None:  # the file's own, checked as meta.json's
        check_voxel_size(sources[0], list(given), UNIT_TO_MM[meta.length_unit])
    return tuple(float(d) for d in given)


def _fmt(size) -> str:
    return "[" + ", ".join(f"{d:.6g}" for d in size) + "]"


def _label_ids(path: Path, raw: dict, first: LabelSource, dtype: np.dtype) -> dict:
    """The layers' label values from meta.json (each one the volumes' ``dtype`` can
    hold), or by default myocardium 1, jelly 2, lumen 3 (checked by
    :func:`check_nesting`, which takes myocardium 1 alone for a volume of 0 and 1)."""
    meta_file = path / "meta.json"
    if "labels" not in raw:
        return dict(DEFAULT_LABEL_IDS)
    ids = raw["labels"]
    unknown = sorted(set(ids) - set(LAYER_NAMES))
    if unknown or "myocardium" not in ids:
        raise DatasetError(
            f"{meta_file}: labels names the layers {', '.join(LAYER_NAMES)} "
            f"(myocardium at least), found {sorted(ids)}"
        )
    values = list(ids.values())
    if not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in values) or len(
        set(values)
    ) != len(values):
        raise DatasetError(
            f"{meta_file}: each layer's label is a distinct whole number "
            f"above 0 (0 is the background), found {ids}"
        )
    top = 1 if np.dtype(dtype).kind == "b" else int(np.iinfo(dtype).max)
    if max(values) > top:
        raise DatasetError(
            f"{meta_file}: label {max(values)} cannot occur in {first}'s "
            f"{np.dtype(dtype)} voxels (at most {top}); is labels right?"
        )
    return {layer: ids[layer] for layer in LAYER_NAMES if layer in ids}


def _sample_frames(n: int) -> list[int]:
    """The frames whose voxels :func:`check_nesting` reads: the first, middle and last."""
    return sorted({0, n // 2, n - 1})


def _as_labels(volume: np.ndarray | dict, label_ids: dict) -> np.ndarray:
    """A frame as labels: a label volume as it is; a probabilities frame (layer ->
    ``(z, y, x)``) as each voxel's most likely layer's value in ``label_ids``, 0 where
    no layer reaches 0.5."""
    if not isinstance(volume, dict):
        return volume
    layers = list(volume)
    stacked = np.stack([volume[layer] for layer in layers])
    codes = np.array([0] + [label_ids[layer] for layer in layers], np.uint8)
    return codes[np.where(stacked.max(axis=0) >= 0.5, stacked.argmax(axis=0) + 1, 0)]


def check_nesting(folder: Path, sources, label_ids: dict, *, given: bool) -> dict:
    """``label_ids`` (layer -> value), once the values they name are seen to nest as the
    layers do (myocardium around jelly around lumen) in the first, middle and last
    frames of ``sources`` (:mod:`oftimg.mesh.nesting`); without a ``labels`` mapping
    in meta.json (``given`` False), a volume of 0 and 1 is the myocardium alone.
    Raises one :class:`DatasetError` for the dataset that names the values found
    with their voxel counts, the nesting seen, and the mapping to write."""
    from ..mesh.nesting import label_contacts, layers_present, nesting_order

    frames = _sample_frames(len(sources))
    contacts = None
    for t in frames:
        part = label_contacts(_as_labels(read_frame(sources[t]), label_ids))
        contacts = part if contacts is None else contacts + part
    present = layers_present(contacts)
    if not given and present == [1]:
        return {"myocardium": 1}
    expected = list(label_ids.values())
    missing = [layer for layer, v in label_ids.items() if contacts.count(v) == 0]
    if not missing and nesting_order(contacts, expected) == expected:
        return label_ids
    names = ", ".join(
        str(Path(sources[t].path).name) if sources[t].index is None else f"frame {sources[t].index}"
        for t in frames
    )
    found = ", ".join(
        f"{int(v)} ({int(n):,} voxels)" for v, n in zip(contacts.values, contacts.voxels) if v
    )
    seen = _nesting_words(contacts, nesting_order(contacts, present))
    wanted = " around ".join(f"{layer} {v}" for layer, v in label_ids.items())
    if isinstance(sources[0], ProbabilitySource):
        channels = {layer: source.channel for layer, source in sources[0].layers}
        if all(c is not None for c in channels.values()):  # one export, a class a channel
            said = "its channels say " + " around ".join(
                f"{layer} (channel {c})" for layer, c in channels.items()
            )
            holds = (
                'meta.json\'s "classes" names the channels: the myocardium the '
                "outermost layer, the jelly the one inside it, the lumen the innermost"
            )
        else:
            said = f"its folders say {' around '.join(f'{layer}/' for layer in label_ids)}"
            holds = (
                "myocardium/ holds the outermost layer, jelly/ the one inside it, "
                "lumen/ the innermost"
            )
        problem = (
            f"no voxel is most likely {', '.join(missing)}"
            if missing
            else f"the layers do not nest as {said}"
        )
        raise DatasetError(
            f"{folder}: {problem} (in {names}, each voxel's most likely layer "
            f"where one reaches 0.5: {found}; {seen}); {holds}"
        )
    if missing:
        problem = "no voxel holds " + ", ".join(f"{layer} {label_ids[layer]}" for layer in missing)
    else:
        problem = f"the labels do not nest as {wanted}"
    source = (
        'meta.json\'s "labels"'
        if given
        else 'no "labels" in meta.json, so myocardium 1, jelly 2, lumen 3 were assumed'
    )
    return _refuse_nesting(
        folder,
        f"{problem} ({source}); in {names} the values found are {found or 'none but 0'}; {seen}",
        contacts,
        present,
    )


def _nesting_words(contacts, order: list[int]) -> str:
    """The nesting seen, in words: "3 encloses 2, which encloses 1"."""
    from ..mesh.nesting import enclosed

    if len(order) < 2:
        return f"one layer, {order[0]}" if order else "no layer"
    text = str(order[0])
    for k, (a, b) in enumerate(zip(order, order[1:])):
        if enclosed(contacts, a, b):
            text += f" encloses {b}" if k == 0 else f", which encloses {b}"
        else:
            text += f"; {b} lies beside {a}, not inside it"
    return text


def _refuse_nesting(folder: Path, said: str, contacts, present: list[int]):
    """Raise the :class:`DatasetError` of :func:`check_nesting` for a labels folder,
    with the ``labels`` mapping to write when the nesting seen gives one."""
    from ..mesh.nesting import nesting_order

    order = nesting_order(contacts, present)
    roles = {1: ["myocardium"], 2: ["myocardium", "lumen"], 3: list(LAYER_NAMES)}
    if len(order) in roles:
        mapping = json.dumps(dict(zip(roles[len(order)], order)))
        fix = f'write "labels": {mapping} in {folder.parent / "meta.json"}'
    else:
        fix = (
            f"name each layer's value in {folder.parent / 'meta.json'}'s \"labels\" "
            "(myocardium the outermost, jelly the one inside it, lumen the innermost)"
        )
    raise DatasetError(f"{folder}: {said}; {fix}")


def _ends(path: Path, raw: dict, shape_zyx, voxel_size) -> tuple | None:
    """meta.json's two cutting planes as ``((point, normal), (point, normal))``: points
    inside the volume's box, normals of finite non-zero length, and some of the volume
    on the kept side of both (checked on a 17^3 lattice over the box)."""
    if "ends" not in raw:
        return None
    ends = raw["ends"]
    shape = (
        'two planes, each {"point": [x, y, z], "normal": [x, y, z]} in '
        "length_unit, the normal pointing into the tube's part to keep"
    )
    ok = len(ends) == 2 and all(
        isinstance(e, dict)
        and set(e) == {"point", "normal"}
        and all(
            isinstance(e[k], list) and len(e[k]) == 3 and all(is_number(x) for x in e[k])
            for k in ("point", "normal")
        )
        for e in ends
    )
    if not ok:
        raise DatasetError(f"{path / 'meta.json'}: ends must be {shape}")
    points = np.array([e["point"] for e in ends], float)
    normals = np.array([e["normal"] for e in ends], float)
    lengths = np.linalg.norm(normals, axis=1)
    if not np.all(np.isfinite(lengths) & (lengths > 0)):
        raise DatasetError(
            f"{path / 'meta.json'}: an ends normal has no direction (zero "
            f"length); ends must be {shape}"
        )
    box = (np.asarray(shape_zyx[::-1], float) - 1) * np.asarray(voxel_size)
    outside = [
        k
        for k in range(2)
        if np.any(points[k] < -1e-9 * box.max()) or np.any(points[k] > box * (1 + 1e-9))
    ]
    if outside:
        raise DatasetError(
            f"{path / 'meta.json'}: ends point {points[outside[0]].tolist()} "
            f"lies outside the volume (0 to {box.tolist()} in length_unit)"
        )
    normals /= lengths[:, None]
    # a coarse lattice over the volume: some of it must lie on the kept side of both
    lattice = np.stack(
        np.meshgrid(*[np.linspace(0, b, 17) for b in box], indexing="ij"), axis=-1
    ).reshape(-1, 3)
    side = np.einsum("pkd,kd->pk", lattice[:, None, :] - points[None], normals)
    kept = np.all(side > 1e-9 * box.max(), axis=1)
    if not kept.any():
        raise DatasetError(
            f"{path / 'meta.json'}: the ends planes keep nothing of the volume "
            "between them (each normal points into the tube's part to keep)"
        )
    return tuple((tuple(map(float, e["point"])), tuple(map(float, e["normal"]))) for e in ends)


def mesh_frame(
    source: LabelSource,
    out: str,
    mesh_name: str,
    label_ids: dict,
    voxel_size,
    options: MeshOptions,
    ends=None,
    length_unit: str = "um",
) -> dict | DatasetError:
    """Mesh one frame's volume into ``out/<wall>/<mesh_name>`` (binary PLY, in the
    volume's length unit): per wall meshed its vertex count, clean-up count,
    sampling step and mask repairs, and ``left_out`` (wall -> why) for the walls
    that cannot be meshed (:func:`~oftimg.mesh.labels.mesh_walls`); or the
    :class:`DatasetError` naming the frame's file when the file itself is bad
    (returned, so that one pass over the frames finds every bad one)."""
    try:
        walls = mesh_walls(
            read_frame(source), label_ids, voxel_size, options, ends, length_unit=length_unit
        )
    except DatasetError as exc:  # names its file already
        return exc
    except (InputError, MeshError) as exc:
        return DatasetError(f"{source}: {exc}")
    meshes = {w: m for w, m in walls.items() if isinstance(m, WallMesh)}
    for wall, mesh in meshes.items():
        _write_wall(out, wall, mesh_name, mesh)
    repairs = [
        {
            "wall": w,
            "what": m.repair.what,
            "voxels": m.repair.voxels,
            "euler_before": m.repair.euler_before,
        }
        for w, m in meshes.items()
        if m.repair is not None
    ]
    repairs += [
        {
            "wall": w,
            "what": "kept inside the mended wall around it",
            "voxels": m.nested,
            "euler_before": None,
        }
        for w, m in meshes.items()
        if m.nested is not None
    ]
    return {
        "vertices": {w: len(m.V) for w, m in meshes.items()},
        "pieces_dropped": {w: m.cleaned.pieces for w, m in meshes.items()},
        "step": {w: round(m.step, 6) for w, m in meshes.items()},
        "repairs": repairs,
        "left_out": {w: why for w, why in walls.items() if isinstance(why, str)},
        "closures": {w: m.closure for w, m in meshes.items() if m.closure is not None},
        "rims": _rims(meshes.get("outer")),
    }


def _rims(mesh: WallMesh | None) -> list[np.ndarray]:
    """The outer wall's boundary loops (points ``(k, 3)`` each, float32): where the
    volume's faces cut it, for :func:`square_the_ends`."""
    if mesh is None:
        return []
    return [mesh.V[loop].astype(np.float32) for loop in boundary_loops(mesh.F)]


def fill_wall(
    sources: tuple,
    t: int,
    wall: str,
    between: tuple,
    mended: tuple,
    left: tuple,
    out: str,
    mesh_name: str,
    label_ids: dict,
    voxel_size,
    options: MeshOptions,
    ends=None,
    length_unit: str = "um",
) -> dict | DatasetError:
    """The ``wall`` of frame ``t``, left out there, meshed from the frames around it:
    ``between = (t_before, t_after, weight)``, their masks (``mended``: whether each
    had its topology mended, redone here) blended by
    :func:`~oftimg.mesh.mask_blend.blended_occupancy`, kept between frame ``t``'s
    own walls around and inside it where those are whole (not in ``left``, the
    frame's walls left out). Written as
    :func:`mesh_frame` writes; returns the wall's record, or the error naming frame
    ``t``'s file when the blend cannot be meshed either."""
    from ..mesh.mask_blend import blended_occupancy
    from ..mesh.mask_topology import core, solid_tube_mask

    t_before, t_after, weight = between
    masks = []
    for frame, was_mended in zip((t_before, t_after), mended):
        mask = frame_masks(read_frame(sources[frame]), label_ids)[wall]
        # mended again as it was; a frame meshed after a wider blur has no mended mask
        solid = solid_tube_mask(mask)[0] if was_mended else None
        masks.append(core(mask) if solid is None else solid)
    own = frame_masks(read_frame(sources[t]), label_ids)
    order = list(own)
    k = order.index(wall)
    whole = [w for w in order if w not in left]
    try:
        occupancy = blended_occupancy(
            *masks,
            weight,
            voxel_size,
            within=own[order[k - 1]].astype(np.float32)
            if k > 0 and order[k - 1] in whole
            else None,
            around=own[order[k + 1]].astype(np.float32)
            if k + 1 < len(order) and order[k + 1] in whole
            else None,
        )
        mesh = mesh_wall(
            occupancy, voxel_size, options, ends, curvature=wall == "lumen", length_unit=length_unit
        )
    except MeshError as exc:
        # a lumen the cushions close in the frames around: their blend, in pieces or a
        # slit's sieve, bridged as a closed lumen of this frame's own
        mesh = (
            closed_lumen_mesh(
                occupancy,
                own["inner"],
                voxel_size,
                options,
                ends,
                openings=(0, 1, 2, 3),
                to_ends=True,
                length_unit=length_unit,
            )
            if wall == "lumen" and "inner" in own
            else None
        )
        if mesh is None:
            return DatasetError(
                f"{sources[t]}: the {wall} wall, left out, filled from "
                f"frames {t_before} and {t_after}, {exc}"
            )
    _write_wall(out, wall, mesh_name, mesh)
    return {
        "vertices": len(mesh.V),
        "pieces_dropped": mesh.cleaned.pieces,
        "step": round(mesh.step, 6),
        "rims": _rims(mesh) if wall == "outer" else None,
        "voxels": int(np.count_nonzero((occupancy > 0.5) != own[wall])),
        "closure": mesh.closure,
    }


def _frame_name(lds: LabelDataset, t: int) -> str:
    """Frame ``t``'s file name within labels/ (``labels.tif (frame 4)`` in a 4-D file)."""
    source = lds.sources[t]
    name = Path(source.path).name
    return name if source.index is None else f"{name} (frame {source.index})"


def _write_wall(out: str, wall: str, mesh_name: str, mesh: WallMesh) -> None:
    """``out/<wall>/<mesh_name>`` as binary PLY, with the level sets' mean curvature
    and a closed lumen's bridge flags (1 on the bridge) as vertex properties when there
    are."""
    (Path(out) / wall).mkdir(parents=True, exist_ok=True)
    values = {} if mesh.mean_curvature is None else {CURVATURE_PROPERTY: mesh.mean_curvature}
    if mesh.closed is not None:
        values[CLOSED_PROPERTY] = mesh.closed.astype(np.float32)
    write_ply(Path(out) / wall / mesh_name, mesh.V, mesh.F, values or None)


def neighbours_to_fill_from(good: np.ndarray, t: int) -> tuple[int, int, float]:
    """The nearest frames before and after ``t`` (a cycle: counted round its end) whose
    wall is ``good`` (``(n_t,)`` bool), and the share of the way from the one before
    to the one after that ``t`` lies."""
    n = len(good)
    back = next(d for d in range(1, n) if good[(t - d) % n])
    ahead = next(d for d in range(1, n) if good[(t + d) % n])
    return (t - back) % n, (t + ahead) % n, back / (back + ahead)


def meshing_notes(path: Path, meshing: dict) -> list[str]:
    """What a user should know of how a label dataset at ``path`` was meshed
    (``meshing``: :func:`mesh_label_dataset`'s record): its masks mended or filled
    (:func:`label_repairs_note`) and its ends cut square (:func:`squared_ends_note`)."""
    notes = [
        label_repairs_note(path, meshing.get("label_repairs", [])),
        squared_ends_note(path, meshing),
        closures_note(path, meshing),
    ]
    return [note for note in notes if note]


def closures_note(path: Path, meshing: dict) -> str | None:
    """The line that says in how many frames the lumen was closed over a stretch and
    bridged (:func:`~oftimg.mesh.labels.closed_lumen_mesh`), or None."""
    closures = meshing.get("lumen_closures") or []
    if not closures:
        return None
    n_t = len(next(iter(meshing["vertices"].values())))
    return (
        f"{path}: the lumen is closed over a stretch of the tube (no lumen voxel: the "
        f"cushions apposed) in {len(closures)} of {n_t} frames; its pieces were joined "
        "by a thin bridge to grid it, and its rows there are measured as closed (area 0, "
        "no curvature: lumen_closed in arrays.npz; summary.json provenance.meshing."
        "lumen_closures)"
    )


def squared_ends_note(path: Path, meshing: dict) -> str | None:
    """The line that says where the volume's faces cut the tube obliquely and how far
    in its walls were cut square (``meshing``: :func:`mesh_label_dataset`'s record,
    its ``ends_squared`` in its ``length_unit``); None where no end was."""
    cut = [end for end in meshing.get("ends_squared") or () if end is not None]
    if not cut:
        return None
    mm = UNIT_TO_MM[meshing["length_unit"]]
    angles = " and ".join(f"{end['oblique_deg']:.0f}" for end in cut)
    depths_mm = " and ".join(f"{end['cut_in'] * mm:.3f}" for end in cut)
    ends = "both ends" if len(cut) == 2 else "one end"
    return (
        f"{path}: the volume's faces cut the tube obliquely at {ends} ({angles} degrees "
        f"from square): every frame's walls were cut square to the centre line {depths_mm} mm "
        "in, past every frame's rim, so that each section is whole (summary.json "
        'provenance.meshing.ends_squared; meta.json "ends" places the planes yourself)'
    )


def label_repairs_note(path: Path, repairs: list[dict]) -> str | None:
    """The warning that names the wall masks mended, and the walls left out and filled
    from the frames around them, in a label dataset at ``path`` (``repairs``:
    :func:`mesh_label_dataset`'s ``label_repairs``); None for none."""
    if not repairs:
        return None
    mended = [r for r in repairs if "filled_from" not in r]
    filled = [r for r in repairs if "filled_from" in r]
    parts = []
    if mended:
        named = "; ".join(
            f"{Path(r['file']).name} {r['wall']} ({r['what']}, {r['voxels']} voxels)"
            for r in mended[:4]
        )
        parts.append(
            f"mended the topology of {len(mended)} wall mask{'s' * (len(mended) > 1)} "
            f"(a handle, tunnel or bridge the segmentation left): {named}"
            f"{'; ...' if len(mended) > 4 else ''}"
        )
    if filled:
        named = "; ".join(
            f"{Path(r['file']).name} {r['wall']} (from frames "
            f"{r['filled_from'][0]} and {r['filled_from'][1]}: {r['why']})"
            for r in filled[:4]
        )
        parts.append(
            f"left out {len(filled)} wall{'s' * (len(filled) > 1)} that could not be "
            f"meshed and filled {'them' if len(filled) > 1 else 'it'} from the frames "
            f"around: {named}{'; ...' if len(filled) > 4 else ''}"
        )
    folder = "probabilities" if (Path(path) / "probabilities").is_dir() else "labels"
    return (
        f"{Path(path) / folder}: {'; and '.join(parts)}; all in summary.json "
        "provenance.meshing.label_repairs"
    )


def write_meshed_meta(lds: LabelDataset, out: Path) -> None:
    """The meshed dataset's meta.json: what meta.json says of the embryo, carried
    over (the meshes are in the volume's length unit, so no voxel_size)."""
    meta = {k: lds.raw_meta[k] for k in CARRIED_META if k in lds.raw_meta}
    meta.setdefault("name", lds.meta.name)
    (out / "meta.json").write_text(json.dumps(meta, indent=2))


def mesh_label_dataset(
    lds: LabelDataset, out: Path, options: MeshOptions, *, executor=None, progress=None
) -> dict:
    """Mesh every frame of ``lds`` into ``out`` (``outer/``, ``inner/``, ``lumen/`` and a
    meta.json: a mesh dataset) in ``executor``'s workers, each holding one volume;
    ``progress()`` after each frame. A wall left out in a frame (its label absent,
    its mask not mendable) is filled from the frames around it (:func:`fill_wall`)
    when at most :data:`FILLED_SHARE` of the frames have one. Returns what the
    results' provenance records: the input files by kind (:func:`listed_files`), the
    meshing options, per wall
    each frame's vertex count and the pieces its clean-up dropped, and every mask
    repair and fill (``label_repairs``). Raises one :class:`DatasetError` naming
    every frame that cannot be meshed."""
    tick = time.perf_counter()
    out = Path(out)
    n = lds.n_frames
    args = (
        lds.sources,
        [str(out)] * n,
        lds.mesh_names(),
        [lds.label_ids] * n,
        [lds.voxel_size] * n,
        [options] * n,
        [lds.ends] * n,
        [lds.meta.length_unit] * n,
    )
    results = []
    for result in map(mesh_frame, *args) if executor is None else executor.map(mesh_frame, *args):
        results.append(result)
        if progress:
            progress()
    _raise_for_bad_files(results, n)
    _gaps_left_out(lds, out, results)
    repairs = [
        {"frame": t, "file": str(lds.sources[t]), **r}
        for t, result in enumerate(results)
        for r in result["repairs"]
    ]
    repairs += _fill_left_out(lds, out, options, results, executor)
    closures = [
        {"frame": t, "file": str(lds.sources[t]), **closure}
        for t, result in enumerate(results)
        for closure in result.get("closures", {}).values()
    ]
    walls = [w for w in ("outer", "inner", "lumen") if w in results[0]["vertices"]]
    squared = None if lds.ends is not None else square_the_ends(lds, out, walls, results, executor)
    check_axis_geometry(lds, out)
    write_meshed_meta(lds, out)
    return {
        "inputs": {kind: listed_files(paths) for kind, paths in lds.inputs_by_kind().items()},
        "meshing": {
            "options": options.as_dict(),
            "voxel_size": list(lds.voxel_size),
            "length_unit": lds.meta.length_unit,
            "shape_zyx": list(lds.shape),
            "labels": lds.label_ids,
            "kind": lds.kind,
            "ends": None if lds.ends is None else [list(map(list, e)) for e in lds.ends],
            "ends_squared": squared,
            **{
                key: {w: [r[key][w] for r in results] for w in walls}
                for key in ("vertices", "pieces_dropped", "step")
            },
            "label_repairs": repairs,
            "lumen_closures": closures,
            "seconds": round(time.perf_counter() - tick, 2),
        },
    }


# frames tried in turn as the reference whose centre line gives the square ends: at
# one phase the sections past a rim may not settle it (speckled zoo draw 631: a wide
# inlet on a tight bend, near its largest expansion, every frame within 2 of the middle),
# at another they do
REFERENCE_TRIES = 5


def reference_frames(n: int) -> list[int]:
    """The frames tried as the square ends' reference, spread over the cycle: the
    middle frame, then a quarter, three quarters, an eighth... of the way through,
    :data:`REFERENCE_TRIES` in all (at most ``n``)."""
    shares = [0.5, 0.25, 0.75, 0.125, 0.375, 0.625, 0.875, 0.0]
    return list(dict.fromkeys(int(share * n) % n for share in shares))[:REFERENCE_TRIES]


def square_the_ends(
    lds: LabelDataset, out: Path, walls: list[str], results: list, executor
) -> list[dict | None] | None:
    """Where the volume's faces cut the tube obliquely (meta.json gives no "ends"),
    every frame's walls in ``out`` cut at the planes square to the centre line past
    every frame's rim (:func:`~oftimg.mesh.ends.square_ends`: the middle frame's
    outer wall gives the centre line, or the next of :func:`reference_frames` where it
    does not settle; ``results``' rims the reach), in ``executor``'s
    workers. Returns per end (in the order of the middle frame's boundary loops) the
    plane as the provenance records it (None where the face cuts square), or None
    when no end needed it. Raises :class:`DatasetError` naming the frame whose wall is
    no tube once cut."""
    names = lds.mesh_names()
    step = float(np.median([r["step"]["outer"] for r in results]))
    failed = None
    for t in reference_frames(len(names)):
        try:
            ends = square_ends(
                read_mesh_file(out / "outer" / names[t]),
                [r["rims"] for r in results],
                MARGIN_STEPS * step,
            )
            break
        except MeshError as exc:
            failed = failed or exc
    else:
        raise DatasetError(
            f'{lds.folder}: the tube {failed}; give the two cutting planes in meta.json ("ends")'
        ) from None
    if all(end is None for end in ends):
        return None
    planes = [(end.point, end.normal) for end in ends if end is not None]
    n = len(names)
    args = ([str(out)] * n, names, [walls] * n, [planes] * n)
    cut = list(map(cut_frame, *args) if executor is None else executor.map(cut_frame, *args))
    bad = [(t, why) for t, why in enumerate(cut) if why]
    if bad:
        t, why = bad[0]
        raise DatasetError(
            f"{_frame_name(lds, t)} in {lds.folder}: cut square to the centre "
            f"line where the volume's face cuts the tube obliquely, {why}; give "
            'the two cutting planes in meta.json ("ends")'
        )
    return [None if end is None else end.as_dict() for end in ends]


# a volume is refused as read in the wrong order of its axes when another order makes its
# outer wall's most stretched sections (their 10th percentile of minor over major axis)
# rounder by this much, and those read are stretched beyond ROUND_ENOUGH
ROUNDER_BY, ROUND_ENOUGH = 0.2, 0.7


def check_axis_geometry(lds: LabelDataset, out: Path) -> None:
    """Refuse a volume whose voxels are not cubes and whose tube is far rounder read in
    another order of its axes than as its file names them (an OME-TIFF of a (t, x, y, z)
    array written as TZYX: a tube twice as long, exit 0), unless meta.json's ``axes``
    confirms the order: the middle frame's outer wall, and the same wall as each other
    order of the array's axes would have placed it (:func:`reordered`), each measured by
    the 10th percentile of its sections' minor over major axis
    (:func:`~oftimg.mesh.ends.section_aspects`)."""
    ratio = max(lds.voxel_size) / min(lds.voxel_size)
    if "axes" in lds.raw_meta or ratio <= CUBE_TOLERANCE:
        return
    V, F = read_mesh_file(out / "outer" / lds.mesh_names()[lds.n_frames // 2])
    given = _roundness(V, F)
    others = {
        order: _roundness(reordered(V, lds.voxel_size, order), F)
        for order in ("xyz", "yxz", "xzy", "yzx", "zxy")
    }  # the likeliest first
    best = max(others.values())
    order = next(o for o, r in others.items() if r >= best - 0.02)  # mirrors tie
    if not (given < ROUND_ENOUGH and best > given + ROUNDER_BY):
        return
    raise DatasetError(
        f"{lds.sources[0].path}: read as its file names its axes, the tube's sections are "
        f"{1 / given:.2g} times longer one way than the other (10th percentile; {1 / best:.2g} "
        f"read as ({', '.join(order)})), as a volume whose axes are named in the wrong order "
        f"gives with voxels of {' x '.join(f'{d:g}' for d in lds.voxel_size)} "
        f"{lds.meta.length_unit}: save it with its axes in their true order; if the order is "
        f'right, say so in meta.json: "axes": "zyx"'
    )


def _roundness(V: np.ndarray, F: np.ndarray) -> float:
    """The 10th percentile of a tube's sections' minor over major axis (1 for none)."""
    aspects = section_aspects(V, F)
    return float(np.percentile(aspects, 10)) if len(aspects) >= 4 else 1.0


def reordered(V: np.ndarray, voxel_size, order: str) -> np.ndarray:
    """Points ``V (n, 3)`` (x, y, z) of a volume read as (z, y, x) with voxels
    ``voxel_size`` (dx, dy, dz), where they would lie had its array's axes been
    ``order`` (a permutation of "zyx", the array's first axis first)."""
    d = dict(zip("xyz", np.asarray(voxel_size, float)))
    out = np.empty_like(V, dtype=float)
    for read, true in zip("zyx", order):  # each array axis: read as, meant as
        out[:, "xyz".index(true)] = V[:, "xyz".index(read)] / d[read] * d[true]
    return out


def cut_frame(out: str, mesh_name: str, walls: list[str], planes: list) -> str | None:
    """Each wall's mesh ``out/<wall>/<mesh_name>`` cut at ``planes`` (``(point,
    normal)`` each, the normal into the part kept) and rewritten, with its stored
    curvature; the largest piece kept. Returns why a wall is no tube once cut (None
    when every wall is)."""
    for wall in walls:
        path = Path(out) / wall / mesh_name
        V, F = read_mesh_file(path)
        stored = {
            name: read_vertex_values(path, name) for name in (CURVATURE_PROPERTY, CLOSED_PROPERTY)
        }
        stored = {name: v.astype(float) for name, v in stored.items() if v is not None}
        values = np.stack([*stored.values(), np.zeros(len(V))], axis=1)
        for point, normal in planes:
            V, F, values = cut_by_plane(V, F, point, normal, values)
        if len(F) == 0:
            return f"nothing of its {wall} wall is left"
        V, F, kept, _ = largest_piece(V, F)
        if len(boundary_loops(F)) != 2:
            return f"its {wall} wall has {len(boundary_loops(F))} open ends, not 2"
        write_ply(path, V, F, {name: values[kept, k] for k, name in enumerate(stored)} or None)
    return None


def listed_files(paths: list[Path]) -> list[dict]:
    """Files as the results' provenance lists them: each one's absolute path and size."""
    return [{"file": str(Path(p).resolve()), "bytes": Path(p).stat().st_size} for p in paths]


def _raise_for_bad_files(results: list, n: int) -> None:
    """One :class:`DatasetError` for the frames whose file is bad: the first one's
    message, the others named in a note."""
    bad = [r for r in results if isinstance(r, DatasetError)]
    if bad:
        if len(bad) > 1:
            bad[0].add_note(
                f"and {len(bad) - 1} more of the {n} frames cannot be meshed: "
                + "; ".join(str(e) for e in bad[1:4])
                + ("; ..." if len(bad) > 4 else "")
            )
        raise bad[0]


def _gaps_left_out(lds: LabelDataset, out: Path, results: list) -> None:
    """A lumen closed in one frame alone (neither frame either side closed) where the
    frames either side are wide open there
    (:func:`~oftimg.mesh.closure.is_one_frame_gap`) is the segmentation's gap, not
    the cushions: its closure dropped from the frame's record in ``results`` and its
    lumen left out, to be filled from the frames around it like any wall that cannot
    be meshed (:func:`_fill_left_out`), when the frames to fill stay within
    :data:`FILLED_SHARE` (else they are kept as the closures they were bridged as)."""
    from ..mesh.closure import is_one_frame_gap

    n = lds.n_frames
    names = lds.mesh_names()
    closed = [t for t, r in enumerate(results) if "lumen" in r.get("closures", {})]
    gaps = []
    for t in closed:
        around = ((t - 1) % n, (t + 1) % n)
        # a neighbour closed too, or not meshed: no wide-open frame either side to judge by
        if any("lumen" in results[f]["left_out"] or f in closed for f in around):
            continue
        path = out / "lumen" / names[t]
        V, _ = read_mesh_file(path)
        bridge = V[read_vertex_values(path, CLOSED_PROPERTY) > 0.5]
        lumen, before, after = (
            frame_masks(read_frame(lds.sources[f]), lds.label_ids)["lumen"] for f in (t, *around)
        )
        if is_one_frame_gap(bridge, lumen, before, after, lds.voxel_size):
            gaps.append(t)
    left = sum(bool(r["left_out"]) for r in results)
    if left + len(gaps) > int(FILLED_SHARE * n):  # not to be filled: kept as closures
        return
    for t in gaps:
        del results[t]["closures"]["lumen"]
        results[t]["left_out"]["lumen"] = (
            "its lumen closed over a stretch in this frame "
            "alone, wide open there in the frames either "
            "side: a gap in the segmentation, not the "
            "cushions"
        )


def _fill_left_out(
    lds: LabelDataset, out: Path, options: MeshOptions, results: list, executor
) -> list[dict]:
    """Fill every wall left out in a frame from the frames around it, into ``out`` and
    each frame's record in ``results``; the fills as ``label_repairs`` entries.
    Raises one :class:`DatasetError` naming every frame with a wall left out when
    they are more than :data:`FILLED_SHARE` of the frames (or a fill fails)."""
    n = lds.n_frames
    left = {t: r["left_out"] for t, r in enumerate(results) if r["left_out"]}
    if not left:
        return []
    allowed = int(FILLED_SHARE * n)
    if len(left) > allowed:
        named = "; ".join(
            f"{_frame_name(lds, t)}: {', '.join(dict.fromkeys(walls.values()))}"
            for t, walls in left.items()
        )
        raise DatasetError(
            f"{lds.folder}: {len(left)} of {n} frames have a wall that "
            f"cannot be meshed, more than the {allowed} ({FILLED_SHARE:.0%}) "
            f"that can be filled from the frames around them: {named}"
        )
    tasks = []
    for t, walls in left.items():
        for wall in walls:
            good = np.array([wall not in r["left_out"] for r in results])
            before, after, weight = neighbours_to_fill_from(good, t)
            mended = tuple(
                any(
                    r["wall"] == wall and r["euler_before"] is not None
                    for r in results[f]["repairs"]
                )
                for f in (before, after)
            )
            tasks.append((t, wall, (before, after, round(weight, 6)), mended))
    names = lds.mesh_names()
    m = len(tasks)
    args = (
        [lds.sources] * m,
        *zip(*[(t, w, b, md, tuple(left[t])) for t, w, b, md in tasks]),
        [str(out)] * m,
        [names[t] for t, *_ in tasks],
        [lds.label_ids] * m,
        [lds.voxel_size] * m,
        [options] * m,
        [lds.ends] * m,
        [lds.meta.length_unit] * m,
    )
    filled = list(map(fill_wall, *args) if executor is None else executor.map(fill_wall, *args))
    failed = [f for f in filled if isinstance(f, DatasetError)]
    if failed:
        raise DatasetError("; ".join(str(e) for e in failed))
    entries = []
    for (t, wall, (before, after, _), _), record in zip(tasks, filled):
        for key in ("vertices", "pieces_dropped", "step"):
            results[t][key][wall] = record[key]
        if record["rims"] is not None:
            results[t]["rims"] = record["rims"]
        if record["closure"] is not None:
            results[t]["closures"][wall] = record["closure"]
        entries.append(
            {
                "frame": t,
                "file": str(lds.sources[t]),
                "wall": wall,
                "what": f"left out, filled from frames {before} and {after}",
                "why": left[t][wall],
                "voxels": record["voxels"],
                "euler_before": None,
                "filled_from": [before, after],
            }
        )
    return entries
