"""Damaged datasets for fuzzing: small phantom datasets (meshes and label volumes),
each mutated in one seeded way as a careless export, a full disk or a wrong click
would (bytes flipped, files cut short, headers that lie, odd meta.json values,
FIFOs, devices, folders and links where files belong), and the checks that oftimg
answered each one as promised: no crash, no hang, no exception text, no raw bytes,
one clear line and exit 2 for what it refuses, and nothing of the user's changed.

:func:`fuzz` runs them; ``tests/test_fuzz.py`` and ``scripts/fuzz.py`` call it.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import shutil
import signal
import stat
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .labels import write_label_phantom
from .phantom import PhantomParams, write_phantom

MESH_FORMATS = (".ply", ".obj", ".stl", ".off", ".vtk")


def base_datasets(folder: Path) -> dict[str, Path]:
    """Two small valid datasets to damage: ``meshes`` (6 frames, outer and lumen, about
    600 vertices a wall) and ``labels`` (6 frames of 40 um voxels)."""
    folder = Path(folder)
    small = dict(n_frames=6, vertices_min=400, vertices_max=800)
    meshes = write_phantom(folder / "meshes", PhantomParams(**small), walls=("outer", "lumen"))
    labels = write_label_phantom(folder / "labels", PhantomParams(**small), (40, 40, 40), noise=0.0)
    for path in (meshes, labels):
        (path / "truth.json").unlink()
    return {"meshes": meshes, "labels": labels}


# --- mutations: each (folder, rng) -> a short description -----------------------------


def _pick(folder: Path, rng, pattern: str) -> Path:
    files = sorted(p for p in folder.glob(pattern) if p.is_file() and not p.is_symlink())
    return files[int(rng.integers(len(files)))]


def _a_frame(folder: Path, rng) -> Path:
    return _pick(folder, rng, "labels/*.tif" if (folder / "labels").is_dir() else "*/*.*")


def flip_bytes(folder, rng):
    """Up to 19 bytes of a frame's file (after a PLY's header) set at random."""
    path = _a_frame(folder, rng)
    data = bytearray(path.read_bytes())
    head = data.find(b"end_header") + 11 if path.suffix == ".ply" else 0
    where = rng.integers(max(head, 0), len(data), size=int(rng.integers(1, 20)))
    for k in where:
        data[k] = int(rng.integers(256))
    path.write_bytes(bytes(data))
    return f"{len(where)} bytes of {path.name} changed"


def cut_short(folder, rng):
    """A frame's file cut at a random byte."""
    path = _a_frame(folder, rng)
    data = path.read_bytes()
    path.write_bytes(data[: int(rng.integers(len(data)))])
    return f"{path.name} cut short"


