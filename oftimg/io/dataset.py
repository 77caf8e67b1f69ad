"""Reading and validating datasets: one folder per embryo, one mesh file per frame.

Dataset layout::

    DATASET/
      meta.json   optional: {"name", "group", "period_ms", "length_unit", "voxel_size",
                             "inlet"}
      outer/      one mesh file per time frame (required)
      inner/      same number of frames (optional)
      lumen/      same number of frames (optional)

Frames are read lazily, one at a time, and returned as plain arrays
``V (n_vert, 3) float64`` in mm and ``F (n_face, 3) int64``. Nothing in a
dataset folder is ever written to.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import DatasetError, OftimgWarning
from ..mesh.topology import loop_centroid, loop_vector_area
from .meshfile import MESH_SUFFIXES, read_mesh_file, read_vertex_values
from .safefile import read_json_file
from .intensity import IntensitySeries, load_intensity
from .tube import Checked, Tube, check_tube_file, load_tube
from .units import UNIT_TO_MM, check_voxel_size, is_number, natural_key

SURFACES = ("outer", "inner", "lumen")
PERIOD_MS_RANGE = (1.0, 1e7)  # a beat of 1 ms to about three hours
FILES_NAMED = 6  # bad files an error names of a kind (the rest counted)
META_KEYS = {
    "name": str,
    "group": str,
    "period_ms": (int, float),
    "length_unit": str,
    "voxel_size": list,
    "inlet": list,
    "intensity": dict,
}


# frames a dataset needs: a cycle whose shape modes have 3 frames in each of expansion
# and contraction (the phases share the frame of maximum volume)
MIN_FRAMES = 5


def check_enough_frames(ds) -> None:
    """Raise :class:`DatasetError` naming the frames' folder of ``ds`` (a mesh or a
    label dataset) if it has fewer than :data:`MIN_FRAMES` frames: before any work,
    in ``validate`` as in ``run``."""
    if ds.n_frames < MIN_FRAMES:
        folder = ds.folder if hasattr(ds, "sources") else ds.path / "outer"  # label dataset
        raise DatasetError(
            f"{folder}: {ds.n_frames} frames; an analysis needs at least "
            f"{MIN_FRAMES} over the cycle (the shape modes take 3 in each of "
            "expansion and contraction)"
        )


def list_frames(folder: Path) -> list[Path]:
    """Mesh files of one surface folder in natural order (a broken link, a FIFO or a
    folder named like one too: reading it says what it is, where leaving it out
    would drop a frame from the time series)."""
    files = [
        p
        for p in folder.iterdir()  # a FIFO or folder too: reading refuses it
        if p.suffix.lower() in MESH_SUFFIXES and not p.name.startswith(".")
    ]
    return sorted(files, key=lambda p: natural_key(p.name))


@dataclass(frozen=True)
class Meta:
    """Dataset metadata after defaults and unit conversion."""

    name: str
    group: str
    period_ms: float
    length_unit: str
    inlet_mm: tuple[float, float, float] | None
    period_assumed: bool = False  # no period_ms: period_ms is NaN, a run refuses
    voxel_size: tuple[float, float, float] | None = None  # in length_unit, x y z
    period_from: str = "meta.json"  # or "--period-ms"

    @property
    def scale_to_mm(self) -> float | tuple[float, float, float]:
        """What the files' coordinates are multiplied by to give mm: one number, or
        one per axis for meshes in (anisotropic) voxel coordinates."""
        return _scale_to_mm(self.length_unit, self.voxel_size)


def _scale_to_mm(unit: str, voxel_size) -> float | tuple[float, float, float]:
    """:attr:`Meta.scale_to_mm` of a length unit and a voxel size (or None)."""
    to_mm = UNIT_TO_MM[unit]
    return to_mm if voxel_size is None else tuple(to_mm * d for d in voxel_size)


def read_meta_json(folder: Path, keys: dict = META_KEYS) -> dict:
    """``meta.json`` as a dict ({} when there is none), each key one of ``keys``
    (name -> allowed type) with a value of its type (never a bool for a number)."""
    path = folder / "meta.json"
    raw = read_json_file(path, optional=True)
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise DatasetError(f"{path}: expected a JSON object, found {type(raw).__name__}")
    for key, value in raw.items():
        _check_text(path, key, value)
        if key not in keys:
            raise DatasetError(f"{path}: unknown key {key[:40]!r}; allowed: {', '.join(keys)}")
        if not isinstance(value, keys[key]) or isinstance(value, bool):
            want = {str: "text", list: "a list", dict: "an object"}.get(keys[key], "a number")
            raise DatasetError(
                f"{path}: {key!r} must be {want}, found "
                f"{_JSON_KINDS.get(type(value), type(value).__name__)}"
            )
    return raw


def _check_text(path: Path, key: str, value) -> None:
    """Every string in a meta.json entry (its key too) is text that can be written:
    JSON lets ``"\\udc80"`` through, half of a UTF-16 pair that no file, folder or
    figure can hold."""
    strings = [key]
    todo = [value]
    while todo:
        item = todo.pop()
        if isinstance(item, str):
            strings.append(item)
        elif isinstance(item, dict):
            strings += list(item)
            todo += list(item.values())
        elif isinstance(item, list):
            todo += item
    for text in strings:
        try:
            text.encode("utf-8")
        except UnicodeEncodeError as exc:
            raise DatasetError(
                f"{path}: {key[:40].encode('utf-8', 'replace').decode()!r} "
                f"holds {text[exc.start]!r}, half of a UTF-16 pair (a lone "
                "surrogate) that is no character; write it as plain text"
            ) from None


_JSON_KINDS = {
    str: "text",
    list: "a list",
    dict: "an object",
    bool: "true/false",
    int: "a number",
    float: "a number",
    type(None): "null",
}


def read_meta(folder: Path, keys: dict = META_KEYS) -> Meta:
    """Parse ``meta.json`` (optional) and fill in the documented defaults. Without
    a ``period_ms`` the period is unknown: ``period_ms`` is NaN and ``period_assumed``
    set (nothing is timed by a guess: a run needs :func:`with_period`)."""
    path = folder / "meta.json"
    raw = read_meta_json(folder, keys)
    unit = raw.get("length_unit", "mm")
    if unit not in UNIT_TO_MM:
        raise DatasetError(f"{path}: length_unit must be 'mm' or 'um', found {unit[:20]!r}")
    period_assumed = "period_ms" not in raw
    period = float("nan") if period_assumed else raw["period_ms"]
    if not period_assumed:
        check_period(path, period)
    voxel = raw.get("voxel_size")
    if voxel is not None:
        voxel = check_voxel_size(path, voxel, UNIT_TO_MM[unit])
    inlet = raw.get("inlet")
    if inlet is not None:
        if len(inlet) != 3 or not all(is_number(x) and abs(x) < 1e9 for x in inlet):
            raise DatasetError(
                f"{path}: inlet must be a point [x, y, z] of three finite "
                f"numbers in the files' coordinates, found {str(inlet)[:60]}"
            )
        scale = np.broadcast_to(_scale_to_mm(unit, voxel), 3)  # in the files' coordinates
        inlet = tuple(float(x) * float(k) for x, k in zip(inlet, scale))
    name = str(raw.get("name", folder.name))
    if name in ("", ".", "..") or any(c in name for c in "/\\\0") or len(name) > 200:
        raise DatasetError(
            f"{path}: name {name[:60]!r} cannot be a folder name (the dataset's "
            "results are written to a folder of that name)"
        )
    group = str(raw.get("group", "unknown"))
    if len(group) > 200 or not group.isprintable():
        raise DatasetError(f"{path}: group must be a short line of text, found {group[:60]!r}")
    return Meta(
        name=name,
        group=group,
        period_ms=float(period),
        length_unit=unit,
        inlet_mm=inlet,
        period_assumed=period_assumed,
        voxel_size=voxel,
    )


def check_period(path, period_ms) -> None:
    """Refuse a period that is not a number of ms in :data:`PERIOD_MS_RANGE`, naming
    ``path`` (meta.json, or the option that gave it)."""
    if not is_number(period_ms) or not PERIOD_MS_RANGE[0] <= period_ms <= PERIOD_MS_RANGE[1]:
        raise DatasetError(
            f"{path}: period_ms is the beat's length in ms, a number from "
            f"{PERIOD_MS_RANGE[0]:g} to {PERIOD_MS_RANGE[1]:g}; found "
            f"{str(period_ms)[:30]}"
        )


def with_period(datasets: list, period_ms: float | None) -> list:
    """``datasets`` (mesh or label datasets) each with a known period: its meta.json's,
    else ``period_ms`` (``--period-ms``). Raises one :class:`DatasetError` naming the
    datasets whose period is unknown when ``period_ms`` is None: their times in ms and
    speeds in mm/s would be a guess."""
    if period_ms is not None:
        check_period("--period-ms", period_ms)
    missing = [d for d in datasets if d.meta.period_assumed]
    if missing and period_ms is None:
        first = missing[0]
        more = (
            f" (and {len(missing) - 1} more of the {len(datasets)} datasets: "
            f"{', '.join(d.meta.name for d in missing[1 : FILES_NAMED + 1])}"
            f"{', ...' if len(missing) > FILES_NAMED + 1 else ''})"
            if len(missing) > 1
            else ""
        )
        meta = first.path / "meta.json"
        where = (
            f"{meta}: no period_ms"
            if meta.is_file()
            else f"{first.path}: no meta.json, so no period_ms"
        )
        raise DatasetError(
            f"{where}{more}: oftimg gives times in ms and speeds in mm/s, which need the "
            'beat\'s length; add "period_ms" to meta.json or run with --period-ms MS (the '
            f"frame interval times the {first.n_frames} frames of one beat)"
        )
    if period_ms is None:  # none missing: each keeps its own
        return list(datasets)
    return [
        replace(
            d,
            meta=replace(
                d.meta, period_ms=float(period_ms), period_assumed=False, period_from="--period-ms"
            ),
        )
        if d.meta.period_assumed
        else d
        for d in datasets
    ]


@dataclass(frozen=True)
class Frame:
    """The files of one time frame: what a worker needs to read it (small to send)."""

    files: dict[str, str]
    unit_scale: float | tuple[float, float, float]  # file coordinates to mm (per axis)
    inlet_mm: tuple[float, float, float]
    checked: dict = field(default_factory=dict)  # surface -> Checked, from validation
    validated: bool = False  # repairs reported by the validation

    @property
    def surfaces(self) -> tuple[str, ...]:
        return tuple(s for s in SURFACES if s in self.files)

    def tube(self, surface: str) -> Tube:
        """This frame's ``surface`` as a validated :class:`Tube` in mm."""
        return load_tube(
            self.files[surface],
            unit_scale=self.unit_scale,
            inlet_point=np.asarray(self.inlet_mm),
            checked=self.checked.get(surface),
            warn=not self.validated,
        )

    def stored_mean_curvature(self, surface: str, tube: Tube) -> np.ndarray | None:
        """The mean curvature stored with each vertex of ``surface``'s file (1/mm, at
        ``tube``'s vertices, found by position: the reading may merge some), as the
        meshing of a label dataset stores the lumen's from its level sets; None when
        the file has none (or its coordinates are scaled per axis)."""
        from ..mesh.labels import CURVATURE_PROPERTY

        values = self._stored(surface, tube, CURVATURE_PROPERTY)
        return None if values is None else values / self.unit_scale

    def stored_closed(self, surface: str, tube: Tube) -> np.ndarray | None:
        """``(n_vert,)`` bool at ``tube``'s vertices: True on the bridge the meshing of a
        label dataset laid across a stretch where the cushions close the lumen
        (:func:`~oftimg.mesh.labels.closed_lumen_mesh`); None when the file has none."""
        from ..mesh.labels import CLOSED_PROPERTY

        values = self._stored(surface, tube, CLOSED_PROPERTY)
        return None if values is None else values > 0.5

    def _stored(self, surface: str, tube: Tube, name: str) -> np.ndarray | None:
        """The vertex property ``name`` of ``surface``'s file at ``tube``'s vertices
        (found by position: the reading may merge some), or None."""
        from scipy.spatial import cKDTree

        values = read_vertex_values(self.files[surface], name)
        if values is None or not np.isscalar(self.unit_scale):
            return None
        V, _ = read_mesh_file(self.files[surface])
        _, nearest = cKDTree(V * self.unit_scale).query(tube.V)
        return values[nearest]


