"""Writing results: a staged output folder that only appears when complete, the
datasets a run has finished (for --resume), JSON, npz."""

from __future__ import annotations

import warnings

import contextlib
import functools
import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import InputError
from ..analysis.group_maps import AROUND_TUBE_MAPS, TESTED_MAPS
from ..image.kymograph import RIDGE_SMOOTHING_MS


# what a run writes beside the datasets' folders (report, html, api._write_run)
COHORT_OUTPUTS = (
    "table1.csv",
    "table1.md",
    "cohort.csv",
    "qc.csv",
    "columns.csv",
    "groups.csv",
    "cohort_maps.npz",
    "cohort_maps.json",
    "figures",
    "index.html",
    "run.json",
)
# what older versions wrote there, which --overwrite replaces too
OLDER_COHORT_OUTPUTS = ("cohort.md",)
# what a file browser leaves in any folder it shows
BROWSER_FILES = (".DS_Store", "Thumbs.db", "desktop.ini")


def not_written_by_oftimg(folder: Path, kind: str = "results") -> list[str]:
    """Names in ``folder`` that oftimg did not write, which --overwrite must not
    delete. ``kind`` "results": a run's or cohort's output (the cohort files and
    one folder per dataset with its summary.json); "demo data": the demo's
    phantom datasets (folders with a truth.json)."""
    marker = {"results": "summary.json", "demo data": "truth.json"}[kind]
    own = COHORT_OUTPUTS + OLDER_COHORT_OUTPUTS if kind == "results" else ()
    return sorted(
        p.name
        for p in folder.iterdir()
        if p.name not in own + BROWSER_FILES
        and not (p.is_dir() and not p.is_symlink() and (p / marker).is_file())
    )


def check_replaceable(out: Path, kind: str = "results") -> None:
    """Refuse to replace an ``out`` holding anything oftimg did not write."""
    foreign = not_written_by_oftimg(out, kind)
    if foreign:
        shown = ", ".join(foreign[:5]) + (
            f" and {len(foreign) - 5} more" if len(foreign) > 5 else ""
        )
        raise InputError(
            f"--out {out}: --overwrite replaces only oftimg's own {kind}, and "
            f"this folder also holds {shown}, which oftimg did not write; move "
            "them away or choose another folder"
        )


def check_output_location(
    out: Path, inputs: list[Path], *, overwrite: bool, kind: str | None = "results"
) -> None:
    """Refuse an ``out`` inside an input folder, or an existing non-empty one; with
    ``overwrite``, one that holds anything oftimg did not write as ``kind`` (None:
    ``out`` itself is not replaced, only what is written inside it)."""
    out_r = out.resolve()
    for src in inputs:
        src_r = src.resolve()
        if out_r == src_r or src_r in out_r.parents:
            raise InputError(
                f"--out {out} is inside the input {src}; oftimg never writes into a dataset folder"
            )
        if out_r in src_r.parents:
            raise InputError(f"--out {out} contains the input {src}; choose another folder")
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} exists and is not a folder")
    if out.exists() and any(out.iterdir()):
        if not overwrite:
            raise InputError(
                f"--out {out} exists and is not empty; pass --overwrite "
                "(overwrite=True in Python) to replace it"
            )
        if kind is not None:
            check_replaceable(out, kind)


def require_new_folder(out: Path) -> None:
    """Refuse an ``out`` that exists and is not an empty folder (the commands
    that make datasets never replace anything)."""
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError(f"{out}: exists and is not an empty folder; choose another one")


@contextlib.contextmanager
def staged_output(out: str | Path, *, overwrite: bool = False, kind: str = "results"):
    """Yield a temporary folder beside ``out``; move it to ``out`` on success.

    On an exception the temporary folder is removed and ``out`` is untouched,
    so a failed run never leaves results that look complete. With ``overwrite``
    an existing ``out`` is replaced only if oftimg wrote all of it, as ``kind``
    (:func:`check_replaceable`), checked again at the swap.
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
        try:
            if any(out.iterdir()) and not overwrite:
                raise FileExistsError(f"{out}: appeared while running and is not empty")
            check_replaceable(out, kind)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
        out.rename(old / "previous")
        tmp.rename(out)
        shutil.rmtree(old, ignore_errors=True)
    else:
        tmp.rename(out)


def link_or_copy(src, dst) -> None:
    """A hard link ``dst`` to ``src``, or a copy where links fail (another file
    system); for ``shutil.copytree(copy_function=...)``. Writing to ``dst`` in
    place then writes ``src`` too: replace such files, never rewrite them."""
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def finished_folder(out: Path) -> Path:
    """Where a run keeps each dataset's complete results until it succeeds
    (beside ``out``, hidden): what ``resume`` reuses."""
    out = Path(out)
    return out.parent / f".{out.name}.finished"


@functools.cache
def _source_digest() -> str:
    """SHA-256 of oftimg's Python source files (~1 ms)."""
    package = Path(__file__).parent
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


