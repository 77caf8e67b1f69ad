"""Label volume files: one frame's volume read as an array ``(z, y, x)``, and the
voxel size the file itself carries.

Formats: one 3-D file per frame (TIFF or OME-TIFF, NIfTI through nibabel, ``.npy``),
or one 4-D file for the whole series (``labels.tif`` with axes (t, z, y, x), as ImageJ
writes a hyperstack; ``labels.ome.tif``, its axes and voxel size from its OME-XML; or a
``labels.zarr`` array). Headers are read without the
voxels, so that a whole series is checked before any frame is meshed; a frame's
voxels are read when it is meshed (a TIFF page range, a memory map, a zarr chunk),
so a worker holds one volume at a time.
"""
from __future__ import annotations

import contextlib
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DatasetError
from .safefile import file_status

PER_FRAME_SUFFIXES = (".tif", ".tiff", ".nii", ".nii.gz", ".npy", ".h5", ".hdf5")
SERIES_NAMES = ("labels.tif", "labels.tiff", "labels.ome.tif", "labels.ome.tiff", "labels.zarr",
                "labels.h5")
HDF5_SUFFIXES = (".h5", ".hdf5")
ILASTIK_DATASET = "exported_data"          # where ilastik's export puts its array
# length units as TIFF (ImageJ) and NIfTI headers spell them, in mm
HEADER_UNITS_MM = {"mm": 1.0, "millimeter": 1.0, "um": 1e-3, "micron": 1e-3, "µm": 1e-3,
                   "\u00b5m": 1e-3, "\u03bcm": 1e-3, "microns": 1e-3, "micrometer": 1e-3,
                   "nm": 1e-6, "meter": 1e3, "m": 1e3}


@dataclass(frozen=True)
class LabelSource:
    """Where one frame's volume lies: a file, or frame ``index`` of a 4-D file."""

    path: str
    index: int | None = None
    channel: int | None = None        # of an HDF5 export's channel axis (ilastik's classes)

    def __str__(self) -> str:
        where = [] if self.index is None else [f"frame {self.index}"]
        where += [] if self.channel is None else [f"channel {self.channel}"]
        return f"{self.path} ({', '.join(where)})" if where else self.path


@dataclass(frozen=True)
class VolumeHeader:
    """What a file says about a frame without its voxels: ``shape (z, y, x)``, the
    stored dtype, and its own voxel size ``(dx, dy, dz)`` in mm (None: it gives none)."""

    shape: tuple[int, int, int]
    dtype: np.dtype
    voxel_size_mm: tuple[float, float, float] | None


def label_suffix(path: Path) -> str:
    """The file's format suffix, ``.nii.gz`` as one."""
    name = path.name.lower()
    return ".nii.gz" if name.endswith(".nii.gz") else path.suffix.lower()


def series_names(folder: Path) -> tuple[str, ...]:
    """The names a 4-D file may have in ``folder``: ``labels.tif`` ..., or the
    folder's own name (``intensity/intensity.zarr``)."""
    own = tuple(folder.name + suffix for suffix in (".tif", ".tiff", ".ome.tif", ".ome.tiff",
                                                    ".zarr", ".h5", ".hdf5"))
    return tuple(dict.fromkeys(SERIES_NAMES + own))


def series_file(folder: Path) -> Path | None:
    """The 4-D file of a ``labels/`` folder, or None for one file per frame."""
    found = [folder / n for n in series_names(folder) if (folder / n).exists()]
    return found[0] if found else None


def list_label_sources(folder: Path, natural_key, what: str = "label volumes"
                       ) -> list[LabelSource]:
    """The frames of a ``labels/`` folder (or another of volumes, ``what`` they are)
    in time order: each frame of its 4-D file, or its per-frame files in natural
    order (one format only)."""
    series = series_file(folder)
    if series is not None:
        _check_kind(series)
        with _read_as(series, "a 4-D series"):
            n_t = _series_shape(series)[0]
        return [LabelSource(str(series), t) for t in range(n_t)]
    files = sorted((p for p in folder.iterdir() if not p.name.startswith(".")
                    and label_suffix(p) in PER_FRAME_SUFFIXES),
                   key=lambda p: natural_key(p.name))
    if not files:
        raise DatasetError(f"{folder}: no {what} (one file per frame: "
                           f"{', '.join(PER_FRAME_SUFFIXES)}; or one 4-D "
                           f"{' or '.join(series_names(folder))})")
    kinds = sorted({label_suffix(p).replace(".tiff", ".tif") for p in files})
    if len(kinds) > 1:
        raise DatasetError(f"{folder}: mixes {' and '.join(kinds)} files; a series is one "
                           "format, so that the frames' order is plain")
    return [LabelSource(str(p)) for p in files]


