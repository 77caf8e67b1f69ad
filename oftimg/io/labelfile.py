"""Label volume files: one frame's volume read as an array ``(z, y, x)``, and the
voxel size the file itself carries.

Formats: one 3-D file per frame (TIFF or OME-TIFF, NIfTI through nibabel, ``.npy``),
or one 4-D file for the whole series (``labels.tif`` with axes (t, z, y, x), as ImageJ
writes a hyperstack; ``labels.ome.tif``, its axes, voxel size and time step from its
OME-XML; ``labels.ome.zarr``, an OME-Zarr image whose ``multiscales`` metadata gives
them; a plain ``labels.zarr`` array; ``labels.h5``, ilastik's export with its axistags).
A file with a channel axis (intensity and labels in one stack) is read one channel at a
time (:attr:`LabelSource.channel`). Headers are read without the voxels, so that a
whole series is checked before any frame is meshed; a frame's voxels are read when it
is meshed (a TIFF page range, a memory map, a zarr chunk), so a worker holds one volume
at a time.
"""

from __future__ import annotations

import atexit
import contextlib
import json
import logging
import os
import threading
from collections import OrderedDict
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import DatasetError
from .safefile import file_status

PER_FRAME_SUFFIXES = (".tif", ".tiff", ".nii", ".nii.gz", ".npy", ".h5", ".hdf5", ".zarr")
SERIES_SUFFIXES = (".tif", ".tiff", ".ome.tif", ".ome.tiff", ".ome.zarr", ".zarr", ".h5", ".hdf5")
SERIES_NAMES = tuple("labels" + suffix for suffix in SERIES_SUFFIXES)
HDF5_SUFFIXES = (".h5", ".hdf5")
AXES_SUFFIXES = (*HDF5_SUFFIXES, ".zarr")  # arrays with named axes (_axes_array)
ILASTIK_DATASET = "exported_data"  # where ilastik's export puts its array
# length units as TIFF (ImageJ) and NIfTI headers spell them, in mm
HEADER_UNITS_MM = {
    "mm": 1.0,
    "millimeter": 1.0,
    "um": 1e-3,
    "micron": 1e-3,
    "\u00b5m": 1e-3,
    "\u03bcm": 1e-3,
    "microns": 1e-3,
    "micrometer": 1e-3,
    "nm": 1e-6,
    "nanometer": 1e-6,
    "meter": 1e3,
    "m": 1e3,
    "centimeter": 10.0,
    "cm": 10.0,
}
# time units as OME (UDUNITS-2 names, OME-XML symbols) and ImageJ spell them, in ms
TIME_UNITS_MS = {
    "millisecond": 1.0,
    "ms": 1.0,
    "second": 1e3,
    "s": 1e3,
    "sec": 1e3,
    "microsecond": 1e-3,
    "us": 1e-3,
    "\u00b5s": 1e-3,
    "minute": 6e4,
    "min": 6e4,
}
AXIS_NAMES = "tczyx"  # the axes a volume file may have, OME's names


@dataclass(frozen=True)
class LabelSource:
    """Where one frame's volume lies: a file, or frame ``index`` of a 4-D file."""

    path: str
    index: int | None = None
    channel: int | None = None  # of an HDF5 export's channel axis (ilastik's classes)
    axes: str | None = None  # meta.json's "axes": the file's, where it names none

    def __str__(self) -> str:
        where = [] if self.index is None else [f"frame {self.index}"]
        where += [] if self.channel is None else [f"channel {self.channel}"]
        return f"{self.path} ({', '.join(where)})" if where else self.path


@dataclass(frozen=True)
class VolumeHeader:
    """What a file says about a frame without its voxels: ``shape (z, y, x)``, the
    stored dtype, its own voxel size ``(dx, dy, dz)`` in mm and, for a series file,
    its time step in ms (None: it gives none)."""

    shape: tuple[int, int, int]
    dtype: np.dtype
    voxel_size_mm: tuple[float, float, float] | None
    time_step_ms: float | None = None


@dataclass(frozen=True)
class AxesArray:
    """An HDF5 or zarr volume array with named axes (a subset of ``tczyx`` in its
    order), what its file says of its voxel size (mm) and time step (ms), and where
    the axes came from (``said``) and what the file is (``format``)."""

    data: object
    axes: str
    voxel_size_mm: tuple[float, float, float] | None
    time_step_ms: float | None
    said: str
    format: str


def label_suffix(path: Path) -> str:
    """The file's format suffix, ``.nii.gz`` as one."""
    name = path.name.lower()
    return ".nii.gz" if name.endswith(".nii.gz") else path.suffix.lower()


def series_names(folder: Path) -> tuple[str, ...]:
    """The names a 4-D file may have in ``folder``: ``labels.tif`` ..., or the
    folder's own name (``intensity/intensity.zarr``)."""
    own = tuple(folder.name + suffix for suffix in SERIES_SUFFIXES)
    return tuple(dict.fromkeys(SERIES_NAMES + own))