def header_lies(folder, rng):
    """A line of a PLY header changed: a count, a line dropped, a byte made non-ASCII,
    a type changed, a line added."""
    path = _pick(folder, rng, "*/*.ply")
    data = path.read_bytes()
    head, _, body = data.partition(b"end_header\n")
    lines = head.rstrip(b"\n").split(b"\n")
    k = int(rng.integers(1, len(lines)))
    words = lines[k].split()
    choice = int(rng.integers(5))
    if choice == 0 and words[:1] == [b"element"]:
        n = int(words[2])
        words[2] = str(rng.choice([n // 2, n - 1, n + 1, 2 * n, 10**9, 0])).encode()
        lines[k] = b" ".join(words)
    elif choice == 1:
        del lines[k]
    elif choice == 2:
        lines[k] = lines[k].replace(b" ", bytes([int(rng.integers(128, 256))]), 1)
    elif choice == 3:
        lines[k] = lines[k].replace(b"float", rng.choice([b"double", b"char", b"quad"]), 1)
    else:
        lines.insert(
            k,
            rng.choice(
                [
                    b"element edge 5",
                    b"property list uchar float bad",
                    b"format ascii 1.0",
                    b"element vertex -3",
                ]
            ),
        )
    path.write_bytes(b"\n".join(lines) + b"\nend_header\n" + body)
    return f"a header line of {path.name} changed"


def face_sizes(folder, rng):
    """A face's corner count changed in a binary .ply."""
    path = _pick(folder, rng, "*/*.ply")
    data = bytearray(path.read_bytes())
    start = data.find(b"end_header\n") + 11
    n_vert = int(data[:start].split(b"element vertex ")[1].split()[0])
    n_face = int(data[:start].split(b"element face ")[1].split()[0])
    at = start + 12 * n_vert + 13 * int(rng.integers(n_face))
    data[at] = int(rng.choice([0, 1, 2, 4, 5, 255]))
    path.write_bytes(bytes(data))
    return f"a face of {path.name} given {data[at]} corners"


def other_format(folder, rng):
    """Every frame of a wall written as another format, one of them then damaged as
    text (a line dropped, a number made odd) or not."""
    import meshio

    from ..io.meshfile import read_mesh_file

    wall = folder / str(rng.choice(["outer", "lumen"]))
    suffix = str(rng.choice(MESH_FORMATS[1:]))
    for path in sorted(wall.glob("*.ply")):
        V, F = read_mesh_file(path)
        with contextlib.redirect_stderr(io.StringIO()):  # meshio's word on ascii VTK
            meshio.write(
                path.with_suffix(suffix),
                meshio.Mesh(V, [("triangle", F)]),
                **({"binary": False} if suffix in (".vtk", ".stl") else {}),
            )
        path.unlink()
    victim = _pick(wall, rng, f"*{suffix}")
    lines = victim.read_bytes().split(b"\n")
    k = int(rng.integers(len(lines)))
    how = int(rng.integers(4))
    if how == 0:
        del lines[k]
    elif how == 1:
        lines[k] = lines[k].replace(
            b" ", rng.choice([b" nan ", b" 0x1p3 ", b" 1e999 ", b" -", b"\xe9", b"\t\t"]), 1
        )
    elif how == 2:
        lines.insert(k, lines[k])
    victim.write_bytes(b"\n".join(lines))
    return f"{wall.name}/ as {suffix}, {victim.name} {['a line dropped', 'a token changed', 'a line doubled', 'whole'][how]}"


def odd_file(folder, rng):
    """A frame, meta.json or a label file replaced by something that is not a file."""
    target = rng.choice(["frame", "meta"])
    path = _a_frame(folder, rng) if target == "frame" else folder / "meta.json"
    kind = str(
        rng.choice(["fifo", "folder", "dev_zero", "broken_link", "link_loop", "empty", "random"])
    )
    if (
        kind == "folder"
        and target == "frame"
        and path.parent.name == "labels"
        and rng.random() < 0.5
    ):
        for frame in path.parent.iterdir():  # the 4-D labels.tif that is a folder
            frame.unlink()
        path = path.parent / "labels.tif"
    if path.exists() or path.is_symlink():
        path.unlink()
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    elif kind == "dev_zero":
        path.symlink_to("/dev/zero")
    elif kind == "broken_link":
        path.symlink_to(path.parent / "nowhere")
    elif kind == "link_loop":
        path.symlink_to(path.name)
    elif kind == "empty":
        path.write_bytes(b"")
    else:
        path.write_bytes(rng.bytes(int(rng.integers(1, 5000))))
    return f"{path.name} made {kind}"


_ODD_VALUES = [
    None,
    True,
    -1,
    0,
    1e-12,
    1e999,
    -1e999,
    10**400,
    10**16,
    "",
    "x" * 300,
    "\x00",
    "ab\udc80c",
    [],
    [1, 2],
    [0, 0, 0],
    [True, 0, 0],
    [1e999, 0, 0],
    [1e9, 1e9, 1e9],
    {"a": 1},
    [[1]],
    3.5,
    360,
    [10, 1e-12, 20],
    [1, 1, 1e6],
    "mm",
    "um",
    "m",
]


def odd_meta(folder, rng):
    """meta.json given an odd value for one key, odd JSON, or deep nesting."""
    path = folder / "meta.json"
    meta = json.loads(path.read_text())
    how = int(rng.integers(6))
    if how <= 2:
        keys = [
            "name",
            "group",
            "period_ms",
            "length_unit",
            "voxel_size",
            "inlet",
            "labels",
            "ends",
            "unknown",
        ]
        key = str(rng.choice(keys))
        value = _ODD_VALUES[int(rng.integers(len(_ODD_VALUES)))]
        if key == "labels" and rng.random() < 0.5:
            value = {"myocardium": value, "lumen": 3}
        if key == "ends" and rng.random() < 0.7:
            p = [float(x) for x in rng.normal(500, 300, 3)]
            n = [float(x) for x in rng.normal(0, 1, 3)]
            value = [
                {"point": p, "normal": n},
                {
                    "point": p if rng.random() < 0.5 else [v * 1e9 for v in p],
                    "normal": value if isinstance(value, list) else [-x for x in n],
                },
            ]
        meta[key] = value
        text = json.dumps(meta)
        what = f"{key}: {str(value)[:30]}"
    elif how == 3:
        depth = int(rng.choice([20, 1000, 100_000]))
        text = '{"name": ' + "[" * depth + "]" * depth + "}"
        what = f"nested {depth} deep"
    elif how == 4:
        text = json.dumps(meta)
        cut = int(rng.integers(len(text)))
        text = (
            text[:cut]
            + str(rng.choice(["", "}", ",", "NaN", "Infinity", "\ud800"]))
            + text[cut + 1 :]
        )
        what = "JSON damaged"
    else:
        text = str(rng.choice(["[]", "null", "42", '"meta"', "{}"]))
        what = f"meta.json is {text}"
    path.write_text(text, errors="surrogatepass")
    return what


def odd_labels(folder, rng):
    """A label frame replaced by an odd volume: random labels, floats, 2-D, a lying
    .npy header, few frames, or an empty zarr store."""
    labels = folder / "labels"
    frames = sorted(labels.glob("*.tif"))
    how = int(rng.integers(7))
    victim = frames[int(rng.integers(len(frames)))]
    shape = (30, 30, 30)
    if how == 0:
        victim.unlink()
        np.save(victim.with_suffix(".npy"), rng.integers(0, 4, shape, dtype=np.uint8))
        what = "random labels"
    elif how == 1:
        import tifffile

        tifffile.imwrite(victim, rng.random(shape).astype(np.float32))
        what = "float labels"
    elif how == 2:
        import tifffile

        tifffile.imwrite(victim, np.zeros((40, 40), np.uint8))
        what = "a 2-D frame"
    elif how == 3:
        for f in frames:
            f.unlink()
            np.save(f.with_suffix(".npy"), np.zeros((8, 8, 8), np.uint8))
        npy = victim.with_suffix(".npy")
        data = npy.read_bytes().replace(
            b"(8, 8, 8)",
            str(rng.choice(["(100000, 100000, 100000)", "(8, 8, 800)", "(-1, 8, 8)"])).encode(),
            1,
        )
        npy.write_bytes(data)
        what = "a .npy header that lies"
    elif how == 4:
        for f in frames[4:]:
            f.unlink()
        what = "4 frames"
    elif how == 5:
        for f in frames:
            f.unlink()
        (labels / "labels.zarr").mkdir()
        what = "an empty labels.zarr"
    else:
        import tifffile

        tifffile.imwrite(victim, np.full(shape, 200, np.uint8))
        what = "a frame of one label only"
    return what


def label_values(folder, rng):
    """The label values renumbered in every frame: layers swapped (meta.json's labels
    kept, or removed), two layers merged into one value, or a layer's voxels given to
    the layer around it (missing). None of these can give a right answer."""
    import tifffile

    how = str(rng.choice(["swapped", "swapped, no labels", "merged", "missing"]))
    table = np.arange(256, dtype=np.uint8)
    if how.startswith("swapped"):
        order = [(2, 1, 3), (1, 3, 2), (3, 2, 1), (2, 3, 1), (3, 1, 2)][int(rng.integers(5))]
        table[[1, 2, 3]] = order
    elif how == "merged":
        a = int(rng.integers(1, 3))
        table[a + 1] = a  # jelly into myocardium, or lumen
    else:  # into jelly
        layer = int(rng.integers(2, 4))
        table[layer] = layer - 1
    for path in sorted((folder / "labels").glob("*.tif")):
        tifffile.imwrite(path, table[tifffile.imread(path)], compression="zlib")
    if how.endswith("no labels"):
        meta = json.loads((folder / "meta.json").read_text())
        meta.pop("labels", None)
        (folder / "meta.json").write_text(json.dumps(meta))
    return how


label_values.must_refuse = True  # an exit 0 is a fault: the answer cannot be right


def units_off(folder, rng):
    """meta.json's length unit or period off by 1000: mm for um and back, the voxel
    size or the period 1000 times too large or too small."""
    meta = json.loads((folder / "meta.json").read_text())
    how = str(rng.choice(["length_unit", "voxel_size", "period_ms"]))
    if how == "length_unit":
        meta["length_unit"] = "mm" if meta.get("length_unit", "mm") == "um" else "um"
        what = f"length_unit {meta['length_unit']}"
    else:
        factor = float(rng.choice([1e-3, 1e3]))
        if how == "voxel_size" and "voxel_size" not in meta:
            how = "period_ms"
        meta[how] = [d * factor for d in meta[how]] if how == "voxel_size" else meta[how] * factor
        what = f"{how} x {factor:g}"
    (folder / "meta.json").write_text(json.dumps(meta))
    return what


def long_header(folder, rng):
    """A valid .ply frame whose header holds 70 KB of comment lines (a tool's history)."""
    path = _pick(folder, rng, "*/*.ply")
    data = path.read_bytes()
    comments = b"".join(
        b"comment exported by a tool, step %d of its history\n" % k for k in range(1500)
    )
    path.write_bytes(data.replace(b"\n", b"\n" + comments, 1))
    return f"{path.name}: {len(comments) // 1024} KB of header comments"


long_header.must_pass = True  # valid: a refusal is a fault


def odd_folder(folder, rng):
    """The folder's layout changed: a wall folder renamed, emptied or given one frame
    fewer, a stray file beside the frames."""
    walls = [p for p in folder.iterdir() if p.is_dir()]
    wall = walls[int(rng.integers(len(walls)))]
    how = int(rng.integers(4))
    if how == 0:
        wall.rename(folder / wall.name.capitalize())
    elif how == 1:
        for f in wall.iterdir():
            f.unlink()
    elif how == 2:
        sorted(wall.iterdir())[-1].unlink()
    else:
        (wall / "notes.ply").write_text("frame 3 looked odd\n")
    return f"{wall.name}/ {['renamed', 'emptied', 'one frame fewer', 'a stray file'][how]}"


MESH_MUTATIONS = (
    flip_bytes,
    cut_short,
    header_lies,
    face_sizes,
    other_format,
    odd_file,
    odd_meta,
    odd_folder,
    units_off,
    long_header,
)
LABEL_MUTATIONS = (
    flip_bytes,
    cut_short,
    odd_file,
    odd_meta,
    odd_labels,
    odd_folder,
    label_values,
    units_off,
)


# --- running and judging ---------------------------------------------------------------


@dataclass
class Outcome:
    """One case: what was done, how oftimg answered, what was wrong with the answer."""

    case: int
    base: str
    mutation: str
    command: str
    exit_code: int | None
    first_line: str
    seconds: float
    faults: list[str]


class _Hung(Exception):
    pass


def _tree_digest(folder: Path) -> str:
    """A digest of a folder's names, kinds and regular files' bytes (links not
    followed, FIFOs and devices not opened)."""
    digest = hashlib.sha256()
    for path in sorted(folder.rglob("*")):
        st = path.lstat()
        digest.update(f"{path.relative_to(folder)}:{stat.S_IFMT(st.st_mode)}".encode())
        if stat.S_ISREG(st.st_mode):
            digest.update(path.read_bytes())
        elif stat.S_ISLNK(st.st_mode):
            digest.update(os.readlink(path).encode())
    return digest.hexdigest()


def call_cli(main, argv: list[str], timeout_s: float) -> tuple[int | None, str, float]:
    """``main(argv)`` (:func:`oftimg.cli.main`, passed in: the command line is a layer
    above this one) in this process: exit status (None: it hung past ``timeout_s``),
    what it wrote to stderr, seconds."""

    def hung(*_):
        raise _Hung

    err = io.StringIO()
    old = signal.signal(signal.SIGALRM, hung)
    signal.setitimer(signal.ITIMER_REAL, timeout_s)
    tick = time.perf_counter()
    try:  # main sets the warnings' filters and format: restored after
        with (
            contextlib.redirect_stderr(err),
            contextlib.redirect_stdout(io.StringIO()),
            warnings.catch_warnings(),
        ):
            code = main(argv)
    except _Hung:
        code = None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    return code, err.getvalue(), time.perf_counter() - tick


def judge(code: int | None, stderr: str, *, unchanged: bool, out: Path | None) -> list[str]:
    """What is wrong with oftimg's answer to one damaged dataset ([] for nothing)."""
    faults = []
    if code is None:
        faults.append("hung")
    elif code not in (0, 2):
        faults.append(f"exit {code}")
    errors = [line for line in stderr.splitlines() if line.startswith("oftimg: error:")]
    if code == 2 and len(errors) != 1:
        faults.append(f"{len(errors)} error lines")
    if "Traceback" in stderr or "internal error" in stderr:
        faults.append("exception text")
    if any(not (c.isprintable() or c == "\n") or "\ufffd" in c for c in stderr):
        faults.append("raw bytes on the terminal")
    if len(stderr) > 4000:
        faults.append(f"{len(stderr)} characters on stderr")
    if not unchanged:
        faults.append("the input was changed")
    if out is not None and code != 0:
        left = [p.name for p in out.parent.iterdir() if p.name != "input"]
        if left:
            faults.append(f"left behind: {', '.join(left)}")
    return faults


def fuzz(
    cases: int,
    work: str | Path,
    cli_main,
    *,
    seed: int = 0,
    run_every: int = 25,
    timeout_s: float = 60.0,
    progress=None,
) -> list[Outcome]:
    """Damage the two base datasets ``cases`` times in all (alternately; one seeded
    mutation a case) and give each to ``oftimg validate``, every ``run_every``-th of
    each base to ``oftimg run`` as well, through ``cli_main`` (:func:`oftimg.cli.main`);
    return every case's :class:`Outcome`."""
    work = Path(work)
    bases = base_datasets(work / "bases")
    outcomes = []
    for case in range(cases):
        rng = np.random.default_rng([seed, case])
        base = "meshes" if case % 2 == 0 else "labels"
        mutations = MESH_MUTATIONS if base == "meshes" else LABEL_MUTATIONS
        mutation = mutations[int(rng.integers(len(mutations)))]
        root = work / f"case{case}"
        folder = root / "input"
        shutil.copytree(bases[base], folder)
        what = f"{mutation.__name__}: {mutation(folder, rng)}"
        before = _tree_digest(folder)
        commands = [["validate", str(folder)]]
        if run_every and (case // 2) % run_every == run_every - 1:  # each base in turn
            commands.append(
                ["run", str(folder), "--out", str(root / "out"), "--quiet", "--jobs", "1"]
            )
        validated = None
        for argv in commands:
            code, stderr, seconds = call_cli(cli_main, argv, timeout_s)
            out = root / "out" if argv[0] == "run" else None
            faults = judge(code, stderr, unchanged=_tree_digest(folder) == before, out=out)
            if argv[0] == "validate":
                validated = code
            elif validated == 0 and code == 2 and "no period_ms" not in stderr:
                faults.append("validate passed what run refused")  # (a run needs a period)
            if code == 0 and getattr(mutation, "must_refuse", False):
                faults.append("exit 0 for what cannot be right")
            if code == 2 and getattr(mutation, "must_pass", False):
                faults.append("refused what is valid")
            outcomes.append(
                Outcome(
                    case,
                    base,
                    what,
                    argv[0],
                    code,
                    (stderr.strip().splitlines() or [""])[0][:300],
                    round(seconds, 3),
                    faults,
                )
            )
        shutil.rmtree(root, ignore_errors=True)
        if progress:
            progress(case + 1)
    return outcomes