@dataclass
class Dataset:
    """A dataset folder: metadata and the frame files of each surface.

    Frames are read on demand with :meth:`tube`; nothing is cached.
    """

    path: Path
    meta: Meta
    frames: dict[str, list[Path]]
    inlet_mm: np.ndarray = field(repr=False)
    checked: dict = field(default_factory=dict, repr=False)  # (surface, t) -> Checked
    validated: bool = False  # set by validate_dataset
    labels: dict | None = None  # meshed from label volumes: their files, how
    intensity: IntensitySeries | None = None  # intensity/ (their headers checked)
    lumen_bridged: dict | None = None  # lumens the cushions closed, joined: frames, files

    def inputs_by_kind(self) -> dict[str, list[Path] | dict[str, list[Path]]]:
        """The files the dataset is made of, by kind: ``meshes`` (wall -> its frames'
        files) and ``intensity``; or, meshed from label volumes, theirs (``labels`` or
        ``probabilities``, and ``intensity``)."""
        if self.labels:
            return {
                kind: [Path(f["file"]) for f in files]
                for kind, files in self.labels["inputs"].items()
            }
        frames = dict(self.frames)
        if self.lumen_bridged:  # the lumens joined in the results: from these
            replaced = {
                r["frame"]: Path(r["source"])
                for r in self.lumen_bridged["closures"] + self.lumen_bridged["repaired"]
            }
            frames["lumen"] = [replaced.get(t, p) for t, p in enumerate(frames["lumen"])]
        inputs: dict[str, list[Path] | dict[str, list[Path]]] = {"meshes": frames}
        if self.intensity is not None:
            inputs["intensity"] = list(dict.fromkeys(Path(s.path) for s in self.intensity.sources))
        return inputs

    def input_files(self) -> list[Path]:
        """The files the dataset is made of (its intensity volumes too), meta.json with
        them."""
        files = []
        for paths in self.inputs_by_kind().values():
            files += (
                [p for wall in paths.values() for p in wall] if isinstance(paths, dict) else paths
            )
        return files + [p for p in [self.path / "meta.json"] if p.is_file()]

    @property
    def n_frames(self) -> int:
        return len(self.frames["outer"])

    @property
    def surfaces(self) -> tuple[str, ...]:
        return tuple(s for s in SURFACES if s in self.frames)

    @property
    def unit_scale(self) -> float | tuple[float, float, float]:
        return self.meta.scale_to_mm

    def frame(self, t: int) -> Frame:
        """The files of frame ``t``, as sent to worker processes."""
        return Frame(
            {s: str(files[t]) for s, files in self.frames.items()},
            self.unit_scale,
            (float(self.inlet_mm[0]), float(self.inlet_mm[1]), float(self.inlet_mm[2])),
            {s: self.checked[s, t] for s in self.frames if (s, t) in self.checked},
            self.validated,
        )

    def tube(self, surface: str, t: int) -> Tube:
        """Frame ``t`` of ``surface`` as a validated :class:`Tube` in mm."""
        if surface not in self.frames:
            raise KeyError(f"{self.path}: has no {surface}/ surface")
        return self.frame(t).tube(surface)

    def iter_tubes(self, surface: str):
        """Every frame of ``surface`` in turn as a validated :class:`Tube` (mm), one
        frame read at a time: a long series never sits in memory whole."""
        for t in range(self.n_frames):
            yield self.tube(surface, t)