def read_header(source: LabelSource) -> VolumeHeader:
    """The frame's shape, dtype and voxel size from its file's header."""
    path = Path(source.path)
    _check_kind(path)
    with _read_as(source, "a volume"):
        return _read_header(source, path)


def _read_header(source: LabelSource, path: Path) -> VolumeHeader:
    """:func:`read_header` by the file's own reader (its errors unwrapped)."""
    kind = label_suffix(path)
    if kind in HDF5_SUFFIXES:
        with _hdf5(path) as data:
            axes = hdf5_axes(data, path)
            shape = tuple(int(data.shape[axes.index(a)]) for a in "zyx")
            return VolumeHeader(shape, data.dtype, None)
    if source.index is not None:
        shape = _series_shape(path)
        return VolumeHeader(tuple(shape[1:]), _series_dtype(path), _series_voxel(path))
    if kind == ".npy":
        arr = np.load(path, mmap_mode="r")
        return VolumeHeader(_three_d(arr.shape, path), arr.dtype, None)
    if kind in (".nii", ".nii.gz"):
        img = _nifti(path)
        shape = _three_d(img.shape, path)[::-1]                   # (x, y, z) -> (z, y, x)
        return VolumeHeader(shape, img.header.get_data_dtype(), _nifti_voxel(img))
    import tifffile
    with tifffile.TiffFile(path) as tif:
        series = tif.series[0]
        return VolumeHeader(_three_d(series.shape, path), series.dtype, _tiff_voxel(tif))


def describe_format(source: LabelSource) -> dict:
    """What a frame's file is, for a person checking their input: ``format`` (its
    kind, one file per frame or one for the series), ``axes`` as the file gives them
    (or as oftimg reads a format that gives none) and ``voxel_size`` (whether the
    file carries one)."""
    path = Path(source.path)
    kind = label_suffix(path)
    series = source.index is not None
    where = "one file for every frame" if series else "one file per frame"
    carries = read_header(source).voxel_size_mm is not None
    if kind in HDF5_SUFFIXES:
        with _read_as(source, "an HDF5 volume"), _hdf5(path) as data:
            name, axes = data.name.lstrip("/"), hdf5_axes(data, path)
            tagged = "axistags" in data.attrs
        return {"format": f"HDF5 ({name}), {where}",
                "axes": f"{axes} ({'its axistags' if tagged else 'ilastik order, no axistags'})",
                "file_voxel_size": False}
    if kind == ".zarr":
        return {"format": f"zarr, {where}", "axes": "tzyx (as oftimg reads zarr)",
                "file_voxel_size": False}
    if kind in (".nii", ".nii.gz"):
        return {"format": f"NIfTI, {where}", "axes": "xyz (its header), turned to zyx",
                "file_voxel_size": carries}
    if kind == ".npy":
        return {"format": f"npy, {where}", "axes": "zyx (as oftimg reads npy)",
                "file_voxel_size": False}
    import tifffile
    with _read_as(source, "a TIFF"), tifffile.TiffFile(path) as tif:
        name = "OME-TIFF" if tif.is_ome else "ImageJ TIFF" if tif.is_imagej else "TIFF"
        if tif.is_ome or tif.is_imagej:
            axes = tif.series[0].axes.lower()
            said = "its OME-XML" if tif.is_ome else "its ImageJ metadata"
        else:                                   # tifffile's letters say nothing: Q, I
            axes, said = ("tzyx" if series else "zyx"), "as oftimg reads a plain TIFF"
    return {"format": f"{name}, {where}", "axes": f"{axes} ({said})",
            "file_voxel_size": carries}


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
        raise DatasetError(f"{source}: cannot be read as {what}: damaged, or not what its "
                           f"name says ({_reader_says(exc)})") from None
    finally:
        logger.disabled = disabled


def _reader_says(exc: BaseException) -> str:
    """What a reader's exception says, as ``"tifffile says: ..."``."""
    reader = {"tifffile": "tifffile", "nibabel": "nibabel", "zarr": "zarr",
              "numcodecs": "zarr", "h5py": "h5py"}.get(type(exc).__module__.split(".")[0], "the reader")
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
    if label_suffix(path) in HDF5_SUFFIXES:
        with _hdf5(path) as data:
            return _hdf5_frame(data, hdf5_axes(data, path), source)
    if source.index is not None:
        if label_suffix(path) == ".zarr":
            return np.asarray(_zarr(path)[source.index])
        import tifffile
        with tifffile.TiffFile(path) as tif:
            shape, pages = _tiff_series_layout(tif)
            return tif.asarray(key=pages[source.index].tolist()).reshape(shape[1:])
    kind = label_suffix(path)
    if kind == ".npy":
        data = np.load(path, mmap_mode="r")
        return np.asarray(data).reshape(_three_d(data.shape, path))
    if kind in (".nii", ".nii.gz"):
        data = np.asanyarray(_nifti(path).dataobj)
        return np.ascontiguousarray(data.reshape(data.shape[:3]).transpose(2, 1, 0))
    import tifffile
    data = tifffile.imread(path)
    return data.reshape(_three_d(data.shape, path))