def series_file(folder: Path) -> Path | None:
    """The 4-D file of a ``labels/`` folder, or None for one file per frame."""
    found = [folder / n for n in series_names(folder) if (folder / n).exists()]
    return found[0] if found else None


def list_label_sources(
    folder: Path, natural_key, what: str = "label volumes", axes: str | None = None
) -> list[LabelSource]:
    """The frames of a ``labels/`` folder (or another of volumes, ``what`` they are)
    in time order: each frame of its 4-D file, or its per-frame files in natural
    order (one format only). ``axes``: meta.json's order of the files' axes, for files
    that name none (:func:`file_names_axes`)."""
    series = series_file(folder)
    if series is not None:
        _check_kind(series)
        with _read_as(series, "a 4-D series"):
            n_t = _series_shape(series, axes)[0]
        return [LabelSource(str(series), t, axes=axes) for t in range(n_t)]
    files = sorted(
        (
            p
            for p in folder.iterdir()
            if not p.name.startswith(".") and label_suffix(p) in PER_FRAME_SUFFIXES
        ),
        key=lambda p: natural_key(p.name),
    )
    if not files:
        raise DatasetError(
            f"{folder}: no {what} (one file per frame: "
            f"{', '.join(PER_FRAME_SUFFIXES)}; or one 4-D "
            f"{' or '.join(series_names(folder))})"
        )
    kinds = sorted({label_suffix(p).replace(".tiff", ".tif") for p in files})
    if len(kinds) > 1:
        raise DatasetError(
            f"{folder}: mixes {' and '.join(kinds)} files; a series is one "
            "format, so that the frames' order is plain"
        )
    return [LabelSource(str(p), axes=axes) for p in files]


def read_header(source: LabelSource) -> VolumeHeader:
    """The frame's shape, dtype and voxel size (and a series' time step) from its
    file's header."""
    path = Path(source.path)
    _check_kind(path)
    with _read_as(source, "a volume"):
        return _read_header(source, path)


def _read_header(source: LabelSource, path: Path) -> VolumeHeader:
    """:func:`read_header` by the file's own reader (its errors unwrapped)."""
    kind = label_suffix(path)
    if kind in AXES_SUFFIXES:
        with _axes_array(path, source.axes) as arr:
            _check_axes_frame(arr, source)
            shape = tuple(int(arr.data.shape[arr.axes.index(a)]) for a in "zyx")
            step = arr.time_step_ms if source.index is not None else None
            return VolumeHeader(shape, np.dtype(arr.data.dtype), arr.voxel_size_mm, step)
    if kind in (".nii", ".nii.gz"):
        img = _nifti(path)
        shape = _three_d(img.shape, path)[::-1]  # (x, y, z) -> (z, y, x)
        return VolumeHeader(shape, img.header.get_data_dtype(), _nifti_voxel(img))
    if kind == ".npy":
        arr = np.load(path, mmap_mode="r")
        return VolumeHeader(
            _to_zyx(_three_d(arr.shape, path), _frame_axes(source, path)), arr.dtype, None
        )
    with _tiff(path, series=source.index is not None) as tif:
        if tif.is_ome or tif.is_imagej:
            _no_axes_given(
                source, tif.series[0].axes, "its OME-XML" if tif.is_ome else "its ImageJ metadata"
            )
        if source.index is not None or _tiff_has_channels(tif):
            shape = _tiff_series_layout(tif, source)[0]
            step = _tiff_time_step(tif) if source.index is not None else None
            return VolumeHeader(
                _to_zyx(shape[1:], _frame_axes(source, path)),
                tif.series[0].dtype,
                _tiff_voxel(tif),
                step,
            )
        shaped = _shaped_shape(tif)
        if shaped is not None:  # tifffile's own: no page parsed
            return VolumeHeader(
                _to_zyx(_three_d(shaped, path), _frame_axes(source, path)),
                tif.pages.first.dtype,
                _tiff_voxel(tif),
            )
        series = tif.series[0]
        return VolumeHeader(
            _to_zyx(_three_d(series.shape, path), _frame_axes(source, path)),
            series.dtype,
            _tiff_voxel(tif),
        )


def _shaped_shape(tif) -> tuple[int, ...] | None:
    """A TIFF's shape as tifffile's "shaped" description gives it, when its pages
    agree (one plane a page): read without building every page, which takes ~3 ms a
    file of 64 planes (a dataset's headers are read for every frame). None otherwise."""
    if not tif.is_shaped or tif.is_ome or tif.is_imagej:
        return None
    first = tif.pages.first
    try:
        shape = tuple(int(n) for n in json.loads(first.description).get("shape", ()))
    except (ValueError, TypeError, AttributeError):
        return None
    if (
        len(shape) < 2
        or shape[-2:] != tuple(first.shape[:2])
        or first.samplesperpixel != 1
        or int(np.prod(shape[:-2])) != len(tif.pages)
    ):
        return None
    return shape