class Finished:
    """Each dataset's complete results, ``root/<name>/``, with ``root/<name>.json``
    recording the inputs, options and version they were made from and the summary."""

    def __init__(self, root: Path):
        self.root = root

    @staticmethod
    def fingerprint(ds, opts, fps: float, figures: bool = True) -> dict:
        """What a dataset's results are made from: its input files (sizes and
        modification times), the options, fps, whether figures are drawn, and oftimg's
        version and source (so that a development install's changed code is not taken for
        the same)."""
        stats = [(str(p.resolve()), p.stat()) for p in ds.input_files()]  # any cwd
        return {
            "oftimg_version": __version__,
            "oftimg_source": _source_digest(),
            "options": opts.as_dict(),
            "fps": fps,
            "figures": figures,
            "period_ms": ds.meta.period_ms,
            "inputs": [[p, st.st_size, st.st_mtime_ns] for p, st in stats],
        }

    def summary_if_current(self, name: str, fingerprint: dict) -> dict | None:
        """The summary of ``name``'s kept results if they were made from ``fingerprint``."""
        marker = self.root / f"{name}.json"
        if not (marker.is_file() and (self.root / name / "summary.json").is_file()):
            return None
        try:
            record = json.loads(marker.read_text())
        except ValueError:
            return None
        return record["summary"] if record.get("fingerprint") == fingerprint else None

    def writing(self, name: str) -> Path:
        """An empty folder to write ``name``'s results into, then :meth:`keep`."""
        folder = self.root / f"{name}.writing"
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        return folder

    def keep(self, name: str, fingerprint: dict, summary: dict) -> None:
        """Make the results written into :meth:`writing` the kept ones."""
        (self.root / f"{name}.json").unlink(missing_ok=True)
        shutil.rmtree(self.root / name, ignore_errors=True)
        (self.root / f"{name}.writing").rename(self.root / name)
        record = {"fingerprint": fingerprint, "summary": jsonable(summary, keep_nan=True)}
        (self.root / f"{name}.json").write_text(json.dumps(record))  # NaN as NaN, not null

    def names(self) -> list[str]:
        return sorted(p.stem for p in self.root.glob("*.json")) if self.root.is_dir() else []

    def copy_into(self, name: str, folder: Path) -> None:
        """``name``'s kept results into ``folder/<name>`` (hard links where possible)."""
        shutil.copytree(self.root / name, folder / name, copy_function=link_or_copy)

    def remove(self) -> None:
        shutil.rmtree(self.root, ignore_errors=True)

    @contextlib.contextmanager
    def locked(self, out: Path):
        """Hold the folder for one run (an advisory lock, released when the process
        ends, however it ends): a second run into the same ``out`` stops at once
        instead of writing over this one's datasets."""
        try:
            import fcntl
        except ImportError:  # not POSIX: no lock
            yield
            return
        self.root.mkdir(parents=True, exist_ok=True)
        with open(self.root / ".lock", "w") as fh:
            try:
                fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                raise FileExistsError(
                    f"--out {out}: another oftimg run is writing its results "
                    f"(it holds {self.root / '.lock'}); wait for it to end or "
                    "choose another --out"
                ) from None
            yield


