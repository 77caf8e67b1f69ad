"""Results folders read back: one dataset's arrays with the dims, unit and meaning
that ``arrays.json`` gives each, its summary and its grids, as NumPy arrays or as
one labelled ``xarray.Dataset``.

>>> res = load_results("results/embryo_A")
>>> res["area_outer_mm2"].shape, res.info("area_outer_mm2")["dims"]
((50, 195), ['v', 't'])
"""

from __future__ import annotations

import difflib
import json
import os
import zipfile
from pathlib import Path

import numpy as np

from .export import CLIPPED, COHORT_OUTPUTS
from ..errors import DatasetError
from ..io.dataset import natural_key
from ..mesh.clip import clipped_grids

RESULT_FILES = ("arrays.npz", "grids.npz", "pca.npz", "pullbacks.npz")

# dims whose entries have names: the xarray dim and its labels
LABELLED_DIMS = {
    "xyz": ("xyz", ["x", "y", "z"]),
    "xy": ("xy", ["x", "y"]),
    "l1,l2": ("stretch", ["l1", "l2"]),
    "up/down": ("crossing", ["up", "down"]),
    "along,around": ("direction", ["along", "around"]),
}


def source_paths(sources) -> list[Path]:
    """``sources``, one path or several, as a list of paths."""
    return [Path(s) for s in ([sources] if isinstance(sources, (str, Path)) else sources)]


def result_folders(sources) -> list[Path]:
    """Every dataset results folder (with summary.json) among ``sources``: each one
    such folder, or a folder of them (a run's ``--out``), in natural order."""
    folders = []
    for src in source_paths(sources):
        if (src / "summary.json").is_file():
            folders.append(src)
            continue
        subs = (
            sorted(
                (p for p in src.iterdir() if (p / "summary.json").is_file()),
                key=lambda p: natural_key(p.name),
            )
            if src.is_dir()
            else []
        )
        if not subs:
            hint = (
                f"; it is one of the cohort files of the run {src.parent}: give that folder itself"
                if src.name in COHORT_OUTPUTS and (src.parent / "run.json").is_file()
                else ""
            )
            raise DatasetError(
                f"{src}: neither one dataset's results (no summary.json) nor "
                f"a folder of them (an oftimg run's --out){hint}"
            )
        folders += subs
    return folders


def read_summary(folder: Path) -> dict:
    """A dataset results folder's ``summary.json``, checked to be oftimg's and to
    have its ``arrays.npz`` beside it."""
    path = Path(folder) / "summary.json"
    summary = _read_json(path)
    provenance = summary.get("provenance") if isinstance(summary, dict) else None
    if (
        not isinstance(provenance, dict)
        or not {"name", "group"} <= set(summary)
        or not {"options", "oftimg_version"} <= set(provenance)
    ):
        raise DatasetError(
            f"{path}: not an oftimg dataset summary (no name, group, or "
            "options and version in its provenance)"
        )
    if not (path.parent / "arrays.npz").is_file():
        raise DatasetError(f"{path.parent}: has no arrays.npz (the cohort's figures need it)")
    return summary


def _read_json(path: Path):
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DatasetError(f"{path}: cannot be read as JSON ({exc})") from None


def _read_npz(path: Path, names=None) -> dict[str, np.ndarray]:
    """Arrays ``names`` (default: all) of an .npz file; a file that cannot be read, or
    lacks one of them, is named."""
    try:
        with np.load(path) as npz:
            missing = [n for n in names or [] if n not in npz.files]
            arrays = {
                n: npz[n] for n in (npz.files if names is None else names) if n not in missing
            }
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise DatasetError(f"{path}: cannot be read ({exc})") from None
    if missing:
        raise DatasetError(f"{path}: has no {', '.join(missing)}, which arrays.json lists")
    return arrays