def describe_format(source: LabelSource) -> dict:
    """What a frame's file is, for a person checking their input: ``format`` (its
    kind, one file per frame or one for the series), ``axes`` as the file gives them
    (or as oftimg reads a format that gives none), ``file_voxel_size`` (whether the
    file carries one) and ``file_time_step`` (whether a series file carries its
    frame interval)."""
    path = Path(source.path)
    kind = label_suffix(path)
    series = source.index is not None
    where = "one file holding every frame" if series else "one file per frame"
    header = read_header(source)
    carries = {
        "file_voxel_size": header.voxel_size_mm is not None,
        "file_time_step": header.time_step_ms is not None,
    }
    if kind in AXES_SUFFIXES:
        with _read_as(source, "a volume"), _axes_array(path, source.axes) as arr:
            return {
                "format": f"{arr.format}, {where}",
                "axes": f"{arr.axes} ({arr.said})",
                **carries,
            }
    if kind in (".nii", ".nii.gz"):
        return {"format": f"NIfTI, {where}", "axes": "xyz (its header), turned to zyx", **carries}
    if kind == ".npy":
        axes = (
            f"{source.axes} (meta.json), turned to zyx"
            if source.axes
            else "zyx (as oftimg reads npy)"
        )
        return {"format": f"npy, {where}", "axes": axes, **carries}
    with _read_as(source, "a TIFF"), _tiff(path, series=series) as tif:
        name = "OME-TIFF" if tif.is_ome else "ImageJ TIFF" if tif.is_imagej else "TIFF"
        if tif.is_ome or tif.is_imagej:
            axes = tif.series[0].axes.lower()
            said = "its OME-XML" if tif.is_ome else "its ImageJ metadata"
        elif source.axes:
            axes, said = source.axes, "meta.json"
        else:  # tifffile's letters say nothing: Q, I
            axes, said = ("tzyx" if series else "zyx"), "as oftimg reads a plain TIFF"
    return {"format": f"{name}, {where}", "axes": f"{axes} ({said})", **carries}


def _check_kind(path: Path) -> None:
    """A zarr store is a folder; every other label file a regular file."""
    if label_suffix(path) == ".zarr":
        if not path.is_dir():
            raise DatasetError(f"{path}: a zarr store is a folder; this is not one")
    else:
        file_status(path)


@contextlib.contextmanager
def _read_as(source, what: str):
    """Reading ``source`` (a path or :class:`LabelSource`) as ``what``: a reader's
    exception (a truncated or foreign file) becomes one :class:`DatasetError` in its
    reader's words, and tifffile's log of what it finds odd (kilobytes of it) is
    kept quiet."""
    logger = logging.getLogger("tifffile")
    disabled, logger.disabled = logger.disabled, True
    try:
        yield
    except DatasetError:
        raise
    except Exception as exc:
        raise DatasetError(
            f"{source}: cannot be read as {what}: damaged, or not what its "
            f"name says ({_reader_says(exc)})"
        ) from None
    finally:
        logger.disabled = disabled


def _reader_says(exc: BaseException) -> str:
    """What a reader's exception says, as ``"tifffile says: ..."``."""
    reader = {
        "tifffile": "tifffile",
        "nibabel": "nibabel",
        "zarr": "zarr",
        "numcodecs": "zarr",
        "h5py": "h5py",
    }.get(type(exc).__module__.split(".")[0], "the reader")
    return f"{reader} says: {printable(exc) or type(exc).__name__}"


def printable(exc: BaseException, limit: int = 120) -> str:
    """An exception's text as one short line of printable characters (a reader's
    message may quote the file's own bytes)."""
    text = "".join(c if c.isprintable() and ord(c) < 0x250 else "?" for c in str(exc))
    return " ".join(text.split())[:limit]


def read_volume(source: LabelSource) -> np.ndarray:
    """The frame's labels ``(z, y, x)`` as stored (one frame read, not the series)."""
    path = Path(source.path)
    _check_kind(path)
    with _read_as(source, "a volume"):
        return _read_volume(source, path)


def _read_volume(source: LabelSource, path: Path) -> np.ndarray:
    """:func:`read_volume` by the file's own reader (its errors unwrapped)."""
    kind = label_suffix(path)
    if kind in AXES_SUFFIXES:
        with _axes_array(path, source.axes) as arr:
            return _axes_frame(arr, source)
    if kind == ".npy":
        data = np.load(path, mmap_mode="r")
        return _as_zyx(
            np.asarray(data).reshape(_three_d(data.shape, path)), _frame_axes(source, path)
        )
    if kind in (".nii", ".nii.gz"):
        data = np.asanyarray(_nifti(path).dataobj)
        return np.ascontiguousarray(data.reshape(data.shape[:3]).transpose(2, 1, 0))
    with _tiff(path, series=source.index is not None) as tif:
        if source.index is not None or _tiff_has_channels(tif):
            shape, pages = _tiff_series_layout(tif, source)
            data = tif.asarray(key=pages[source.index or 0].tolist()).reshape(shape[1:])
        else:
            data = tif.asarray()
            data = data.reshape(_three_d(data.shape, path))
    return _as_zyx(data, _frame_axes(source, path))


