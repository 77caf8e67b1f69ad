"""Intensity volumes: the images a segmentation was made from (OCT), one 3-D volume
per frame in a dataset's ``intensity/`` folder, for pulling the tissue's texture back
onto the grid (:mod:`oftimg.analysis.pullback`).

Layout::

    DATASET/
      intensity/  one 3-D volume per frame (.tif/.tiff, .nii/.nii.gz, .npy, ...), or one
                  4-D intensity.tif / intensity.ome.zarr ... with axes (t, z, y, x), as
                  labels/ holds them (oftimg.io.labelfile); or, in a label dataset, a
                  channel of the labels' stack (meta.json's "channels")
      meta.json   for a mesh dataset: "intensity": {"voxel_size": [dx, dy, dz],
                  "origin": [x, y, z]} in length_unit, where voxel (k, j, i) lies
                  at origin + (i dx, j dy, k dz) in the meshes' coordinates

A label dataset's intensity lies on its labels' voxel grid (same shape, same voxel
size, origin 0): meta.json gives nothing more. Headers are checked before any frame
is read; a frame's voxels are read when it is sampled.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DatasetError
from .units import UNIT_TO_MM, check_voxel_size, is_number, natural_key
from .labelfile import LabelSource, list_label_sources, read_header, read_volume

FOLDER = "intensity"
SPACING_TOLERANCE = 1e-3  # relative: a file's voxel size and the labels' agree


@dataclass(frozen=True)
class IntensitySeries:
    """A dataset's intensity volumes: one source per frame (in the frames' order),
    every frame's ``shape (z, y, x)``, ``voxel_size (dx, dy, dz)`` and ``origin (x, y,
    z)`` in mm (the meshes' coordinates times the dataset's unit scale)."""

    folder: Path
    sources: tuple[LabelSource, ...]
    shape: tuple[int, int, int]
    voxel_size_mm: tuple[float, float, float]
    origin_mm: tuple[float, float, float]

    @property
    def n_frames(self) -> int:
        return len(self.sources)

    def volume(self, t: int) -> np.ndarray:
        """Frame ``t``'s intensity ``(z, y, x)`` float32, as stored (no scaling)."""
        return np.asarray(read_volume(self.sources[t]), dtype=np.float32)


def load_intensity(
    path: str | Path,
    n_frames: int,
    length_unit: str,
    raw_meta: dict,
    *,
    labels_grid: tuple | None = None,
    sources: list | None = None,
) -> IntensitySeries | None:
    """The dataset's ``intensity/`` checked from its headers: one volume per frame
    (``n_frames``), every frame one shape, whole or real numbers. ``labels_grid``
    (``(shape (z, y, x), voxel_size (dx, dy, dz))`` in ``length_unit``) for a label
    dataset: the volumes lie on it; else meta.json's ``"intensity"`` gives their
    voxel size and origin. ``sources``: the frames' intensity as a channel of the
    labels' stack, instead of ``intensity/``. None when there is neither. Raises one
    :class:`DatasetError` naming the file and what is wrong."""
    path = Path(path)
    folder = path / FOLDER
    if sources is None:
        if not folder.is_dir():
            return None
        sources = list_label_sources(
            folder, natural_key, what="intensity volumes", axes=raw_meta.get("axes")
        )
    else:
        folder = Path(sources[0].path).parent
    if len(sources) != n_frames:
        raise DatasetError(
            f"{folder}: {len(sources)} volumes for a dataset of {n_frames} "
            "frames; intensity/ holds one volume per frame, in the frames' "
            "order"
        )
    headers = [read_header(s) for s in sources]
    for source, header in zip(sources, headers):
        if not (
            np.issubdtype(header.dtype, np.integer) or np.issubdtype(header.dtype, np.floating)
        ):
            raise DatasetError(
                f"{source}: {header.dtype} voxels; an intensity volume holds whole or real numbers"
            )
        if header.shape != headers[0].shape:
            raise DatasetError(
                f"{source}: a volume of shape (z, y, x) {header.shape}, but the "
                f"first frame's is {headers[0].shape}; every frame has one shape"
            )
    to_mm = UNIT_TO_MM[length_unit]
    given = raw_meta.get("intensity")
    if labels_grid is not None:
        if given is not None:
            raise DatasetError(
                f'{path / "meta.json"}: "intensity" places the volumes; a '
                "label dataset's intensity/ lies on its labels' voxels (remove "
                "it)"
            )
        shape, voxel = labels_grid
        if headers[0].shape != tuple(shape):
            raise DatasetError(
                f"{sources[0]}: a volume of shape (z, y, x) {headers[0].shape}, "
                f"but the labels' is {tuple(shape)}; intensity/ lies on the "
                "labels' voxels"
            )
        own = headers[0].voxel_size_mm
        if own is not None and not np.allclose(
            np.array(own) / to_mm, voxel, rtol=SPACING_TOLERANCE, atol=0
        ):
            raise DatasetError(
                f"{sources[0]}: its voxel size "
                f"{', '.join(f'{d / to_mm:.4g}' for d in own)} {length_unit} "
                f"disagrees with the labels' "
                f"{', '.join(f'{d:.4g}' for d in voxel)}; intensity/ lies on "
                "the labels' voxels"
            )
        return IntensitySeries(
            folder,
            tuple(sources),
            headers[0].shape,
            tuple(float(d) * to_mm for d in voxel),
            (0.0, 0.0, 0.0),
        )
    voxel, origin = _placement(path / "meta.json", given, to_mm)
    return IntensitySeries(folder, tuple(sources), headers[0].shape, voxel, origin)


def _placement(meta_path: Path, given, to_mm: float) -> tuple[tuple, tuple]:
    """A mesh dataset's ``"intensity": {"voxel_size", "origin"}`` in mm, checked."""
    if not isinstance(given, dict):
        raise DatasetError(
            f'{meta_path}: the dataset has intensity/ but no "intensity": '
            '{"voxel_size": [dx, dy, dz], "origin": [x, y, z]} (in '
            "length_unit, the meshes' coordinates of voxel (0, 0, 0))"
        )
    unknown = set(given) - {"voxel_size", "origin"}
    if unknown:
        raise DatasetError(
            f'{meta_path}: "intensity" has unknown key '
            f"{sorted(unknown)[0][:40]!r}; allowed: voxel_size, origin"
        )
    voxel = check_voxel_size(meta_path, list(given.get("voxel_size") or []), to_mm)
    origin = given.get("origin", [0.0, 0.0, 0.0])
    if not (
        isinstance(origin, list)
        and len(origin) == 3
        and all(map(is_number, origin))
        and max(abs(x) * to_mm for x in origin) < 1e4
    ):
        raise DatasetError(
            f'{meta_path}: "intensity" origin must be three numbers [x, y, '
            f"z] in length_unit, found {str(origin)[:60]}"
        )
    return (tuple(d * to_mm for d in voxel), tuple(float(x) * to_mm for x in origin))