def _reference_inlet(frames: list[Path], unit_scale, n_probe: int = 5) -> np.ndarray:
    """Centroid (mm) of the inlet loop, chosen once for the whole series.

    The loops of a few evenly spaced frames are matched to the first frame's
    loops by centroid; the end whose enclosed area summed over these frames is
    larger is the inlet (the OFT tapers towards the outlet). A frame that cannot be
    read is passed over for the next one (the validation names every such frame);
    when none can, the first one's error is raised.
    """
    idx = np.unique(np.linspace(0, len(frames) - 1, min(n_probe, len(frames))).astype(int))
    order = [*idx, *sorted(set(range(len(frames))) - set(idx))]
    ref, refused, n_read = None, [], 0
    area = np.zeros(2)
    for i in order:
        if n_read == len(idx):
            break
        try:
            tube = load_tube(frames[i], unit_scale=unit_scale, warn=False)  # validation will
        except DatasetError as exc:
            refused.append(exc)
            continue
        n_read += 1
        loops = (tube.inlet, tube.outlet)
        cents = [loop_centroid(tube.V[lp]) for lp in loops]
        areas = [np.linalg.norm(loop_vector_area(tube.V[lp])) for lp in loops]
        if ref is None:
            ref = cents
        d_same = np.linalg.norm(cents[0] - ref[0]) + np.linalg.norm(cents[1] - ref[1])
        d_swap = np.linalg.norm(cents[0] - ref[1]) + np.linalg.norm(cents[1] - ref[0])
        if d_swap < d_same:
            areas = areas[::-1]
        area += areas
    if ref is None:
        refused[0].add_note(
            f"no frame of {frames[0].parent} can be read as a tube (all {len(frames)} were tried)"
        )
        raise refused[0]
    return np.asarray(ref[0] if area[0] >= area[1] else ref[1])