def _frame_axes(source: LabelSource, path: Path) -> str:
    """The order of a frame's spatial axes as stored in a file that names none:
    meta.json's ``axes`` (its z, y and x; a series file's t, if given, first), else
    (z, y, x)."""
    if source.axes is None:
        return "zyx"
    if "c" in source.axes or ("t" in source.axes and source.axes[0] != "t"):
        raise DatasetError(
            f'{path}: meta.json\'s "axes" {source.axes!r} for a file that '
            "names none of its own: z, y, x in the order stored, a series' t "
            'first, e.g. "xyz" or "txyz"'
        )
    return _spatial(source.axes)


def _spatial(axes: str) -> str:
    """The order of z, y and x among ``axes``."""
    return "".join(a for a in axes if a in "zyx")


def _to_zyx(shape, stored: str) -> tuple[int, int, int]:
    """A frame's ``shape`` in the ``stored`` order of its axes as ``(z, y, x)``."""
    return tuple(int(shape[stored.index(a)]) for a in "zyx")


def _as_zyx(volume: np.ndarray, stored: str) -> np.ndarray:
    """A frame's volume in the ``stored`` order of its axes turned to ``(z, y, x)``."""
    if stored == "zyx":
        return volume
    return np.ascontiguousarray(np.transpose(volume, [stored.index(a) for a in "zyx"]))


def _no_axes_given(source: LabelSource, own: str, said: str) -> None:
    """Refuse meta.json's ``axes`` for a file that names its own (``own``, as ``said``)
    in another order of z, y and x."""
    if source.axes is not None and _spatial(source.axes.lower()) != _spatial(own.lower()):
        raise DatasetError(
            f"{source.path}: names its own axes ({said}: {own}), which "
            f'meta.json\'s "axes" {source.axes!r} contradicts; "axes" is for '
            "files that name none (a plain TIFF, npy, a zarr array, HDF5 "
            "without axistags): remove it"
        )


def file_names_axes(source: LabelSource) -> bool:
    """Whether a frame's file says which of its axes is which: an OME-TIFF, an ImageJ
    TIFF, NIfTI, an OME-Zarr image, HDF5 with ilastik's axistags; not a plain TIFF,
    npy, a zarr array or HDF5 without axistags (oftimg takes (z, y, x) there)."""
    path = Path(source.path)
    kind = label_suffix(path)
    if kind in (".nii", ".nii.gz"):
        return True
    if kind == ".npy":
        return False
    with _read_as(source, "a volume"):
        if kind in AXES_SUFFIXES:
            with _axes_array(path) as arr:
                return not arr.said.startswith(_UNNAMED)
        with _tiff(path, series=source.index is not None) as tif:
            return bool(tif.is_ome or tif.is_imagej)


def _three_d(shape, path: Path) -> tuple[int, int, int]:
    """``shape`` without axes of length 1 beyond three, or the error for a file
    that is not one 3-D volume."""
    dims = tuple(int(n) for n in shape)
    while len(dims) > 3 and 1 in dims:
        dims = tuple(np.delete(dims, dims.index(1)))
    if len(dims) != 3:
        raise DatasetError(
            f"{path}: a {len(dims)}-D array of shape {dims}; a frame is one 3-D "
            "label volume (z, y, x)"
        )
    return dims


def _series_shape(path: Path, axes: str | None = None) -> tuple[int, int, int, int]:
    """``(t, z, y, x)`` of a 4-D file (``axes``: meta.json's, where it names none)."""
    if label_suffix(path) in AXES_SUFFIXES:
        with _axes_array(path, axes) as arr:
            if "t" not in arr.axes:
                raise DatasetError(
                    f"{path}: axes {arr.axes} ({arr.said}) have no time; the "
                    "series file holds every frame, axes t, z, y, x"
                )
            return tuple(int(arr.data.shape[arr.axes.index(a)]) for a in "tzyx")
    with _tiff(path, series=True) as tif:
        source = LabelSource(str(path), 0, axes=axes)
        shape = _tiff_series_layout(tif, source, probe=True)[0]  # any channel
    if len(shape) != 4:
        raise DatasetError(
            f"{path}: a {len(shape)}-D array of shape {tuple(shape)}; "
            "the series file is 4-D, axes (t, z, y, x)"
        )
    return (int(shape[0]),) + _to_zyx(shape[1:], _frame_axes(source, path))


# series files kept open per process, their pages parsed once: (path, mtime, size) ->
# (TiffFile, its lock), the last used last
_OPEN_SERIES: OrderedDict = OrderedDict()
_OPEN_SERIES_LOCK = threading.Lock()
SERIES_KEPT_OPEN = 2


@atexit.register
def close_series_files() -> None:
    """Close the series files this process keeps open (:func:`_tiff`)."""
    with _OPEN_SERIES_LOCK:
        while _OPEN_SERIES:
            _, (tif, lock) = _OPEN_SERIES.popitem()
            with lock:
                tif.close()