def _three_d(shape, path: Path) -> tuple[int, int, int]:
    """``shape`` without axes of length 1 beyond three, or the error for a file
    that is not one 3-D volume."""
    dims = tuple(int(n) for n in shape)
    while len(dims) > 3 and 1 in dims:
        dims = tuple(np.delete(dims, dims.index(1)))
    if len(dims) != 3:
        raise DatasetError(f"{path}: a {len(dims)}-D array of shape {dims}; a frame is one 3-D "
                           "label volume (z, y, x)")
    return dims


def _series_shape(path: Path) -> tuple[int, int, int, int]:
    """``(t, z, y, x)`` of a 4-D file."""
    if label_suffix(path) in HDF5_SUFFIXES:
        with _hdf5(path) as data:
            axes = hdf5_axes(data, path)
            if "t" not in axes:
                raise DatasetError(f"{path}: axes {axes} (its axistags) have no time; the "
                                   "series file holds every frame, axes t, z, y, x")
            shape = tuple(int(data.shape[axes.index(a)]) for a in "tzyx")
    elif label_suffix(path) == ".zarr":
        shape = _zarr(path).shape
    else:
        import tifffile
        with tifffile.TiffFile(path) as tif:
            shape = _tiff_series_layout(tif)[0]
    if len(shape) != 4:
        raise DatasetError(f"{path}: a {len(shape)}-D array of shape {tuple(shape)}; "
                           "the series file is 4-D, axes (t, z, y, x)")
    return tuple(int(n) for n in shape)


def _tiff_series_layout(tif) -> tuple[tuple[int, ...], np.ndarray]:
    """A 4-D TIFF's shape ``(t, z, y, x)`` and its pages, ``(t, z)`` page indices.

    An OME-TIFF's axes come from its metadata (Fiji, Bio-Formats and microscope
    software may store the planes z-major, ``DimensionOrder`` XYTZC): its pages are
    taken in that order, never guessed from the shape. An ImageJ hyperstack or a
    plain TIFF is (t, z, y, x) as stored; an ImageJ file of one frame, (z, y, x)."""
    series = tif.series[0]
    shape, axes = tuple(int(n) for n in series.shape), series.axes
    path = tif.filehandle.path
    if "C" in axes or "S" in axes:
        raise DatasetError(f"{path}: has channels (axes {axes}); a label series has "
                           "axes (t, z, y, x)")
    if tif.is_ome and len(shape) == 4:
        if sorted(axes) != sorted("TZYX") or axes[-2:] != "YX":
            raise DatasetError(f"{path}: OME axes {axes}; a series is a time series of "
                               "3-D volumes, axes T, Z, Y, X (in any order of T and Z)")
        lead = axes[:2]
        pages = np.arange(shape[0] * shape[1]).reshape(shape[:2])
        if lead == "ZT":                                  # z-major planes
            pages, shape = pages.T, (shape[1], shape[0], *shape[2:])
        return shape, pages
    if len(shape) == 3 and (tif.is_imagej or tif.is_ome):   # a single frame
        shape = (1, *shape)
    if len(shape) != 4:
        return shape, np.zeros((0, 0), int)           # refused by the caller, named there
    return shape, np.arange(shape[0] * shape[1]).reshape(shape[:2])


def _series_dtype(path: Path) -> np.dtype:
    if label_suffix(path) == ".zarr":
        return np.dtype(_zarr(path).dtype)
    import tifffile
    with tifffile.TiffFile(path) as tif:
        return tif.series[0].dtype


def _series_voxel(path: Path):
    if label_suffix(path) == ".zarr":
        return None
    import tifffile
    with tifffile.TiffFile(path) as tif:
        return _tiff_voxel(tif)


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
        raise DatasetError(f"{tif.filehandle.path}: ImageJ unit {meta.get('unit')!r} is not a "
                           f"length oftimg knows ({', '.join(HEADER_UNITS_MM)})")
    tags = tif.pages[0].tags
    dx, dy = (tags[name].value[1] / tags[name].value[0] for name in ("XResolution", "YResolution"))
    return (dx * unit, dy * unit, float(meta["spacing"]) * unit)