class Results:
    """One dataset's results folder (``oftimg run``'s ``OUT/<name>``): ``summary``
    (summary.json), and every array of arrays.npz, grids.npz and pca.npz by name,
    read when asked for, with its dims, unit and description (arrays.json)."""

    def __init__(self, folder):
        self.folder = Path(folder)
        self.summary = read_summary(self.folder)
        path = self.folder / "arrays.json"
        if not path.is_file():
            raise DatasetError(
                f"{self.folder}: has no arrays.json (it gives each array's dims and unit)"
            )
        self.described: dict[str, dict] = _read_json(path)
        for name, d in self.described.items():
            if not isinstance(d, dict) or d.get("file") not in RESULT_FILES:
                raise DatasetError(f"{path}: {name!r} names none of {', '.join(RESULT_FILES)}")

    @property
    def name(self) -> str:
        return self.summary["name"]

    @property
    def group(self) -> str:
        return self.summary["group"]

    @property
    def names(self) -> list[str]:
        """Every array's name, as arrays.json lists them."""
        return list(self.described)

    def __repr__(self) -> str:
        return (
            f"Results({str(self.folder)!r}: {self.name}, group {self.group}, "
            f"{len(self.described)} arrays)"
        )

    def __contains__(self, name) -> bool:
        return name in self.described

    def dataset_candidates(self) -> list[Path]:
        """Where the dataset these results were made from may be, in the order to try:
        its absolute path at the run, then its path from the results applied to where
        the results are now (both moved together), then (results of before 0.2) the
        folders around its first input file."""
        provenance = self.summary.get("provenance", {})
        dataset = provenance.get("dataset") or {}
        places = []
        if dataset.get("path"):
            places.append(Path(dataset["path"]))
        if dataset.get("from_results"):
            places.append(Path(os.path.normpath(self.folder.resolve() / dataset["from_results"])))
        if not places:
            inputs = provenance.get("inputs", {})
            files: list | dict = next(iter(inputs.values()), [])
            files = next(iter(files.values()), []) if isinstance(files, dict) else files
            if files:
                places += list(Path(files[0]["file"]).parents)[1:3]
        return list(dict.fromkeys(places))

    def info(self, name: str) -> dict:
        """``{"dims", "unit", "description", "file", ...}`` of array ``name``."""
        if name not in self.described:
            close = difflib.get_close_matches(name, self.described, n=3)
            raise KeyError(
                f"{self.folder}: no array {name!r}"
                + (f" (did you mean {', '.join(close)}?)" if close else "")
            )
        return self.described[name]

    def arrays(self, names) -> dict[str, np.ndarray]:
        """The arrays ``names``, each file opened once; those arrays.json marks
        ``made_on_load`` (the clipped grids) made from the stored ones they come from."""
        names = list(names)
        made = [n for n in names if "made_on_load" in self.info(n)]
        sources = list(
            dict.fromkeys(
                [n.removesuffix(CLIPPED) for n in made]
                + (["clip_v", "plane_origin_mm", "plane_normal"] if made else [])
            )
        )
        by_file: dict[str, list[str]] = {}
        for name in dict.fromkeys([n for n in names if n not in made] + sources):
            by_file.setdefault(self.info(name)["file"], []).append(name)
        out = {}
        for file, wanted in by_file.items():
            out.update(_read_npz(self.folder / file, wanted))
        if made:
            clipped = clipped_grids(
                {n.removesuffix(CLIPPED): out[n.removesuffix(CLIPPED)] for n in made},
                out["plane_origin_mm"],
                out["plane_normal"],
                out["clip_v"],
            )
            out.update({n: g.astype(np.float32) for n, g in clipped.items()})
        return {n: out[n] for n in names}

    def __getitem__(self, name: str) -> np.ndarray:
        return self.arrays([name])[name]

    def to_xarray(self, names=None):
        """An ``xarray.Dataset`` of ``names`` (default: every array of arrays.npz and
        grids.npz) on dims u (around, from the seam, u = i / n_u), v (along, inlet 0,
        outlet 1), v_clipped (the clipped grids': clipping plane 0, outlet 1), t (the
        times ``t_ms``) and the labelled dims xyz, stretch (l1, l2), crossing (up,
        down) and direction (along, around: the wave's velocity); ``s_mm`` is a
        coordinate along v. Each variable's
        attrs hold its ``units`` and ``description``. The PCA arrays, whose contour
        axes differ by row and phase, are read with ``results[name]``."""
        xr = _xarray("to_xarray")
        if names is None:
            names = [n for n, d in self.described.items() if d["file"] != "pca.npz"]
        pca = [n for n in names if self.info(n)["file"] == "pca.npz"]
        if pca:
            raise KeyError(
                f"{self.folder}: {', '.join(pca)} are PCA arrays, each with a "
                "contour axis of its own: read them with results[name]"
            )
        values = self.arrays(list(dict.fromkeys([*names, "s_mm", "t_ms"])))
        variables = {}
        for name in names:
            d = self.described[name]
            dims = [LABELLED_DIMS.get(dim, (dim,))[0] for dim in d["dims"]]
            variables[name] = xr.Variable(
                dims, values[name], {"units": d["unit"], "description": d["description"]}
            )
        sizes = {dim: n for v in variables.values() for dim, n in v.sizes.items()}
        coords = {dim: labels for dim, labels in LABELLED_DIMS.values() if dim in sizes}
        coords["t"] = (
            "t",
            values["t_ms"],
            {"units": "ms", "description": self.described["t_ms"]["description"]},
        )
        n_v = len(values["s_mm"])
        coords["v"] = (
            "v",
            np.linspace(0.0, 1.0, n_v),
            {
                "units": "1",
                "description": "grid parameter along the tube: 0 at the inlet, 1 at the outlet",
            },
        )
        coords["s_mm"] = (
            "v",
            values["s_mm"],
            {"units": "mm", "description": self.described["s_mm"]["description"]},
        )
        if "v_clipped" in sizes:
            coords["v_clipped"] = (
                "v_clipped",
                np.linspace(0.0, 1.0, sizes["v_clipped"]),
                {
                    "units": "1",
                    "description": "along the clipped grids: 0 "
                    "at the Lagrangian clipping plane, 1 at the outlet",
                },
            )
        if "u" in sizes:
            coords["u"] = (
                "u",
                np.arange(sizes["u"]) / sizes["u"],
                {
                    "units": "1",
                    "description": "grid parameter around the tube: 0 on the seam, "
                    "clockwise looking from the inlet",
                },
            )
        for name in ("s_mm", "t_ms"):
            variables.pop(name, None)
        return xr.Dataset(
            variables,
            coords,
            attrs={
                "name": self.name,
                "group": self.group,
                "period_ms": self.summary["period_ms"],
                "oftimg_version": self.summary["provenance"]["oftimg_version"],
                "source": str(self.folder),
            },
        )