@contextlib.contextmanager
def _tiff(path: Path, *, series: bool = False):
    """A TIFF file open for the ``with``; a ``series`` file (every frame in one) kept
    open in this process and parsed once: opened afresh for each frame, its OME-XML
    and every page were parsed again (195 frames of 54 planes took 48 s to check, 91
    s to validate against 16 s as files per frame: quadratic in the frames). Up to
    :data:`SERIES_KEPT_OPEN` are kept, keyed by path, time and size (a file written
    anew is opened anew); one reader at a time each."""
    import tifffile

    if not series:
        with tifffile.TiffFile(path) as tif:
            yield tif
        return
    stat = os.stat(path)
    key = (str(Path(path).resolve()), stat.st_mtime_ns, stat.st_size)
    with _OPEN_SERIES_LOCK:
        entry = _OPEN_SERIES.pop(key, None)
        if entry is None:
            entry = (tifffile.TiffFile(path), threading.Lock())
        _OPEN_SERIES[key] = entry
        while len(_OPEN_SERIES) > SERIES_KEPT_OPEN:
            _, (old, old_lock) = _OPEN_SERIES.popitem(last=False)
            with old_lock:
                old.close()
    tif, lock = entry
    with lock:
        if tif.filehandle.closed:  # closed by another thread meanwhile
            with tifffile.TiffFile(path) as fresh:
                yield fresh
        else:
            yield tif


# a class or channel axis longer than this is an axis of space read as channels
MAX_CLASSES = 16


def _swapped(axes: str, other: str) -> str:
    """``axes`` with ``c`` moved to where ``other`` is, the others in their order."""
    rest = axes.replace("c", "")
    at = axes.index(other)
    return rest[:at] + "c" + rest[at:]


def channel_count(source: LabelSource) -> int:
    """How many channels the frame's file has (its c axis; 1 without one)."""
    path = Path(source.path)
    _check_kind(path)
    with _read_as(source, "a volume"):
        if label_suffix(path) in AXES_SUFFIXES:
            with _axes_array(path, source.axes) as arr:
                if "c" not in arr.axes:
                    return 1
                n_c = int(arr.data.shape[arr.axes.index("c")])
                if n_c > MAX_CLASSES and arr.said.startswith(_UNNAMED):
                    short = [a for a, n in zip(arr.axes, arr.data.shape) if n <= MAX_CLASSES]
                    guess = (
                        (
                            f"; its {short[0]} axis, {arr.data.shape[arr.axes.index(short[0])]}"
                            f' long, looks like them: if so, write "axes": '
                            f'"{_swapped(arr.axes, short[0])}" in meta.json'
                        )
                        if short
                        else ""
                    )
                    raise DatasetError(
                        f"{path}: read in {arr.said} (axes {arr.axes}), its c axis, {n_c} long, "
                        f'would hold {n_c} classes{guess}; meta.json\'s "axes" gives the '
                        "order of a file's axes where it has no axistags"
                    )
                return n_c
        if label_suffix(path) in (".tif", ".tiff"):
            with _tiff(path, series=source.index is not None) as tif:
                axes = tif.series[0].axes
                return int(tif.series[0].shape[axes.index("C")]) if "C" in axes else 1
    return 1


def _tiff_has_channels(tif) -> bool:
    return (tif.is_ome or tif.is_imagej) and "C" in tif.series[0].axes


def _tiff_series_layout(
    tif, source: LabelSource, *, probe: bool = False
) -> tuple[tuple[int, ...], np.ndarray]:
    """A TIFF's shape ``(t, z, y, x)`` and its pages, ``(t, z)`` page indices, for
    channel ``source.channel``.

    An OME-TIFF's or ImageJ hyperstack's axes come from its metadata (Fiji,
    Bio-Formats and microscope software may store the planes z-major,
    ``DimensionOrder`` XYTZC, and interleave channels): its pages are taken in that
    order, never guessed from the shape. A plain TIFF is (t, z, y, x) as stored; an
    ImageJ or OME file of one frame, (z, y, x). ``probe``: any shape is returned (the
    caller names a wrong one)."""
    series = tif.series[0]
    shape, axes = tuple(int(n) for n in series.shape), series.axes
    path = tif.filehandle.path
    if "S" in axes:
        raise DatasetError(
            f"{path}: has colour samples (axes {axes}); a volume holds one value per voxel"
        )
    if not (tif.is_ome or tif.is_imagej):
        if len(shape) == 4:
            return shape, np.arange(shape[0] * shape[1]).reshape(shape[:2])
        if probe:
            return shape, np.zeros((0, 0), int)
        raise DatasetError(
            f"{path}: a {len(shape)}-D array of shape {shape}; the series file "
            "is 4-D, axes (t, z, y, x)"
        )
    lead = axes[:-2]
    if axes[-2:] != "YX" or not set(lead) <= set("TZC") or "Z" not in lead:
        raise DatasetError(
            f"{path}: axes {axes} ({'its OME-XML' if tif.is_ome else 'ImageJ'}); "
            "a volume has axes Z, Y, X (and T, C)"
        )
    pages = np.arange(int(np.prod(shape[: len(lead)]))).reshape(shape[: len(lead)])
    if "C" in lead:
        n_c, at = shape[lead.index("C")], lead.index("C")
        channel = 0 if probe and source.channel is None else _channel(source, n_c, axes)
        pages, lead = np.take(pages, channel, axis=at), lead.replace("C", "")
    elif source.channel not in (None, 0):
        raise DatasetError(
            f"{path}: has no channel axis (axes {axes}); channel {source.channel} is not there"
        )
    if lead == "ZT":  # z-major planes
        pages = pages.T
    elif lead == "Z":  # a single frame
        pages = pages[None]
    return (*pages.shape, *shape[-2:]), pages