def is_dataset(path: Path) -> bool:
    """A mesh dataset (outer/) or a label dataset (labels/ or probabilities/)."""
    return any((path / name).is_dir() for name in ("outer", "labels", "probabilities"))


def load_dataset(path: str | Path) -> Dataset:
    """Open a dataset folder, check its layout and metadata, choose the inlet, and
    check its intensity volumes' headers when it has ``intensity/``
    (:func:`~oftimg.io.intensity.load_intensity`).

    Reads only a few outer frames (to choose the inlet end); the rest stay on
    disk until asked for.
    """
    path = Path(path)
    if not path.exists():
        raise DatasetError(f"{path}: folder not found")
    if not path.is_dir():
        raise DatasetError(f"{path}: not a folder")
    misnamed = sorted(
        p
        for p in path.iterdir()  # an Inner/ was left out, unread
        if p.is_dir() and p.name.lower() in SURFACES and p.name not in SURFACES
    )
    if misnamed:
        raise DatasetError(
            f"{misnamed[0]}: surface folders are named in lower case "
            f"({', '.join(SURFACES)}); rename it {misnamed[0].name.lower()}/"
        )
    if not (path / "outer").is_dir():
        raise DatasetError(
            f"{path}: no outer/ folder; a dataset has outer/ "
            "(and optionally inner/, lumen/) with one mesh file per frame"
        )
    frames = {}
    for surface in SURFACES:
        folder = path / surface
        if folder.is_dir():
            files = list_frames(folder)
            if not files:
                raise DatasetError(f"{folder}: no mesh files ({', '.join(MESH_SUFFIXES)})")
            broken = [f for f in files if not f.exists()]  # a frame moved away
            if broken:
                raise DatasetError(
                    f"{broken[0]}: a broken link"
                    + (
                        f" (and {len(broken) - 1} more in {folder}: "
                        f"{', '.join(f.name for f in broken[1 : FILES_NAMED + 1])}"
                        f"{', ...' if len(broken) > FILES_NAMED + 1 else ''})"
                        if len(broken) > 1
                        else ""
                    )
                )
            frames[surface] = files
    n = len(frames["outer"])
    for surface, files in frames.items():
        if len(files) != n:
            raise DatasetError(f"{path / surface}: {len(files)} frames, but outer/ has {n}")
    meta = read_meta(path)
    if meta.inlet_mm is not None:
        inlet = np.asarray(meta.inlet_mm)
    else:
        inlet = _reference_inlet(frames["outer"], meta.scale_to_mm)
    intensity = load_intensity(path, n, meta.length_unit, read_meta_json(path))
    return Dataset(path=path, meta=meta, frames=frames, inlet_mm=inlet, intensity=intensity)