def _xarray(what: str):
    try:
        import xarray
    except ImportError:
        raise ImportError(f"{what} needs xarray: pip install 'oftimg[xarray]'") from None
    return xarray


def load_results(folder) -> Results:
    """One dataset's results folder (``OUT/<name>``) read back: :class:`Results`."""
    folder = Path(folder)
    if not (folder / "summary.json").is_file() and (folder / "run.json").is_file():
        raise DatasetError(
            f"{folder}: a run's --out, not one dataset's results: "
            "oftimg.load_cohort reads all of them, or give OUT/<name>"
        )
    return Results(folder)


def load_cohort(sources) -> dict[str, Results]:
    """Every dataset's results among ``sources`` (each a dataset's results folder or
    a folder of them, as ``oftimg cohort`` takes them), by name in natural order:
    ``cohort["normal_0"]``, ``for name, res in cohort.items()``."""
    results = sorted(
        (Results(f) for f in result_folders(sources)), key=lambda r: natural_key(r.name)
    )
    for a, b in zip(results, results[1:]):
        if a.name == b.name:
            raise DatasetError(
                f"{b.folder}: its dataset is named {b.name!r}, as "
                f"{a.folder}'s is; load them apart, or rename one (its "
                "meta.json's name)"
            )
    return {r.name: r for r in results}


def load_cohort_maps(out):
    """A run's (or ``oftimg cohort``'s) ``cohort_maps.npz`` as an ``xarray.Dataset``:
    every embryo's maps on dims embryo (its name; coordinate ``group``), position
    (fraction of the tube, inlet 0) and phase (fraction of the cycle), and where the
    groups differ on dim comparison; units and descriptions from cohort_maps.json."""
    xr = _xarray("load_cohort_maps")
    out = Path(out)
    path = out / "cohort_maps.npz"
    if not path.is_file():
        raise DatasetError(
            f"{out}: has no cohort_maps.npz (an oftimg run's --out, or oftimg cohort's, has one)"
        )
    described = _read_json(out / "cohort_maps.json")
    arrays = _read_npz(path)
    coords = {
        "embryo": arrays.pop("names"),
        "group": ("embryo", arrays.pop("groups")),
        "position": (
            "position",
            arrays.pop("position_fraction"),
            {"units": "1", "description": described["position_fraction"]["description"]},
        ),
        "phase": (
            "phase",
            arrays.pop("cycle_fraction"),
            {"units": "1", "description": described["cycle_fraction"]["description"]},
        ),
    }
    if "comparisons" in arrays:
        coords["comparison"] = ("comparison", arrays.pop("comparisons"))
    return xr.Dataset(
        {
            k: (
                described[k]["dims"],
                v,
                {"units": described[k]["unit"], "description": described[k]["description"]},
            )
            for k, v in arrays.items()
        },
        coords,
        attrs={"source": str(out)},
    )