def _channel(source: LabelSource, n_c: int, axes: str) -> int:
    """The channel ``source`` reads of a file with ``n_c`` channels (its only one
    when it names none), or the one-line error."""
    if source.channel is None:
        if n_c != 1:
            raise DatasetError(
                f"{source.path}: has {n_c} channels (axes {axes}); meta.json's "
                '"channels" says which holds what, e.g. {"intensity": 0, '
                '"labels": 1} (ilastik\'s probabilities go in probabilities/)'
            )
        return 0
    if not 0 <= source.channel < n_c:
        raise DatasetError(
            f"{source.path}: has channels 0-{n_c - 1} (axes {axes}); channel "
            f"{source.channel} is not there"
        )
    return source.channel


def _tiff_time_step(tif) -> float | None:
    """A series TIFF's frame interval in ms: an OME-TIFF's ``TimeIncrement`` (in its
    unit, seconds where none is given), an ImageJ hyperstack's ``finterval`` (s)."""
    if tif.is_ome:
        pixels = _ome_pixels(tif)
        if pixels is None or pixels.get("TimeIncrement") is None:
            return None
        return _time_ms(
            tif.filehandle.path,
            "OME TimeIncrementUnit",
            float(pixels.get("TimeIncrement")),
            pixels.get("TimeIncrementUnit", "s"),
        )
    meta = tif.imagej_metadata or {}
    return float(meta["finterval"]) * 1e3 if meta.get("finterval") else None


def _time_ms(path, what: str, value: float, unit: str) -> float:
    scale = TIME_UNITS_MS.get(str(unit).strip().lower())
    if scale is None:
        raise DatasetError(
            f"{path}: {what} {unit!r} is not a time oftimg knows ({', '.join(TIME_UNITS_MS)})"
        )
    return value * scale


def _tiff_voxel(tif) -> tuple[float, float, float] | None:
    """A TIFF's voxel size in mm: an OME-TIFF's ``PhysicalSizeX/Y/Z`` (each in its
    unit, micrometres where none is given, as the OME schema has it); an ImageJ
    TIFF's (x and y from the resolution tags, z from its ``spacing``); else None
    (another TIFF's resolution is a print setting)."""
    if tif.is_ome:
        return _ome_voxel(tif)
    meta = tif.imagej_metadata
    if not meta or "spacing" not in meta:
        return None
    unit = HEADER_UNITS_MM.get(str(meta.get("unit", "")).strip().lower())
    if unit is None:
        raise DatasetError(
            f"{tif.filehandle.path}: ImageJ unit {meta.get('unit')!r} is not a "
            f"length oftimg knows ({', '.join(HEADER_UNITS_MM)})"
        )
    tags = tif.pages[0].tags
    dx, dy = (tags[name].value[1] / tags[name].value[0] for name in ("XResolution", "YResolution"))
    return (dx * unit, dy * unit, float(meta["spacing"]) * unit)


def _ome_pixels(tif):
    """The ``Pixels`` element of an OME-TIFF's OME-XML (None without one)."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(tif.ome_metadata)
    except ET.ParseError as exc:
        raise DatasetError(f"{tif.filehandle.path}: its OME-XML cannot be read ({exc})") from None
    return next((e for e in root.iter() if e.tag.rsplit("}", 1)[-1] == "Pixels"), None)


def _ome_voxel(tif) -> tuple[float, float, float] | None:
    """An OME-TIFF's PhysicalSizeX, Y and Z in mm, or None unless all three are given."""
    pixels = _ome_pixels(tif)
    if pixels is None:
        return None
    sizes = []
    for axis in "XYZ":
        value = pixels.get(f"PhysicalSize{axis}")
        if value is None:
            return None
        unit = pixels.get(f"PhysicalSize{axis}Unit", "µm")
        scale = HEADER_UNITS_MM.get(unit.strip().lower())
        if scale is None:
            raise DatasetError(
                f"{tif.filehandle.path}: OME PhysicalSize{axis}Unit {unit!r} "
                f"is not a length oftimg knows ({', '.join(HEADER_UNITS_MM)})"
            )
        sizes.append(float(value) * scale)
    return tuple(sizes)