def find_datasets(path: str | Path) -> list[Path]:
    """The dataset folders at ``path``: itself, or its sub-folders (a cohort)."""
    path = Path(path)
    if not path.is_dir():
        raise DatasetError(f"{path}: {'not a folder' if path.exists() else 'folder not found'}")
    if is_dataset(path):
        return [path]
    subs = sorted(
        (p for p in path.iterdir() if p.is_dir() and is_dataset(p)),
        key=lambda p: natural_key(p.name),
    )
    if not subs:
        raise DatasetError(
            f"{path}: neither a dataset (no outer/ or labels/ folder) nor a "
            "cohort (no sub-folder has outer/ or labels/)"
        )
    return subs


def frame_facts(
    frame: Frame, surface: str
) -> tuple[tuple[int, int, float, float], Checked | None, str]:
    """Vertices, faces, inlet and outlet loop areas (mm^2) of one frame, checked in
    full; its :class:`Checked` record; what was repaired ("" for nothing)."""
    tube, record, repairs = check_tube_file(
        frame.files[surface], unit_scale=frame.unit_scale, inlet_point=np.asarray(frame.inlet_mm)
    )
    facts = (
        len(tube.V),
        len(tube.F),
        float(np.linalg.norm(loop_vector_area(tube.V[tube.inlet]))),
        float(np.linalg.norm(loop_vector_area(tube.V[tube.outlet]))),
    )
    return facts, record, repairs.describe()


