"""The dataset contract's units and numbers: length units, voxel sizes, JSON numbers,
and the natural order of frame files (shared by mesh, label and intensity folders)."""

from __future__ import annotations

import re

import numpy as np

from ..errors import DatasetError

UNIT_TO_MM = {"mm": 1.0, "um": 1e-3}
VOXEL_MM_RANGE = (1e-5, 10.0)


def natural_key(name: str):
    """Sort key that puts ``f2`` before ``f10``."""
    return [int(tok) if tok.isdigit() else tok.lower() for tok in re.split(r"(\d+)", name)]


def is_number(x) -> bool:
    """A JSON number (not a bool) that is finite."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and bool(np.isfinite(x))


def check_voxel_size(path, voxel: list, to_mm: float) -> tuple[float, float, float]:
    """A voxel size (meta.json's, or a file's own, named by ``path``), checked: three
    numbers in a unit of ``to_mm`` mm, each side from 10 nm to 10 mm, the longest at
    most 100 times the shortest."""
    ok = len(voxel) == 3 and all(is_number(x) and x > 0 for x in voxel)
    if not ok:
        raise DatasetError(
            f"{path}: voxel_size must be three positive numbers [dx, dy, dz] "
            f"in length_unit (the files' coordinates are voxel indices), "
            f"found {str(voxel)[:60]}"
        )
    mm = [float(x) * to_mm for x in voxel]
    if min(mm) < VOXEL_MM_RANGE[0] or max(mm) > VOXEL_MM_RANGE[1] or max(mm) > 100 * min(mm):
        raise DatasetError(
            f"{path}: voxel_size {[float(x) for x in voxel]} is "
            f"{', '.join(f'{d:.3g}' for d in mm)} mm: each side must lie between "
            f"{VOXEL_MM_RANGE[0]:g} and {VOXEL_MM_RANGE[1]:g} mm, the longest at "
            "most 100 times the shortest (is length_unit right?)"
        )
    return tuple(float(x) for x in voxel)