# an AxesArray's ``said`` where its file names no axes (oftimg's default order)
_UNNAMED = ("as oftimg reads", "ilastik order")


@contextlib.contextmanager
def _axes_array(path: Path, given: str | None = None):
    """The :class:`AxesArray` of an HDF5 file or a zarr store, open for as long as
    the ``with`` lasts; ``given``: meta.json's ``axes``, for an array that names none
    (refused for one that does)."""
    if label_suffix(path) == ".zarr":
        yield _given_axes(_zarr_array(path), given, path)
        return
    with _hdf5(path) as data:
        tagged = "axistags" in data.attrs
        yield _given_axes(
            AxesArray(
                data,
                hdf5_axes(data, path),
                None,
                None,
                "its axistags" if tagged else "ilastik order, no axistags",
                f"HDF5 ({data.name.lstrip('/')})",
            ),
            given,
            path,
        )


def _given_axes(arr: AxesArray, given: str | None, path: Path) -> AxesArray:
    """``arr`` with meta.json's ``given`` axes where its file names none."""
    if given is None:
        return arr
    if not arr.said.startswith(_UNNAMED):
        _no_axes_given(LabelSource(str(path), axes=given), arr.axes, arr.said)
        return arr
    if len(given) + 1 == arr.data.ndim and "t" not in given:
        given = "t" + given  # a series: its frames first
    return replace(arr, axes=_checked_axes(given, arr.data.shape, path), said="meta.json")


def _check_axes_frame(arr: AxesArray, source: LabelSource) -> None:
    """Refuse a per-frame file holding several frames, or a channel it lacks, before
    any voxel is read."""
    if source.index is None and "t" in arr.axes and arr.data.shape[arr.axes.index("t")] != 1:
        raise DatasetError(
            f"{source.path}: {arr.data.shape[arr.axes.index('t')]} frames in a "
            "file of one frame; a whole series is one file named as its folder "
            "(labels.ome.zarr, labels.h5)"
        )
    if "c" in arr.axes:
        _channel(source, int(arr.data.shape[arr.axes.index("c")]), arr.axes)
    elif source.channel not in (None, 0):
        raise DatasetError(
            f"{source.path}: has no channel axis (axes {arr.axes}); channel "
            f"{source.channel} is not there"
        )


def _axes_frame(arr: AxesArray, source: LabelSource) -> np.ndarray:
    """One frame's volume ``(z, y, x)`` of an array with named axes: frame
    ``source.index`` along t, channel ``source.channel`` along c; only those voxels
    are read."""
    _check_axes_frame(arr, source)
    where = []
    for axis in arr.axes:
        if axis == "t":
            where.append(source.index or 0)
        elif axis == "c":
            where.append(source.channel or 0)
        else:
            where.append(slice(None))
    kept = [a for a in arr.axes if a in "zyx"]
    return np.ascontiguousarray(
        np.transpose(np.asarray(arr.data[tuple(where)]), [kept.index(a) for a in "zyx"])
    )


@contextlib.contextmanager
def _hdf5(path: Path):
    """The volume array of an HDF5 file (ilastik's ``exported_data``, or the file's
    only array), open for as long as the ``with`` lasts."""
    try:
        import h5py
    except ImportError:
        raise DatasetError(f"{path}: reading HDF5 needs h5py: pip install 'oftimg[h5]'") from None
    with h5py.File(path, "r") as f:
        arrays = []
        f.visititems(
            lambda name, obj: arrays.append(name) if isinstance(obj, h5py.Dataset) else None
        )
        name = (
            ILASTIK_DATASET if ILASTIK_DATASET in f else (arrays[0] if len(arrays) == 1 else None)
        )
        if name is None:
            raise DatasetError(
                f"{path}: no '{ILASTIK_DATASET}' array (ilastik's export) and "
                f"{len(arrays)} others ({', '.join(arrays[:5]) or 'none'}); "
                "oftimg reads the file's one volume array"
            )
        yield f[name]


def hdf5_axes(data, path: Path) -> str:
    """An HDF5 array's axes, ``"tzyxc"`` or a part of it, from ilastik's ``axistags``
    attribute (never guessed from the shape where it is given); without it, ilastik's
    order by the number of axes (zyx, zyxc, tzyxc)."""
    tags = data.attrs.get("axistags")
    if tags is not None:
        try:
            axes = "".join(a["key"] for a in json.loads(tags)["axes"]).lower()
        except (ValueError, KeyError, TypeError) as exc:
            raise DatasetError(f"{path}: its axistags cannot be read ({printable(exc)})") from None
    else:
        axes = {3: "zyx", 4: "zyxc", 5: "tzyxc"}.get(data.ndim, "")
    return _checked_axes(axes, data.shape, path)