def _ome_voxel(tif) -> tuple[float, float, float] | None:
    """An OME-TIFF's PhysicalSizeX, Y and Z in mm, or None unless all three are given."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(tif.ome_metadata)
    except ET.ParseError as exc:
        raise DatasetError(f"{tif.filehandle.path}: its OME-XML cannot be read ({exc})") \
            from None
    pixels = next((e for e in root.iter() if e.tag.rsplit("}", 1)[-1] == "Pixels"), None)
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
            raise DatasetError(f"{tif.filehandle.path}: OME PhysicalSize{axis}Unit {unit!r} "
                               f"is not a length oftimg knows ({', '.join(HEADER_UNITS_MM)})")
        sizes.append(float(value) * scale)
    return tuple(sizes)


@contextlib.contextmanager
def _hdf5(path: Path):
    """The volume array of an HDF5 file (ilastik's ``exported_data``, or the file's
    only array), open for as long as the ``with`` lasts."""
    try:
        import h5py
    except ImportError:
        raise DatasetError(f"{path}: reading HDF5 needs h5py: pip install 'oftimg[h5]'") \
            from None
    with h5py.File(path, "r") as f:
        arrays = []
        f.visititems(lambda name, obj: arrays.append(name) if isinstance(obj, h5py.Dataset)
                     else None)
        name = ILASTIK_DATASET if ILASTIK_DATASET in f else (arrays[0] if len(arrays) == 1
                                                              else None)
        if name is None:
            raise DatasetError(f"{path}: no '{ILASTIK_DATASET}' array (ilastik's export) and "
                               f"{len(arrays)} others ({', '.join(arrays[:5]) or 'none'}); "
                               "oftimg reads the file's one volume array")
        yield f[name]


def hdf5_axes(data, path: Path) -> str:
    """An HDF5 array's axes, ``"tzyxc"`` or a part of it, from ilastik's ``axistags``
    attribute (never guessed from the shape where it is given); without it, ilastik's
    order by the number of axes (zyx, zyxc, tzyxc)."""
    import json

    tags = data.attrs.get("axistags")
    if tags is not None:
        try:
            axes = "".join(a["key"] for a in json.loads(tags)["axes"]).lower()
        except (ValueError, KeyError, TypeError) as exc:
            raise DatasetError(f"{path}: its axistags cannot be read ({printable(exc)})") \
                from None
    else:
        axes = {3: "zyx", 4: "zyxc", 5: "tzyxc"}.get(data.ndim, "")
    if len(axes) != data.ndim or not set("zyx") <= set(axes) or not set(axes) <= set("tzyxc"):
        raise DatasetError(f"{path}: an array of shape {tuple(data.shape)} with axes "
                           f"{axes or 'not given'}; a volume has axes z, y, x (and t, c)")
    return axes


def hdf5_channels(path: Path) -> int:
    """How many channels an HDF5 volume file has (its c axis; 1 without one)."""
    _check_kind(path)
    with _read_as(path, "an HDF5 volume"), _hdf5(path) as data:
        axes = hdf5_axes(data, path)
        return int(data.shape[axes.index("c")]) if "c" in axes else 1


def _hdf5_frame(data, axes: str, source: LabelSource) -> np.ndarray:
    """One frame's volume ``(z, y, x)`` of an HDF5 array with ``axes``: frame
    ``source.index`` along t, channel ``source.channel`` along c (a label export's one
    channel when None)."""
    where = []
    for axis in axes:
        if axis == "t":
            n_t = data.shape[axes.index("t")]
            if source.index is None and n_t != 1:
                raise DatasetError(f"{source.path}: {n_t} frames in a file of one frame; a "
                                   "whole series is one file named as its folder (labels.h5)")
            where.append(source.index or 0)
        elif axis == "c":
            n_c = data.shape[axes.index("c")]
            if source.channel is None and n_c != 1:
                raise DatasetError(f"{source.path}: {n_c} channels; a label volume has one "
                                   "(ilastik's probabilities go in probabilities/)")
            where.append(source.channel or 0)
        else:
            where.append(slice(None))
    kept = [a for a in axes if a in "zyx"]
    return np.ascontiguousarray(np.transpose(data[tuple(where)],
                                             [kept.index(a) for a in "zyx"]))


def _zarr(path: Path):
    """The zarr array at ``path``, opened read-only."""
    try:
        import zarr
    except ImportError:
        raise DatasetError(f"{path}: reading a zarr store needs zarr: pip install "
                           "'oftimg[zarr]'") from None
    return zarr.open(str(path), mode="r")


def _nifti(path: Path):
    try:
        import nibabel
    except ImportError:
        raise DatasetError(f"{path}: reading NIfTI needs nibabel: pip install "
                           "'oftimg[nifti]'") from None
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