def _facts_or_problem(frame: Frame, surface: str):
    """:func:`frame_facts`, or the :class:`DatasetError` that refuses the frame's
    mesh, returned: one pass finds every bad frame."""
    try:
        return frame_facts(frame, surface)
    except DatasetError as exc:
        return exc


def _every_bad_frame(ds: Dataset, problems: list[tuple[str, DatasetError]]) -> DatasetError:
    """One error for the meshes that cannot be used, ``problems`` (file, its error)
    in surface and time order: the first one's message, with how many more, and a
    note per kind of problem (the same message but for its numbers) giving its
    first file's message and naming the others, relative to the dataset."""
    if len(problems) == 1:
        error = problems[0][1]
        error.problems = [(problems[0][0], str(error))]
        return error
    kinds: dict[str, list[tuple[str, str]]] = {}
    for file, exc in problems:
        problem = str(exc).removeprefix(f"{file}: ")
        kinds.setdefault(re.sub(r"\d+", "#", problem), []).append(
            (Path(file).relative_to(ds.path).as_posix(), problem)
        )
    error = DatasetError(
        f"{problems[0][1]} (and {len(problems) - 1} more of the dataset's "
        f"{ds.n_frames * len(ds.surfaces)} meshes cannot be used: below)"
    )
    for k, members in enumerate(kinds.values()):
        others = [file for file, _ in members[1:]]
        named = ", ".join(others[:FILES_NAMED]) + (
            f", ... {others[-1]}" if len(others) > FILES_NAMED else ""
        )
        same = (
            (
                f"the same problem in {len(others)} more mesh{'es' if len(others) > 1 else ''}: "
                f"{named}"
            )
            if others
            else ""
        )
        if k == 0 and not others:  # the first line names it
            continue
        error.add_note(
            same if k == 0 else f"{members[0][0]}: {members[0][1]}" + (f"; {same}" if same else "")
        )
    error.problems = [(file, str(exc)) for file, exc in problems]
    return error


def validate_dataset(ds: Dataset, *, executor=None, progress=None) -> dict:
    """Read every frame of every surface once; return a per-surface report.

    Raises one :class:`DatasetError` for every bad frame: the first one's message
    names its file, the notes the others by kind of problem (its ``problems``:
    each file and its message), so that one pass finds them all. With
    an ``executor`` (``concurrent.futures``), frames are checked in its workers.
    Remembers in ``ds.checked`` which files needed no repair, so that the
    analysis reads them again without the checks while they are unchanged.
    Repairs are listed per surface in the report (file name: what) and in one
    warning per surface; reading the frames again does not repeat them.
    ``progress()`` is called after each mesh.
    """
    report: dict = {
        "name": ds.meta.name,
        "path": str(ds.path),
        "n_frames": ds.n_frames,
        "inlet_mm": [round(float(x), 6) for x in ds.inlet_mm],
        "inlet_from": "meta.json" if ds.meta.inlet_mm is not None else "larger end loop",
        "period_ms": None if ds.meta.period_assumed else ds.meta.period_ms,
        "period_from": None if ds.meta.period_assumed else ds.meta.period_from,
        "surfaces": {},
    }
    problems = []
    for surface in ds.surfaces:
        frames = [ds.frame(t) for t in range(ds.n_frames)]
        checks = (
            map(_facts_or_problem, frames, [surface] * ds.n_frames)
            if executor is None
            else executor.map(_facts_or_problem, frames, [surface] * ds.n_frames)
        )
        results = []
        for result in checks:
            results.append(result)
            if progress:
                progress()
        bad = [
            (ds.frames[surface][t], r) for t, r in enumerate(results) if isinstance(r, DatasetError)
        ]
        if bad:
            problems += [(str(file), exc) for file, exc in bad]
            continue
        for t, (_, record, _) in enumerate(results):
            if record is not None:
                ds.checked[surface, t] = record
        repairs = {
            ds.frames[surface][t].name: what for t, (_, _, what) in enumerate(results) if what
        }
        if repairs:
            listed = "; ".join(f"{name}: {what}" for name, what in list(repairs.items())[:3])
            more = (
                f"; {len(repairs) - 3} more, listed in the validation report"
                if len(repairs) > 3
                else ""
            )
            warnings.warn(
                f"{ds.path / surface}: repaired {len(repairs)} of {ds.n_frames} "
                f"frames ({listed}{more})",
                OftimgWarning,
                stacklevel=2,
            )
        nv, nf, inlet_area, outlet_area = (list(x) for x in zip(*(f for f, _, _ in results)))
        if surface == "outer":
            check_frames_alike(ds, inlet_area)
        report["surfaces"][surface] = {
            "frames": len(nv),
            "vertices_min": int(min(nv)),
            "vertices_max": int(max(nv)),
            "faces_min": int(min(nf)),
            "faces_max": int(max(nf)),
            "boundary_loops": 2,
            "inlet_area_mm2_median": float(np.median(inlet_area)),
            "outlet_area_mm2_median": float(np.median(outlet_area)),
            "repairs": repairs,
        }
    if problems:
        raise _every_bad_frame(ds, problems)
    check_tube_size(ds, report["surfaces"]["outer"])
    ds.validated = True
    return report