def _checked_axes(axes: str, shape, path: Path) -> str:
    """``axes`` once they name each of the array's axes once, z, y and x among them."""
    if (
        len(axes) != len(shape)
        or not set("zyx") <= set(axes)
        or not set(axes) <= set(AXIS_NAMES)
        or len(set(axes)) != len(axes)
    ):
        raise DatasetError(
            f"{path}: an array of shape {tuple(shape)} with axes "
            f"{axes or 'not given'}; a volume has axes z, y, x (and t, c)"
        )
    return axes


def _zarr_array(path: Path) -> AxesArray:
    """A zarr store's volume: an OME-Zarr image (the first multiscale's full-resolution
    array, its axes, voxel size and time step from the ``multiscales`` metadata of
    OME-Zarr 0.4 or 0.5), or a plain array (axes t, z, y, x or z, y, x as oftimg
    reads it)."""
    try:
        import zarr
    except ImportError:
        raise DatasetError(
            f"{path}: reading a zarr store needs zarr: pip install "
            f"'oftimg[{'ome' if path.name.endswith('.ome.zarr') else 'zarr'}]'"
        ) from None
    node = zarr.open(str(path), mode="r")
    if hasattr(node, "shape"):
        axes = {3: "zyx", 4: "tzyx"}.get(len(node.shape), "")
        return AxesArray(
            node,
            _checked_axes(axes, node.shape, path),
            None,
            None,
            "as oftimg reads a plain zarr array",
            "zarr array",
        )
    attrs = node.attrs.asdict()
    ome = attrs.get("ome", attrs)
    multiscales = ome.get("multiscales")
    if not (isinstance(multiscales, list) and multiscales and isinstance(multiscales[0], dict)):
        raise DatasetError(
            f'{path}: a zarr group without OME-Zarr "multiscales" metadata; '
            "oftimg reads an OME-Zarr image or one zarr array"
        )
    image = multiscales[0]
    version = ome.get("version") or image.get("version", "")
    try:
        described = [a if isinstance(a, dict) else {"name": a} for a in image["axes"]]
        level = image["datasets"][0]
        data = node[level["path"]]
    except (KeyError, IndexError, TypeError) as exc:
        raise DatasetError(
            f"{path}: its OME-Zarr multiscales metadata lacks "
            f"{printable(exc) or 'axes or datasets'}"
        ) from None
    letters = [_axis_letter(a) for a in described]
    axes = _checked_axes(
        "".join(letters) if all(letters) else ",".join(str(a.get("name")) for a in described),
        data.shape,
        path,
    )
    units = {letter: a.get("unit") for letter, a in zip(axes, described)}
    scale = np.ones(len(axes))
    for transforms in (
        level.get("coordinateTransformations", []),
        image.get("coordinateTransformations", []),
    ):
        for transform in transforms:
            if transform.get("type") == "scale":
                scale = scale * np.asarray(transform["scale"], float)
    voxel = None
    if all(units.get(a) for a in "xyz"):
        voxel = tuple(float(scale[axes.index(a)]) * _length_mm(path, a, units[a]) for a in "xyz")
    step = None
    if "t" in axes and units.get("t"):
        step = _time_ms(path, "OME-Zarr t axis unit", float(scale[axes.index("t")]), units["t"])
    return AxesArray(
        data,
        axes,
        voxel,
        step,
        f"its OME-Zarr {version} multiscales".replace("  ", " "),
        f"OME-Zarr {version}".strip(),
    )


def _axis_letter(axis: dict) -> str:
    """An OME-Zarr axis as one of ``tczyx``: its name, or its type for a time or
    channel axis named otherwise ("" for neither)."""
    name = str(axis.get("name", "")).lower()
    if name in AXIS_NAMES and len(name) == 1:
        return name
    return {"time": "t", "channel": "c"}.get(axis.get("type"), "")


def _length_mm(path: Path, axis: str, unit: str) -> float:
    scale = HEADER_UNITS_MM.get(str(unit).strip().lower())
    if scale is None:
        raise DatasetError(
            f"{path}: OME-Zarr {axis} axis unit {unit!r} is not a length oftimg "
            f"knows ({', '.join(HEADER_UNITS_MM)})"
        )
    return scale


def _nifti(path: Path):
    try:
        import nibabel
    except ImportError:
        raise DatasetError(
            f"{path}: reading NIfTI needs nibabel: pip install 'oftimg[nifti]'"
        ) from None
    return nibabel.load(str(path))


def _nifti_voxel(img) -> tuple[float, float, float] | None:
    """A NIfTI file's voxel size in mm from its ``pixdim`` and ``xyzt_units``
    (a file without a unit says mm, as the NIfTI standard reads it)."""
    unit = img.header.get_xyzt_units()[0]
    scale = 1.0 if unit in ("unknown", None) else HEADER_UNITS_MM.get(unit)
    if scale is None:
        raise DatasetError(f"{img.get_filename()}: NIfTI unit {unit!r} is not a length")
    zooms = img.header.get_zooms()[:3]
    return tuple(float(d) * scale for d in zooms)
