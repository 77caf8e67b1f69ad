"""Writing results: a staged output folder that only appears when complete, JSON, npz."""
from __future__ import annotations

import contextlib
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np


def check_output_location(out: Path, inputs: list[Path], *, overwrite: bool) -> None:
    """Refuse an ``out`` inside an input folder, or an existing non-empty one."""
    out_r = out.resolve()
    for src in inputs:
        src_r = src.resolve()
        if out_r == src_r or src_r in out_r.parents:
            raise ValueError(f"--out {out} is inside the input {src}; "
                             "oftimg never writes into a dataset folder")
        if out_r in src_r.parents:
            raise ValueError(f"--out {out} contains the input {src}; choose another folder")
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} exists and is not a folder")
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise ValueError(f"--out {out} exists and is not empty; pass --overwrite to replace it")


@contextlib.contextmanager
def staged_output(out: str | Path, *, overwrite: bool = False):
    """Yield a temporary folder beside ``out``; move it to ``out`` on success.

    On an exception the temporary folder is removed and ``out`` is untouched,
    so a failed run never leaves results that look complete.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=out.parent))
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if out.exists():
        if any(out.iterdir()) and not overwrite:
            shutil.rmtree(tmp, ignore_errors=True)
            raise FileExistsError(f"{out}: appeared while running and is not empty")
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
        out.rename(old / "previous")
        tmp.rename(out)
        shutil.rmtree(old, ignore_errors=True)
    else:
        tmp.rename(out)


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return None if not np.isfinite(obj) else float(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path: Path, data: dict) -> None:
    """JSON with NaN written as null."""
    path.write_text(json.dumps(_jsonable(data), indent=2) + "\n")


def write_arrays(folder: Path, arrays: dict[str, np.ndarray], described: dict[str, dict]) -> None:
    """``arrays.npz`` plus ``arrays.json`` giving each array's dims and unit."""
    missing = set(arrays) - set(described)
    if missing:
        raise ValueError(f"arrays without a description: {sorted(missing)}")
    np.savez_compressed(folder / "arrays.npz", **arrays)
    desc = {k: dict(described[k], shape=list(np.shape(v)), dtype=str(np.asarray(v).dtype))
            for k, v in arrays.items()}
    write_json(folder / "arrays.json", desc)


def write_dataset_results(folder: Path, result: dict) -> None:
    """``summary.json``, ``grids.npz`` (float32 mm, (n_u, n_v, n_t, 3)), figures/, videos/."""
    (folder / "figures").mkdir(exist_ok=True)
    (folder / "videos").mkdir(exist_ok=True)
    grids = {w: g.X.astype(np.float32) for w, g in result["grids"].items()}
    np.savez_compressed(folder / "grids.npz", **grids)
    write_json(folder / "summary.json", result["summary"])