AREA_OFF = 100.0  # a frame whose inlet's area is this many times the median's: not alike


def check_frames_alike(ds: Dataset, inlet_areas_mm2: list[float]) -> None:
    """Refuse a frame whose outer inlet loop's area is :data:`AREA_OFF` times the
    frames' median or more (or as much less): a beat changes it by far less, a frame
    exported in other units (or of another embryo) by that much."""
    areas = np.asarray(inlet_areas_mm2, float)
    off = np.abs(np.log(np.maximum(areas, 1e-300) / np.median(areas)))
    t = int(np.argmax(off))
    if off[t] > np.log(AREA_OFF):
        raise DatasetError(
            f"{ds.frames['outer'][t]}: its inlet's area is "
            f"{areas[t] / np.median(areas):.3g} times the frames' median (a "
            "beat changes it by far less): is this frame in other units, or "
            "of another embryo?"
        )


def _length(mm: float) -> str:
    """A length for a message, in µm under a millimetre."""
    return f"{1000 * mm:.3g} µm" if mm < 1 else f"{mm:.3g} mm"


# a living tube's radius: a capillary's few µm to the largest aorta's (a blue whale's,
# about 115 mm); outside this, the length unit is most likely wrong
RADIUS_MM_RANGE = (1e-3, 150.0)


def check_tube_size(ds: Dataset, outer: dict) -> None:
    """Refuse an outer wall whose ends' radius (from the median area of its inlet and
    outlet loops, ``outer``: the validation report's entry) is outside
    :data:`RADIUS_MM_RANGE`: no living tube's, and what a length unit off by 1000 gives
    (µm given as mm, or mm as µm)."""
    areas = [outer["inlet_area_mm2_median"], outer["outlet_area_mm2_median"]]
    radius_mm = float(np.sqrt(max(areas) / np.pi))
    low_mm, high_mm = RADIUS_MM_RANGE
    if low_mm <= radius_mm <= high_mm:
        return
    # meta.json as it is (a label dataset's has keys a mesh dataset's has not)
    raw = read_json_file(ds.path / "meta.json", optional=True) or {}
    said = (
        "meta.json's length_unit"
        if isinstance(raw, dict) and "length_unit" in raw
        else "the length unit (mm when meta.json gives no length_unit)"
    )
    unit = "um" if ds.meta.length_unit == "mm" else "mm"
    volumes = ds.labels is not None  # meshed from label or probability volumes
    where = (
        ds.path / ds.labels["meshing"].get("kind", "labels")
        if ds.labels is not None
        else ds.path / "outer"
    )
    raise DatasetError(
        f"{where}: a tube {_length(2 * radius_mm)} across at its wider end: "
        f"no living tube is {'so thin' if radius_mm < low_mm else 'so wide'} "
        f"({2 * low_mm * 1000:g} µm to {2 * high_mm:g} mm); is {said} right? The "
        f"{'voxel sizes' if volumes else 'coordinates'} look like {unit}: set "
        f'"length_unit": "{unit}" in meta.json'
    )