def jsonable(obj, *, keep_nan: bool = False):
    """``obj`` with NumPy scalars and arrays as Python numbers and lists, paths as
    strings; NaN and infinities as None (null), or kept with ``keep_nan``."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v, keep_nan=keep_nan) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v, keep_nan=keep_nan) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist(), keep_nan=keep_nan)
    if isinstance(obj, (np.floating, float)):
        return float(obj) if keep_nan or np.isfinite(obj) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path: Path, data: dict) -> None:
    """JSON with NaN written as null."""
    path.write_text(json.dumps(jsonable(data), indent=2) + "\n")


# float32 results are stored with this many of their 23 mantissa bits (relative
# precision 2^-16 = 1.5e-5: 0.03 um on a 2 mm coordinate, far under the meshes' noise);
# the bits dropped are noise to zlib, which then saves a third instead of a tenth
MANTISSA_BITS_KEPT = 15
# an array whose own noise is measured (a field's noise SD, oftimg.analysis.pipeline)
# keeps fewer: its rounding error at most this share of that noise
NOISE_SHARE_KEPT = 0.1
MANTISSA_BITS_LEAST = 6


def mantissa_bits(values: np.ndarray, noise_sd: float | None) -> int:
    """The mantissa bits an array keeps: :data:`MANTISSA_BITS_KEPT`, or fewer where
    its measured ``noise_sd`` (same unit) allows, so that the largest rounding error,
    ``max |x| 2^-(bits + 1)``, stays under :data:`NOISE_SHARE_KEPT` of the noise (the
    dropped bits are noise to zlib; none of the field's information is in them)."""
    finite = np.abs(np.asarray(values, float)[np.isfinite(values)])
    if not finite.size or noise_sd is None or not np.isfinite(noise_sd) or noise_sd <= 0:
        return MANTISSA_BITS_KEPT
    largest = float(finite.max())
    if largest == 0:
        return MANTISSA_BITS_KEPT
    bits = int(np.ceil(np.log2(largest / (NOISE_SHARE_KEPT * noise_sd)))) - 1
    return int(np.clip(bits, MANTISSA_BITS_LEAST, MANTISSA_BITS_KEPT))


def measured_noise(summary: dict, arrays: dict) -> dict[str, float]:
    """The noise SD of each stored field that the analysis measured, in the field's
    unit: the smoothed fields' remaining noise (``field_noise``), and the strain
    energies' and principal stretches' (``strain_noise``: the share by which the nodes'
    noise moves the energy, times its median; the median change it makes in the
    stretches)."""
    noise = {
        k: v.get("noise_sd_smoothed")
        for k, v in (summary.get("field_noise") or {}).items()
        if k in arrays
    }
    for k, v in (summary.get("strain_noise") or {}).items():
        if k in arrays and np.isfinite(v.get("error_share", np.nan)):
            noise[k] = float(v["error_share"] * np.nanmedian(np.abs(arrays[k])))
        stretch = k.replace("strain_energy_", "principal_stretch_")
        if stretch in arrays:
            noise[stretch] = v.get("stretch_noise_median")
    return {k: float(v) for k, v in noise.items() if v is not None and np.isfinite(v)}


def bit_round(values: np.ndarray, keep: int = MANTISSA_BITS_KEPT) -> np.ndarray:
    """A float32 array rounded (half to even) to ``keep`` mantissa bits, as netCDF's
    BitRound does; other dtypes, NaN and infinities unchanged."""
    values = np.asarray(values)
    if values.dtype != np.float32 or keep >= 23:
        return values
    drop = 23 - keep
    bits = np.ascontiguousarray(values).view(np.uint32)
    kept_lsb = (bits >> np.uint32(drop)) & np.uint32(1)
    rounded = (bits + np.uint32((1 << (drop - 1)) - 1) + kept_lsb) & np.uint32(
        (0xFFFFFFFF << drop) & 0xFFFFFFFF
    )
    return np.where(np.isfinite(values), rounded.view(np.float32), values)


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """``arrays`` as a compressed ``.npz`` (zip, deflate level 1) that ``np.load``
    reads as any other: a fast level, because the higher ones save under 2 % more
    on these float arrays and take several times as long."""
    import zipfile

    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        for name, value in arrays.items():
            with zf.open(f"{name}.npy", "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, np.asanyarray(value), allow_pickle=False)


def write_arrays(
    folder: Path,
    files: dict[str, dict[str, np.ndarray]],
    described: dict[str, dict],
    made_on_load: dict[str, dict] | None = None,
    noise: dict[str, float] | None = None,
) -> None:
    """Each of ``files`` (file name -> its arrays) as ``folder/<file name>`` (npz),
    and one ``arrays.json`` giving every array's dims, unit and meaning
    (``described``), its file, shape and dtype, and the precision it is stored to; and
    the entries ``made_on_load`` (arrays not stored, which
    :func:`~oftimg.output.results.load_results` makes from stored ones: described in
    full, with what they are made from). ``noise``: an array's measured noise SD,
    which lets it keep fewer mantissa bits (:func:`mantissa_bits`)."""
    missing = {k for arrays in files.values() for k in arrays} - set(described)
    if missing:
        raise ValueError(f"arrays without a description: {sorted(missing)}")
    desc, noise = {}, noise or {}
    for file, arrays in files.items():
        bits = {k: mantissa_bits(v, noise.get(k)) for k, v in arrays.items()}
        write_npz(folder / file, {k: bit_round(v, bits[k]) for k, v in arrays.items()})
        desc.update(
            {
                k: dict(
                    described[k],
                    file=file,
                    shape=list(np.shape(v)),
                    dtype=str(np.asarray(v).dtype),
                    **_precision(v, bits[k], noise.get(k)),
                )
                for k, v in arrays.items()
            }
        )
    desc.update(made_on_load or {})
    write_json(folder / "arrays.json", desc)


def _precision(values, bits: int, noise_sd: float | None) -> dict:
    """What arrays.json says of a float32 array's stored precision."""
    if np.asarray(values).dtype != np.float32:
        return {}
    said = {"mantissa_bits": bits, "relative_precision": 2.0 ** -(bits + 1)}
    if bits < MANTISSA_BITS_KEPT:
        said.update(
            noise_sd=noise_sd,
            rounding_error_max=float(np.nanmax(np.abs(values)) * 2.0 ** -(bits + 1)),
        )
    return said


WALLS = ("outer", "inner", "lumen")
CLIPPED = "_clipped"
CLIPPED_ON_LOAD = (
    "not stored: made on load from the wall's grid, clip_v, plane_origin_mm "
    "and plane_normal (oftimg.mesh.clip.clipped_grids), as the run made it"
)


# the cohort's maps on one grid (cohort_maps.npz): name -> (dims, unit, description)
COHORT_MAPS = {
    "names": (["embryo"], "", "dataset names, in the cohort table's order"),
    "groups": (["embryo"], "", "each dataset's group"),
    "position_fraction": (["position"], "1", "s / tube length: 0 at the inlet, 1 at the outlet"),
    "cycle_fraction": (["phase"], "1", "t / period: 0 at the minimum outer volume"),
    "area_outer_mm2": (
        ["embryo", "position", "phase"],
        "mm^2",
        "outer area map (area_outer_mm2) resampled linearly onto the common grid, periodic in time",
    ),
    "area_outer_normalized": (
        ["embryo", "position", "phase"],
        "1",
        "each row of the outer area map over its maximum, resampled likewise",
    ),
    "wall_thickness_mm": (
        ["embryo", "position", "phase"],
        "mm",
        "the myocardial wall's mean thickness around the tube, resampled "
        "likewise (NaN for a dataset without an inner wall)",
    ),
    "jelly_thickness_mm": (
        ["embryo", "position", "phase"],
        "mm",
        "the cardiac jelly's mean thickness around the tube (inner wall "
        "to lumen), resampled likewise (NaN for a dataset without an "
        "inner wall and a lumen)",
    ),
    "strain_energy_outer": (
        ["embryo", "position", "phase"],
        "1",
        "the outer wall's strain energy against t = 0 "
        "(strain_energy_outer), mean around the tube, resampled likewise",
    ),
    "comparisons": (
        ["comparison"],
        "",
        "each other group against the first (normals first): 'banded - normal'",
    ),
}
for _key in TESTED_MAPS:
    _unit = COHORT_MAPS[_key][1]
    COHORT_MAPS[f"{_key}_difference"] = (
        ["comparison", "position", "phase"],
        _unit,
        f"difference of the two groups' means of {_key} (first group minus second)",
    )
    COHORT_MAPS[f"{_key}_p_fwer"] = (
        ["comparison", "position", "phase"],
        "1",
        "two-sided p-value of that difference, corrected over the whole map (max-statistic "
        "permutation test; NaN with fewer than 2 embryos in a group)",
    )
    COHORT_MAPS[f"{_key}_p_cluster"] = (
        ["comparison", "position", "phase"],
        "1",
        "p-value of the cluster of pixels each pixel belongs to, corrected over the whole "
        "map (cluster-mass permutation test, clusters of uncorrected p <= cluster_alpha "
        "joined across the cycle's ends; 1 outside clusters, NaN as p_fwer)",
    )
COHORT_MAPS["cluster_alpha"] = (
    [],
    "1",
    "cluster-forming threshold of the *_p_cluster maps: the uncorrected p a pixel's "
    "|difference| must reach to join a cluster (--cluster-alpha, default 0.05)",
)


def cohort_maps(
    results: Path, summaries: list[dict], *, cluster_alpha: float = 0.05
) -> dict[str, np.ndarray]:
    """Every dataset's outer area map (and each row over its maximum) and the mean
    around the tube of each field of :data:`AROUND_TUBE_MAPS` (NaN where a dataset
    has none) on one grid of position and cycle fractions
    (:mod:`oftimg.analysis.group_maps`), read from ``results/<name>/arrays.npz``, and
    where the groups differ in the maps of :data:`TESTED_MAPS`: the arrays of
    :data:`COHORT_MAPS`, clusters formed at uncorrected p <= ``cluster_alpha``."""
    from ..analysis.group_maps import common_grid, group_differences, on_common_grid, row_normalized
    from ..analysis.fields import mean_around_tube

    position, phase = common_grid()
    missing = np.full((len(position), len(phase)), np.nan)
    stacks = {key: [] for key in ("area_outer_mm2", "area_outer_normalized", *AROUND_TUBE_MAPS)}
    for s in summaries:
        with np.load(Path(results) / s["name"] / "arrays.npz") as a:
            grid = (a["s_mm"], a["t_ms"], s["period_ms"])
            stacks["area_outer_mm2"].append(on_common_grid(a["area_outer_mm2"], *grid))
            stacks["area_outer_normalized"].append(
                on_common_grid(row_normalized(a["area_outer_mm2"]), *grid)
            )
            for key in AROUND_TUBE_MAPS:
                stacks[key].append(
                    on_common_grid(mean_around_tube(a[key]), *grid) if key in a.files else missing
                )
    maps = {
        "names": np.array([s["name"] for s in summaries]),
        "groups": np.array([s["group"] for s in summaries]),
        "position_fraction": position,
        "cycle_fraction": phase,
        **{key: np.array(stack) for key, stack in stacks.items()},
    }
    for key in TESTED_MAPS:
        compared = group_differences(maps[key], maps["groups"], cluster_alpha=cluster_alpha)
        names = compared.pop("names")  # the same groups for every map
        maps.update({f"{key}_{what}": value for what, value in compared.items()})
    maps["comparisons"] = np.array(names, dtype=str)
    maps["cluster_alpha"] = np.array(float(cluster_alpha))
    return maps


def write_cohort_maps(folder: Path, maps: dict[str, np.ndarray]) -> None:
    """``cohort_maps.npz`` and ``cohort_maps.json`` (dims, unit, meaning of each)."""
    write_npz(folder / "cohort_maps.npz", maps)
    write_json(
        folder / "cohort_maps.json",
        {
            k: {
                "dims": dims,
                "unit": unit,
                "description": text,
                "shape": list(maps[k].shape),
                "dtype": str(maps[k].dtype),
            }
            for k, (dims, unit, text) in COHORT_MAPS.items()
        },
    )


def describe_array(name: str, *, map_positions: str = "rows") -> dict:
    """Dims (u, v, t order) and unit of an array in ``arrays.npz`` / ``grids.npz``;
    ``map_positions`` as in the run's options."""
    # long, and kept whole: a table of every array (the data dictionary of the npz
    # files), not logic
    fixed = {
        "s_mm": (
            ["v"],
            "mm",
            "arc length from the inlet along the outer contours' centroid line, time average",
        ),
        "s_rows_mm": (
            ["v", "t"],
            "mm",
            "arc length from the inlet along the outer contours' "
            "centroid line of each grid row in each frame",
        ),
        "t_ms": (
            ["t"],
            "ms",
            "time since the minimum outer volume of each sample (with --warp: "
            "two segments, maximum expansion at the middle sample)",
        ),
        "clip_v": (["t"], "1", "v of the Lagrangian clipping plane (constant myocardial volume)"),
        "surface_speed_outer_mm_s": (
            ["u", "v", "t"],
            "mm/s",
            "texture tracking: the outer wall's tissue's speed along "
            "its surface (the tracked node's velocity less its part along the normal)",
        ),
        "surface_divergence_outer_per_s": (
            ["u", "v", "t"],
            "1/s",
            "texture tracking: the outer wall's rate of local area "
            "change, d ln(l1 l2) / dt of its principal stretches (positive: spreading)",
        ),
        "pathlines_uv": (
            ["u", "v", "t", "uv"],
            "grid steps",
            "where each tracked node's tissue lies in each frame's own grid "
            "(around from the seam, along from the inlet; around not wrapped): "
            "the tracked fields are each frame's read there",
        ),
        "texture_support": (
            ["u", "v", "t"],
            "1",
            "texture tracking: the local correlation of the beat's template "
            "with each frame's texture along the node's pathline (1 a "
            "perfect match, about 0 none): the node's confidence",
        ),
        "texture_fallback": (
            ["u", "v", "t"],
            "bool",
            "texture tracking: the node follows the shape alone along or "
            "around the tube in that frame (the texture did not match "
            "better with its own motion than without it)",
        ),
        "grid_in_view": (
            ["u", "v", "t"],
            "bool",
            "texture tracking: the node's tissue lies within the imaged part of "
            "the tube in that frame (outside it, and one node beside it along "
            "the tube, the per-pixel fields are NaN)",
        ),
        "pullback_outer_mean": (
            ["u_fine", "v_fine", "t"],
            "intensity",
            "the intensity volumes' mean across the myocardium (from the outer to the inner "
            "wall at --pullback-layers depths, default 5; a dataset without an inner wall: "
            "across --pullback-shell-um about the outer wall along its normal, default 10 um "
            "either side) on each frame's own grid refined to about a pixel a voxel "
            "(u_fine: n_u times f_u around from the seam, v_fine: (n_v - 1) f_v + 1 from the "
            "inlet); in the volumes' own values; NaN where the shell leaves the volume",
        ),
        "pullback_outer_max": (
            ["u_fine", "v_fine", "t"],
            "intensity",
            "the same, the maximum across the myocardium",
        ),
        "pullback_inner_mean": (
            ["u_fine", "v_fine", "t"],
            "intensity",
            "--pullback-walls inner: the intensity volumes' mean across --pullback-shell-um "
            "about the inner wall along its normal (the jelly's edge), on each frame's own "
            "inner grid refined as pullback_outer_mean's",
        ),
        "pullback_inner_max": (["u_fine", "v_fine", "t"], "intensity", "the same, the maximum"),
        "pullback_lumen_mean": (
            ["u_fine", "v_fine", "t"],
            "intensity",
            "--pullback-walls lumen: the same about the lumen's wall, on each frame's own "
            "lumen grid",
        ),
        "pullback_lumen_max": (["u_fine", "v_fine", "t"], "intensity", "the same, the maximum"),
        "trim_percent": (["t"], "%", "trim distance along the centroid line, % of its length"),
        "volume_myocardium_mm3": (["t"], "mm^3", "outer minus inner capped volume"),
        "volume_jelly_mm3": (["t"], "mm^3", "the cardiac jelly: inner minus lumen capped volume"),
        "area_jelly_mm2": (
            ["v", "t"],
            "mm^2",
            "the cardiac jelly's section area: area_inner_mm2 minus area_lumen_mm2",
        ),
        "lumen_closed": (
            ["v", "t"],
            "bool",
            "the lumen closed: its section's area at most 2 % "
            "of its row's largest over the cycle (the cushions apposed)",
        ),
        "lumen_aspect_ratio": (
            ["v", "t"],
            "1",
            "the lumen section's minor over major axis, "
            "from its area's second moments; NaN where closed",
        ),
        "lumen_major_axis_deg": (
            ["v", "t"],
            "deg",
            "the lumen section's major axis, in [0, "
            "180) from its seam (u = 0) turning as u does; NaN where "
            "closed or round (aspect over 0.95)",
        ),
        "lumen_close_ms": (
            ["v"],
            "ms",
            "when each row's lumen closes (its longest closure; NaN in rows that never close)",
        ),
        "lumen_open_ms": (["v"], "ms", "when each row's lumen opens again after it"),
        "lumen_closed_share": (["v"], "1", "the share of the cycle each row's lumen is closed"),
        "jelly_at_cushions_mm": (
            ["v", "t"],
            "mm",
            "the cardiac jelly's thickness at the "
            "cushions: jelly_thickness_mm's mean over the inner nodes "
            "within 22.5 deg of the lumen's minor axis",
        ),
        "jelly_between_cushions_mm": (
            ["v", "t"],
            "mm",
            "the same about the lumen's major axis (between the cushions)",
        ),
        "centroid_outer_mm": (["v", "t", "xyz"], "mm", "centroids of the outer section contours"),
        "plane_origin_mm": (["v", "t", "xyz"], "mm", "a point of each cross-section plane"),
        "plane_normal": (
            ["v", "t", "xyz"],
            "1",
            "unit normal of each cross-section plane, towards the outlet",
        ),
        "plane_crossing": (
            ["v", "t"],
            "bool",
            "planes that still cross another inside the tube after blending (should be all False)",
        ),
    }
    fixed.update(
        {
            "ridge_t_ms": (
                ["v"],
                "ms",
                "time of each row's maximum outer area, the row smoothed "
                "in time by summary.ridge_smoothing_ms (sub-frame, unwrapped)",
            ),
            "local_speed_mm_s": (
                ["v"],
                "mm/s",
                "local peristaltic wave speed ds/dt along the ridge "
                "(7-row least-squares slope; negative: backwards)",
            ),
            "ridge_t_noise_sd_ms": (
                ["v"],
                "ms",
                "spread (SD) of ridge_t_ms over copies of the "
                "outer area map with its frame-to-frame noise drawn again "
                "(area_noise_sd_outer_mm2); errors that do not change from "
                "frame to frame are not in it",
            ),
            "local_speed_noise_sd_mm_s": (
                ["v"],
                "mm/s",
                "spread (SD) of local_speed_mm_s over the "
                "same draws; NaN: not finite in 10 % of them",
            ),
            "ridge_bridged": (
                ["v"],
                "1",
                "1 where the row barely moves (area swing under 0.7 of "
                "the median row's, a neck): its ridge time is not the wave's, and "
                "the speeds bridge it with the ridge's line between the nearest "
                "moving rows; else 0",
            ),
            "area_noise_sd_outer_mm2": (
                ["v"],
                "mm^2",
                "SD of each row's frame-to-frame noise in the "
                "outer area map (mean power of its high harmonics in time)",
            ),
        }
    )
    if name in fixed:
        dims, unit, text = fixed[name]
        return {"dims": dims, "unit": unit, "description": text}
    if name == "corner_count_per_row":
        return {
            "dims": ["v"],
            "unit": "1",
            "description": "curvature maxima around the outer "
            "contour at each row's minimum-area frame (curvature averaged over 5 frames "
            "around it, smoothed over 1/40 of the contour)",
        }
    fields = {
        "radial_curvature_{w}_per_mm": (
            "1/mm",
            "signed in-plane curvature of the {w} section "
            "contours (each section's own polygon at the "
            "scale summary.field_noise names; smoothed in "
            "time by summary.field_smoothing_ms)",
        ),
        "radial_curvature_{w}_band95_per_mm": (
            "1/mm",
            "half the width of each node's 95 % "
            "band of radial_curvature_{w}_per_mm: "
            "the noise the frames show and what its "
            "scale may not resolve there, widened as "
            "calibrated on the phantom zoo",
        ),
        "strain_energy_{w}": (
            "1",
            "(l1-1)^2 + (l2-1)^2 of the {w} grid against t = 0 (its "
            "nodes smoothed in time by summary.strain_smoothing_ms; "
            "the lift its nodes' noise gives a square taken off: "
            "summary.strain_noise.bias_removed)",
        ),
        "strain_energy_{w}_band95": (
            "1",
            "half the width of each node's 95 % band of "
            "strain_energy_{w}: its nodes' noise, as measured "
            "by adding it once more, widened as calibrated on "
            "the phantom zoo",
        ),
        "wall_thickness_mm": (
            "mm",
            "myocardial wall thickness: distance from each outer grid "
            "node to its inner node (carried towards the row's "
            "centre), negative where the inner wall lies outside the "
            "outer one; smoothed in time by "
            "summary.field_smoothing_ms",
        ),
        "jelly_thickness_mm": (
            "mm",
            "cardiac jelly thickness: distance from each inner grid "
            "node on along the line from its outer node to the "
            "lumen, negative where the lumen lies outside the inner "
            "wall; smoothed in time by summary.field_smoothing_ms",
        ),
        "mean_curvature_lumen_per_mm": (
            "1/mm",
            "mean curvature of the lumen at its grid's "
            "nodes: half its sections' normal curvature "
            "(each section's own polygon at the scale "
            "summary.field_noise names) and the normal "
            "curvature across them; smoothed in time by "
            "summary.field_smoothing_ms",
        ),
        "mean_curvature_lumen_band95_per_mm": (
            "1/mm",
            "half the width of each node's 95 % "
            "band of mean_curvature_lumen_per_mm, "
            "as the radial curvatures' bands",
        ),
    }
    for w in WALLS:
        for pattern, (unit, text) in fields.items():
            f = pattern.format(w=w)
            if name == f:
                return {"dims": ["u", "v", "t"], "unit": unit, "description": text.format(w=w)}
            for which in ("max", "min"):
                if name == f"phase_{which}_{f}_ms":
                    return {
                        "dims": ["u", "v"],
                        "unit": "ms",
                        "description": f"time of each pixel's {which}imum of {f} "
                        f"(smoothed in time by {RIDGE_SMOOTHING_MS:g} ms, "
                        "a curvature or a thickness by "
                        "summary.field_smoothing_ms "
                        "and a strain by summary.strain_smoothing_ms "
                        "if more; sub-frame)",
                    }
        if name == f"principal_stretch_{w}":
            return {
                "dims": ["u", "v", "t", "l1,l2"],
                "unit": "1",
                "description": f"principal stretches of the {w} grid against t = 0 "
                "(its nodes smoothed in time by summary.strain_smoothing_ms)",
            }
    per_wall = {
        "activation_time_{w}_ms": (
            ["u", "v"],
            "ms",
            "when the {w} wall at each node moves "
            "outward fastest: the steepest rise of the first harmonic "
            "of its distance from its ring's centre over the cycle "
            "(sub-frame; the wave's arrival, as optical mapping's "
            "activation time)",
        ),
        "activation_sd_{w}_ms": (
            ["u", "v"],
            "ms",
            "SD of activation_time_{w}_ms from the "
            "node's frame-to-frame noise (its high harmonics)",
        ),
        "wave_velocity_{w}_mm_s": (
            ["u", "v", "along,around"],
            "mm/s",
            "the wave's velocity on the {w} wall: the activation "
            "times' gradient on the wall (its mean shape's metric, the "
            "times smoothed over summary.wave_fronts.smoothing_nodes "
            "nodes) turned into speed along it; components along the "
            "tube (towards the outlet) and around it (towards "
            "increasing u)",
        ),
        "phase_{w}": (
            ["u", "v", "t"],
            "rad",
            "each node's phase of its motion in the cycle (0 at its activation, -pi to pi)",
        ),
        "max_area_{w}_mm2": (["v"], "mm^2", "maximum over the cycle of the {w} area"),
        "expanded_fraction_75_{w}": (
            ["v"],
            "1",
            "share of the cycle with {w} area >= 75 % of its maximum",
        ),
        "expanded_fraction_sigma_{w}": (
            ["v"],
            "1",
            "share of the cycle within one sigma of the "
            "{w} area's peak (Gaussian fit; NaN: no fit)",
        ),
        "expanded_mask_75_{w}": (["v", "t"], "bool", "cells with {w} area >= 75 % of the row max"),
        "expanded_mask_sigma_{w}": (["v", "t"], "bool", "cells within one sigma of the row's peak"),
        "crossing_75_{w}_ms": (
            ["up/down", "v"],
            "ms",
            "times the {w} area rises above and falls below 75 % of its maximum (periodic)",
        ),
        "gaussian_sigma_{w}_ms": (["v"], "ms", "sigma of the Gaussian fitted to the {w} area"),
        "gaussian_fit_r2_{w}": (["v"], "1", "R^2 of that Gaussian fit"),
        "volume_from_sections_{w}_mm3": (
            ["t"],
            "mm^3",
            "sum over slabs of mean {w} section area x slab thickness (a check on volume_{w}_mm3)",
        ),
        "section_from_ring_{w}": (
            ["v", "t"],
            "bool",
            "{w} sections measured on the grid ring "
            "projected onto the plane (no clean "
            "contour; should be rare)",
        ),
    }
    for w in WALLS:
        for pattern, (dims, unit, text) in per_wall.items():
            if name == pattern.format(w=w):
                return {"dims": dims, "unit": unit, "description": text.format(w=w)}
    for w in WALLS:
        if name == f"area_{w}_mm2":
            where = (
                "at grid row v"
                if map_positions == "rows"
                else f"at the fraction s_mm / s_mm[-1] of each frame's centroid line, "
                f"interpolated (cubic spline) from area_rows_{w}_mm2"
            )
            return {
                "dims": ["v", "t"],
                "unit": "mm^2",
                "description": f"area inside the {w} section contour, {where}",
            }
        if name == f"area_rows_{w}_mm2":
            return {
                "dims": ["v", "t"],
                "unit": "mm^2",
                "description": f"area inside the {w} section contour at grid row v",
            }
        if name == f"volume_{w}_mm3":
            return {
                "dims": ["t"],
                "unit": "mm^3",
                "description": f"volume inside the {w} wall closed by its end caps",
            }
        if name == f"contour_{w}_mm":
            return {
                "dims": ["u", "v", "t", "xyz"],
                "unit": "mm",
                "description": f"{w} section contours, n_u points evenly spaced by arc "
                "length from the seam, in u order",
            }
        if name == w:
            return {
                "dims": ["u", "v", "t", "xyz"],
                "unit": "mm",
                "description": f"{w} grid G_t(u, v), Eulerian (fixed window)",
            }
        if name == f"{w}_clipped":
            return {
                "dims": ["u", "v_clipped", "t", "xyz"],
                "unit": "mm",
                "description": f"{w} grid clipped at the Lagrangian plane and resampled "
                "by arc length along each u-line: v_clipped from the "
                "plane (0) to the outlet (1)",
            }
    raise KeyError(f"no description for array {name!r}")


def describe_pca(name: str) -> dict:
    """Dims and unit of an array in ``pca.npz`` (``pca_row{k}_{phase}_{what}``)."""
    what = {
        "mean_mm": (["u", "xy"], "mm", "mean contour in its plane (Karcher mean, SRVF)"),
        "displacement_mm": (
            ["mode", "u", "xy"],
            "mm",
            "displacement of the mean contour at +1 sd of each mode",
        ),
        "explained": (["mode"], "1", "share of the total shape variance"),
        "scores": (["contour", "mode"], "SRVF", "each contour's coordinates on the modes"),
    }
    for key, (dims, unit, text) in what.items():
        if name.endswith(key):
            return {"dims": dims, "unit": unit, "description": text}
    raise KeyError(f"no description for array {name!r}")


def write_dataset_results(
    folder: Path,
    result: dict,
    *,
    fps: float | None = None,
    executor=None,
    early_videos: list | None = None,
    started: float | None = None,
    figures: bool = True,
) -> None:
    """summary.json, arrays.npz + arrays.json, grids.npz (float32 mm), figures/, videos/
    (rendered in ``executor``'s workers when one is given; neither without ``figures``,
    and the summary says ``numbers_only``). ``early_videos``: the
    :data:`~oftimg.output.video.EARLY_VIDEOS` already started (:func:`oftimg.output.video.start_videos`).
    ``started``: the ``time.perf_counter()`` at which the analysis began; the summary's
    ``timings_s.total_s`` then holds the seconds of analysis and writing."""
    import time

    timings = result["summary"].setdefault("timings_s", {})
    tick = time.perf_counter()
    grids = {
        w: g.astype(np.float32) for w, g in result["grids"].items() if not w.endswith(CLIPPED)
    }  # the clipped ones are made on load from these
    arrays = result["arrays"]
    positions = result["summary"]["provenance"]["options"]["map_positions"]
    described = {
        k: describe_array(k, map_positions=positions) for k in list(arrays) + list(result["grids"])
    }
    described.update({k: describe_pca(k) for k in result.get("pca") or {}})
    described.update({k: describe_array(k) for k in result.get("pullbacks") or {}})
    made_on_load = {
        k: dict(
            described.pop(k),
            file="grids.npz",
            shape=list(g.shape),
            dtype="float32",
            made_on_load=CLIPPED_ON_LOAD,
        )
        for k, g in result["grids"].items()
        if k.endswith(CLIPPED)
    }
    write_arrays(
        folder,
        {
            "arrays.npz": arrays,
            "grids.npz": grids,
            **({"pca.npz": result["pca"]} if result.get("pca") else {}),
            **({"pullbacks.npz": result["pullbacks"]} if result.get("pullbacks") else {}),
        },
        described,
        made_on_load,
        noise=measured_noise(result["summary"], arrays),
    )
    timings["write_arrays_s"] = time.perf_counter() - tick
    if figures:
        _draw_figures_and_videos(
            folder, result, fps=fps, executor=executor, early_videos=early_videos
        )
    else:
        result["summary"]["numbers_only"] = True
        result["summary"]["drawings_failed"] = []  # none drawn, none failed
    if started is not None:
        timings["total_s"] = time.perf_counter() - started
    write_json(folder / "summary.json", result["summary"])


def _draw_figures_and_videos(folder: Path, result: dict, *, fps, executor, early_videos) -> None:
    """figures/ and videos/ of :func:`write_dataset_results`; their seconds in the
    summary's ``timings_s``."""
    import time

    from .figures import dataset_figures, field_grid_note
    from .video import LATER_VIDEOS, save_videos, start_videos

    arrays, timings = result["arrays"], result["summary"]["timings_s"]
    tick = time.perf_counter()
    (folder / "figures").mkdir(exist_ok=True)
    (folder / "videos").mkdir(exist_ok=True)
    # the workers render the videos while this process draws the figures
    videos = (early_videos or []) + start_videos(
        {**arrays, **(result.get("pullbacks") or {})},
        result["grids"],
        fps=fps,
        executor=executor,
        kinds=None if early_videos is None else LATER_VIDEOS,
        grid_note=field_grid_note(result["summary"]),
    )
    timings["videos_s"] = time.perf_counter() - tick
    tick = time.perf_counter()
    failed = []
    dataset_figures(
        folder / "figures",
        result["summary"],
        arrays,
        result["grids"],
        result.get("pullbacks"),
        failed,
    )
    if result.get("pca"):
        from .figures import attempt, pca_figure

        attempt(
            failed,
            pca_figure,
            result["pca"],
            result["summary"]["pca"],
            folder / "figures" / "shape_pca.png",
            title=f"{result['summary']['name']}: cross-section shape modes",
        )
    timings["figures_s"] = time.perf_counter() - tick
    tick = time.perf_counter()
    save_videos(folder / "videos", videos, failed)
    timings["videos_s"] += time.perf_counter() - tick
    _say_what_failed(result["summary"], failed)


def _say_what_failed(summary: dict, failed: list) -> None:
    """The figures and videos that could not be drawn: in the summary
    (``drawings_failed``), its warnings (the page shows them) and as a warning now;
    the numbers are written all the same."""
    summary["drawings_failed"] = failed
    if not failed:
        return
    from ..errors import OftimgWarning

    named = "; ".join(f"{f.get('figure') or f.get('video')} ({f['error']})" for f in failed[:3])
    text = (
        f"{len(failed)} figure{'s' * (len(failed) > 1)} or video{'s' * (len(failed) > 1)} "
        f"could not be drawn and {'are' if len(failed) > 1 else 'is'} left out, the "
        f"numbers written all the same: {named}{'; ...' if len(failed) > 3 else ''} "
        "(summary.json drawings_failed; please report it)"
    )
    summary.setdefault("warnings", []).append(text)
    warnings.warn(f"{summary['name']}: {text}", OftimgWarning, stacklevel=3)
