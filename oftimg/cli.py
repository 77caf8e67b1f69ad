"""Command line: a thin layer over :mod:`oftimg.api`.

Only this module catches exceptions: one line to stderr, exit status 2 for
bad input (:class:`~oftimg.errors.InputError`, a path that is missing or in the
way), 1 for anything else (a ValueError or TypeError out of a library is
oftimg's failure, not the user's).
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import textwrap
import threading
import warnings
from contextlib import contextmanager
from pathlib import Path

from . import __version__
from .image.kymograph import AUTO_SPREAD_TARGET, RIDGE_SMOOTHING_LADDER_MS
from .image.normalize import FIELD_NOISE_TARGET, STRAIN_NOISE_TARGET


class Terminated(BaseException):
    """SIGTERM arrived: a job scheduler's time limit, ``kill``."""


@contextmanager
def _sigterm_unwinds():
    """While a command runs, SIGTERM raises :class:`Terminated`, so that the run
    ends as after Ctrl-C (workers stopped, nothing half-written, datasets finished
    so far kept for --resume) instead of dying on the spot. A second SIGTERM
    kills at once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        raise Terminated()

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


RUN_EXAMPLES = """examples:
  oftimg run embryo1 --out results              one dataset (meshes, labels/ or probabilities/)
  oftimg run cohort --out results               a folder of datasets: tables, groups, report
  oftimg run cohort --out results --jobs 8 --numbers-only
                                                numbers, tables and pages, no figures or videos
  oftimg run embryo1 --out results --period-ms 420
                                                a dataset whose meta.json gives no period
  oftimg run cohort --out results --resume      go on after a failed or interrupted run
  oftimg run cohort --out results --scheduler tcp://host:8786
                                                on a Dask cluster
every option and output: docs/guide.md"""


def _parser_for_docs() -> argparse.ArgumentParser:
    """:func:`_parser` with each epilog as a literal block: docs/cli.rst reads the
    epilogs as reStructuredText, which would set the examples' columns as prose."""
    p = _parser()
    for command in p._subparsers._group_actions[0].choices.values():
        if command.epilog:
            head, _, rest = command.epilog.partition("\n")
            command.epilog = f"{head}\n\n.. code-block:: text\n\n" + textwrap.indent(rest, "  ")
    return p


def _parser() -> argparse.ArgumentParser:
    # long, and kept whole: the command line read top to bottom as --help prints it
    # (docs/cli.rst renders the same parser)
    p = argparse.ArgumentParser(
        prog="oftimg",
        description="Turn a beating tube (a time series of triangle surfaces, or the label "
        "volumes or probability maps of a 4-D segmentation) into a consistent "
        "(u, v) grid, images, videos and numbers.",
    )
    p.add_argument("--version", action="version", version=f"oftimg {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser(
        "run",
        help="process a dataset or a cohort folder",
        description=textwrap.fill(
            "Process a dataset (one embryo's frames: meshes, label volumes or probability "
            "maps) or a cohort folder of them into OUT: per dataset arrays.npz, "
            "summary.json, figures, videos and a page; per cohort the tables, the group "
            "comparison and the report (OUT/index.html).",
            79,
        ),
        epilog=RUN_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    inp = r.add_argument_group("input")
    ana = r.add_argument_group("analysis")
    out = r.add_argument_group("outputs")
    perf = r.add_argument_group("performance")
    inp.add_argument(
        "source",
        type=Path,
        help="dataset folder (with outer/, or labels/ or "
        "probabilities/ to mesh frame by frame) or "
        "cohort folder",
    )
    out.add_argument("--out", type=Path, required=True, help="results folder (created)")
    inp.add_argument(
        "--period-ms",
        type=float,
        default=None,
        metavar="MS",
        help="the beat's length in ms for datasets whose meta.json gives no "
        "period_ms (without either, such a dataset is refused: its times and "
        "speeds would be a guess)",
    )
    out.add_argument("--overwrite", action="store_true", help="replace an --out that oftimg wrote")
    out.add_argument(
        "--resume",
        action="store_true",
        help="reuse the datasets a failed or interrupted run into the same --out "
        "finished (when their inputs, options and oftimg are unchanged)",
    )
    out.add_argument("--quiet", action="store_true", help="no progress bars")
    perf.add_argument(
        "--jobs",
        type=int,
        default=None,
        help="worker processes (default: all cores this job may use)",
    )
    perf.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run the work on a Dask cluster (e.g. tcp://host:8786)",
    )
    perf.add_argument(
        "--parallel",
        choices=["auto", "frames", "embryos"],
        default="auto",
        help="what the workers share out: each dataset's frames, or whole "
        "datasets (auto: datasets when there are at least twice as many "
        "as workers)",
    )
    ana.add_argument("--n-u", type=int, default=80, help="grid nodes around (default 80)")
    ana.add_argument("--n-v", type=int, default=50, help="grid nodes along (default 50)")
    ana.add_argument(
        "--authalic-weight",
        type=float,
        default=0.5,
        help="Desbrun blend: 0 conformal, 1 authalic (default 0.5)",
    )
    ana.add_argument(
        "--seam-method",
        default="graph",
        metavar="METHOD",
        help="seed of the shortest-seam search: graph (Dijkstra, default), heat "
        "(heat method), exact (MMP distances, 5x slower; a cross-check)",
    )
    out.add_argument(
        "--fps",
        type=float,
        default=None,
        help="frames per second of the videos (default: one beat in 4 s)",
    )
    out.add_argument(
        "--numbers-only",
        action="store_true",
        help="no figures or videos: arrays, summaries, tables and pages only "
        "(sweeps and batches; 2-3x faster on short datasets)",
    )
    out.add_argument(
        "--log",
        type=Path,
        default=None,
        metavar="FILE",
        help="keep a full log (progress, warnings, timings) in FILE",
    )
    ana.add_argument(
        "--warp",
        action="store_true",
        help="resample time in two segments so maximum expansion is at mid-cycle",
    )
    ana.add_argument(
        "--tracking",
        choices=("auto", "material", "texture", "none"),
        default="auto",
        help="the grid of the per-pixel fields (curvature, thickness, strain, "
        "phase maps): material, each row turned about the tube with the "
        "tissue from frame to frame; texture, each node moved with the "
        "intensity volumes' texture (intensity/), along the tube too; none, "
        "each frame's own grid, as in the paper; auto (default): texture "
        "where a dataset has intensity/, else material",
    )
    ana.add_argument(
        "--pullback-layers",
        type=int,
        default=5,
        metavar="N",
        help="with intensity/: depths sampled across the myocardium (or the "
        "shell) for the pullbacks (default 5)",
    )
    ana.add_argument(
        "--pullback-shell-um",
        type=float,
        nargs=2,
        default=(-10.0, 10.0),
        metavar=("INSIDE", "OUTSIDE"),
        help="with intensity/: the shell about a wall along its outward normal, "
        "um (default -10 10; the outer wall with an inner wall: the "
        "myocardium)",
    )
    ana.add_argument(
        "--pullback-walls",
        nargs="+",
        choices=("outer", "inner", "lumen"),
        default=["outer"],
        metavar="WALL",
        help="with intensity/: the walls pulled back (outer, inner, lumen; "
        "default outer, the myocardium)",
    )
    ana.add_argument(
        "--map-positions",
        choices=("rows", "fixed"),
        default="rows",
        help="rows of the (v, t) area maps: the grid rows, as in the paper "
        "(default; they drift along the tube as its shape changes), or fixed "
        "fractions of the centroid line in every frame (more accurate next to "
        "a band: see oftimg's docs/accuracy.md)",
    )
    ana.add_argument(
        "--ridge-smoothing-ms",
        default="auto",
        metavar="MS",
        help="Gaussian sigma (ms) with which each row of the outer area map is "
        "smoothed in time before its maximum (the ridge, hence the wave "
        "speeds) is found; auto (default): the least of "
        f"{', '.join(f'{x:g}' for x in RIDGE_SMOOTHING_LADDER_MS)} ms that "
        "leaves the local speeds' noise spread under "
        f"{100 * AUTO_SPREAD_TARGET:g} %%; 0: none (see oftimg's docs/accuracy.md)",
    )
    ana.add_argument(
        "--field-smoothing-ms",
        default="auto",
        metavar="MS",
        help="Gaussian sigma (ms) with which every pixel of each curvature field "
        "and of the wall thickness is smoothed in time (each frame's surface "
        "carries its own noise, which a curvature multiplies); auto "
        "(default): the least of "
        f"{', '.join(f'{x:g}' for x in RIDGE_SMOOTHING_LADDER_MS)} ms after "
        f"which at most {100 * FIELD_NOISE_TARGET:g} %% of each pixel's change "
        "over the cycle is noise; 0: none. summary.json: field_noise says how "
        "much of each field is noise and the sigma taken",
    )
    ana.add_argument(
        "--strain-smoothing-ms",
        default="auto",
        metavar="MS",
        help="Gaussian sigma (ms) with which every grid node's position is smoothed "
        "in time before the strain fields (each frame's grid moves along the "
        "wall with its own mesh's roughness, which a strain takes for stretch); "
        "auto (default): up "
        f"{', '.join(f'{x:g}' for x in RIDGE_SMOOTHING_LADDER_MS)} ms until "
        "that noise moves the strain energy by at most "
        f"{100 * STRAIN_NOISE_TARGET:g} %% of its median, or before the "
        "flattening of its peaks outweighs the noise removed; 0: none. "
        "summary.json: strain_noise says how much that noise still moves "
        "each field and the sigma taken",
    )
    _mesh_arguments(inp)
    inp.add_argument(
        "--rough-mesh-smoothing",
        default="auto",
        metavar="STEPS",
        type=lambda x: x if x == "auto" else int(x),
        help="Taubin smoothing steps on every wall's mesh before anything is "
        "measured on it; auto (default): 30 on a mesh rough at its own "
        "vertices (each vertex's normal offset from its neighbours', which "
        "they do not share, 3 %% of the edge length or more), none on a "
        "smooth one; 0: never (the paper). summary.json: "
        "frames_smoothed_as_rough counts them",
    )

    results_help = (
        "one dataset's results (a folder with summary.json) or a folder of them (a run's --out)"
    )
    c = sub.add_parser(
        "cohort",
        help="gather datasets analysed separately (e.g. one cluster "
        "job each) into one cohort with its tables and report",
    )
    c.add_argument("results", type=Path, nargs="+", help=results_help)
    c.add_argument("--out", type=Path, required=True, help="cohort folder (created)")
    c.add_argument("--overwrite", action="store_true", help="replace an --out that oftimg wrote")
    for parser in (ana, c):
        parser.add_argument(
            "--cluster-alpha",
            type=float,
            default=0.05,
            metavar="P",
            help="cluster-forming threshold of the cohort maps' cluster test: "
            "pixels of uncorrected p <= P form clusters (default 0.05; "
            "lower finds smaller, stronger clusters)",
        )

    exports = {
        "paraview": "write analysed datasets' grids (with every field on their nodes) "
        "and section contours as ParaView time series (.pvd)",
        "tiff": "write analysed datasets' maps and fields (and a run's cohort maps) as "
        "TIFF images that Fiji / ImageJ open (float32, time as frames)",
        "ome-zarr": "write analysed datasets' (u, v, t) fields, phase maps and "
        "pullbacks as OME-Zarr images (axes, time in ms) for napari, "
        "Fiji or web viewers",
    }
    for name, what in exports.items():
        ex = sub.add_parser(name, help=what)
        ex.add_argument("results", type=Path, nargs="+", help=results_help)
        ex.add_argument(
            "--out", type=Path, required=True, help="folder to create (one subfolder per dataset)"
        )
        if name == "paraview":
            ex.add_argument(
                "--jobs",
                type=int,
                default=None,
                help="worker processes, each writing one series at a time "
                "(default: all cores this job may use)",
            )
        ex.add_argument("--quiet", action="store_true", help="no progress bar")

    d = sub.add_parser(
        "demo",
        help="make the built-in phantom cohort and process it",
        description="Write the built-in phantom cohort (3 normal and 3 banded beating "
        "tubes of 24 frames, their truth beside them) and run it as `oftimg run` "
        "would: every file a run writes, on data whose answers are known (about "
        "two minutes on 2 cores; --full: the paper's 4 + 4 embryos of 195 "
        "frames).",
    )
    d.add_argument("--out", type=Path, default=Path("oftimg-demo"), help="results folder")
    d.add_argument("--full", action="store_true", help="4 normal + 4 banded, 195 frames")
    d.add_argument("--overwrite", action="store_true", help="replace an --out that oftimg wrote")
    d.add_argument("--quiet", action="store_true", help="no progress bars")
    d.add_argument(
        "--jobs",
        type=int,
        default=None,
        help="worker processes (default: all cores this job may use)",
    )

    ph = sub.add_parser("phantom", help="write a synthetic beating OFT dataset with truth.json")
    ph.add_argument("out", type=Path, help="dataset folder to create")
    ph.add_argument(
        "--group",
        choices=["normal", "banded"],
        default="normal",
        help="normal, or banded (a band narrows the tube at 40-65 %% of its "
        "length and blocks most of its motion there) (default normal)",
    )
    ph.add_argument(
        "--seed",
        type=int,
        default=0,
        help="which phantom of the group: its shape, timing and wave (default 0)",
    )
    ph.add_argument(
        "--frames", type=int, default=195, help="frames over one cardiac cycle (default 195)"
    )
    ph.add_argument(
        "--vertices",
        "--resolution",
        type=int,
        nargs=2,
        metavar=("MIN", "MAX"),
        help="vertex count range of each frame's mesh (default 4000 8000)",
    )
    ph.add_argument(
        "--noise-mm",
        type=float,
        default=0.0,
        help="radial surface noise, standard deviation in mm (e.g. 0.001)",
    )
    ph.add_argument(
        "--expand-change",
        type=float,
        default=0.0,
        help="growth of the expansion share of the cycle from inlet to outlet "
        "(0.2: 20 percentage points); the ridge then runs at a speed of its own",
    )
    _front_arguments(ph)
    ph.add_argument(
        "--labels",
        action="store_true",
        help="write label volumes (labels/, one TIFF per frame) instead of meshes: "
        "the tube bent to a quarter circle, leaving the volume through two "
        "faces",
    )
    ph.add_argument(
        "--voxel-size",
        type=float,
        nargs=3,
        metavar=("DX", "DY", "DZ"),
        default=(4.0, 4.0, 8.0),
        help="with --labels: voxel size in um (default 4 4 8)",
    )
    ph.add_argument(
        "--segmentation-noise",
        type=float,
        default=None,
        metavar="SHARE",
        help="with --labels: share of boundary voxels given a neighbour's label, "
        "with specks of wrong labels (default 0.05; 0: none); with "
        "--probabilities, the SD of the noise on each class's "
        "log-probability (default 0.3)",
    )
    ph.add_argument(
        "--probabilities",
        action="store_true",
        help="write each layer's probability map "
        "(probabilities/<layer>/, uint8 TIFF per frame: its share of each "
        "voxel, blurred by half a voxel, with noise on its log-probability) "
        "instead of labels",
    )
    ph.add_argument(
        "--intensity",
        action="store_true",
        help="with --labels or --probabilities: intensity volumes too "
        "(intensity/, uint8 TIFF per frame, as OCT would image the tube): "
        "a texture fixed in the tissue, which slides and twists beneath the "
        "walls, with speckle, attenuation and noise",
    )
    ph.add_argument("--quiet", action="store_true", help="no progress bar")

    me = sub.add_parser(
        "mesh",
        help="mesh a label dataset (labels/) into a mesh dataset "
        "(outer/ inner/ lumen/ PLY files) to inspect",
    )
    me.add_argument(
        "source",
        type=Path,
        help="label dataset folder (with labels/ or probabilities/) or a folder of them",
    )
    me.add_argument("out", type=Path, help="mesh dataset folder to create")
    _mesh_arguments(me)
    me.add_argument(
        "--jobs",
        type=int,
        default=None,
        help="worker processes (default: all cores this job may use)",
    )
    me.add_argument("--quiet", action="store_true", help="no progress bar")

    an = sub.add_parser(
        "animate",
        help="turn a static open tube into a dataset with a known wave",
        description="Turn one static open tube (a mesh file: a vessel, a gut, your own "
        "OFT) into a beating dataset whose wave, twist and shortening are known "
        "(truth.json): the truth for oftimg's measures on your own shape.",
    )
    an.add_argument("mesh", type=Path, help="a mesh file of one open tube")
    an.add_argument("out", type=Path, help="dataset folder to create")
    an.add_argument("--speed-mm-s", type=float, required=True, help="wave speed (mm/s)")
    an.add_argument(
        "--amplitude",
        type=float,
        default=0.3,
        help="the wave's radial change, a share of the radius (default 0.3)",
    )
    an.add_argument(
        "--period-ms", type=float, default=360.0, help="the beat's length in ms (default 360)"
    )
    an.add_argument("--frames", type=int, default=60, help="frames over one beat (default 60)")
    an.add_argument(
        "--unit",
        choices=["mm", "um"],
        default="mm",
        help="the coordinates' unit after --scale (default mm)",
    )
    an.add_argument(
        "--scale",
        type=float,
        default=1.0,
        help="multiply the file's coordinates by this (e.g. 0.2619 um per voxel)",
    )
    an.add_argument(
        "--twist-deg",
        type=float,
        default=0.0,
        help="twist about the centre line at the outlet at mid-cycle, growing "
        "from 0 at the inlet (degrees)",
    )
    an.add_argument(
        "--shortening",
        type=float,
        default=0.0,
        help="longitudinal shortening towards the inlet at mid-cycle (0.15: 15 %%)",
    )
    _front_arguments(an)
    an.add_argument(
        "--remesh",
        action="store_true",
        help="remesh every frame on its own, as a lab's per-frame segmentation "
        "would be (default: the same mesh moved)",
    )
    an.add_argument(
        "--texture",
        action="store_true",
        help="intensity volumes too (intensity/, uint8 TIFF per frame): a texture "
        "fixed in the tissue, which twists and shortens with it",
    )
    an.add_argument(
        "--seed",
        type=int,
        default=0,
        help="the remeshing's and the texture's random draw (default 0)",
    )
    an.add_argument("--quiet", action="store_true", help="no progress bar")

    v = sub.add_parser(
        "validate",
        help="check a dataset, or every dataset of a cohort, and print a per-surface report",
    )
    v.add_argument(
        "dataset",
        type=Path,
        help="dataset folder (with outer/, or labels/: meshed as a run would) or cohort folder",
    )
    v.add_argument("--json", action="store_true", help="print the report as JSON")
    v.add_argument(
        "--period-ms",
        type=float,
        default=None,
        metavar="MS",
        help="the beat's length of every dataset whose meta.json gives none "
        "(as oftimg run takes it; without it such a dataset is a problem)",
    )
    return p


# the demo's phantoms warn on purpose: what a newcomer reads after their warnings
DEMO_WARNINGS_NOTE = (
    "the warnings above are the phantoms' own, made on purpose (a band that "
    "barely moves, meshes remade each frame, groups of different noise); "
    "docs/getting-started.md, 'The demo's warnings', says what each means"
)


def _print_report(report: dict) -> None:
    print(
        f"dataset {report['name']} ({report['path']}): {report['n_frames']} frames, "
        f"inlet at ({', '.join(f'{round(x, 3) + 0.0:.3f}' for x in report['inlet_mm'])}) mm "
        f"({report['inlet_from']})"
    )  # to the µm: what a mesh resolves
    if "labels" in report:
        lab = report["labels"]
        soft = lab["kind"] == "probabilities"
        print(
            f"  {'probability maps' if soft else 'label volumes'} (z, y, x) "
            f"{tuple(lab['shape_zyx'])}, voxel "
            f"{' x '.join(f'{d:g}' for d in lab['voxel_size'])} {lab['length_unit']}, "
            f"{'layers' if soft else 'labels'} {lab['labels']}: meshed as a run meshes them"
        )
        if "format" in lab:
            print(
                f"  {lab['format']}; axes {lab['axes']}; voxel size from {lab['voxel_size_from']}"
            )
        if "intensity_format" in lab:
            print(f"  intensity: {lab['intensity_format']}")
        if "channels" in lab:
            print(
                "  channels: "
                + ", ".join(f"{role} {c}" for role, c in lab["channels"].items())
                + " (meta.json)"
            )
        for end in lab.get("ends_squared") or ():
            if end is not None:
                print(
                    f"  an end cut by the volume's face {end['oblique_deg']:.0f} degrees "
                    f"from square: cut square to the centre line "
                    f"{end['cut_in']:.4g} {lab['length_unit']} in"
                )
        for r in lab["label_repairs"]:
            name = f"{'probabilities/*' if soft else 'labels'}/{Path(r['file']).name} {r['wall']}"
            if "filled_from" in r:
                print(
                    f"  filled {name} from frames {r['filled_from'][0]} and "
                    f"{r['filled_from'][1]} ({r['why']})"
                )
            else:
                print(f"  mended {name}: {r['what']}, {r['voxels']} voxels changed")
    print(
        f"  {'surface':8} {'frames':>6} {'vertices':>13} {'faces':>13} {'loops':>5} "
        f"{'inlet mm2':>10} {'outlet mm2':>10}"
    )
    for name, s in report["surfaces"].items():
        print(
            f"  {name:8} {s['frames']:>6} {s['vertices_min']:>6}-{s['vertices_max']:<6} "
            f"{s['faces_min']:>6}-{s['faces_max']:<6} {s['boundary_loops']:>5} "
            f"{s['inlet_area_mm2_median']:>10.4f} {s['outlet_area_mm2_median']:>10.4f}"
        )
    for name, s in report["surfaces"].items():
        for file, what in s["repairs"].items():
            print(f"  repaired {name}/{file}: {what}")
    joined = report.get("lumen_bridged") or {}
    if joined.get("closures"):
        print(
            f"  lumen closed by the cushions (in pieces) in {len(joined['closures'])} "
            "frames: joined by a bridge as a run joins them, its rows measured as closed"
        )
    for r in joined.get("repaired", []):
        print(f"  repaired lumen/{r['file']}: {r['why']}")
    print(f"  period: {report['period_ms']:g} ms ({report['period_from']})")
    print("  problems: none")


@contextmanager
def _logging_to(path: Path | None, args):
    """Keep the run's log (progress, warnings, timings) in ``path`` while a command
    runs. Refused inside --out (replaced when the run succeeds) or the input (never
    written to), or in a folder that does not exist."""
    if path is None:
        yield
        return
    import logging

    from .errors import InputError

    where = path.resolve()
    for folder, why in (
        (args.out, "--out, which the results replace"),
        (args.source, "the input, which oftimg never writes to"),
    ):
        if folder.resolve() in where.parents:
            raise InputError(f"--log {path} is inside {why}; keep the log beside it")
    if not where.parent.is_dir():
        raise InputError(f"--log {path}: the folder {path.parent} does not exist")
    handler = logging.FileHandler(path)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
    echo = logging.StreamHandler()  # warnings still reach stderr too
    loggers = {name: logging.getLogger(name) for name in ("oftimg", "py.warnings")}
    levels = {name: lg.level for name, lg in loggers.items()}
    for lg in loggers.values():
        lg.addHandler(handler)
        lg.setLevel(logging.INFO)
    loggers["py.warnings"].addHandler(echo)
    logging.captureWarnings(True)
    try:
        yield
    finally:
        logging.captureWarnings(False)
        loggers["py.warnings"].removeHandler(echo)
        for name, lg in loggers.items():
            lg.removeHandler(handler)
            lg.setLevel(levels[name])
        handler.close()


def _report_line(out: Path) -> str:
    """The last line of a run: the report to open first."""
    run_info = out / "run.json"
    numbers_only = run_info.is_file() and json.loads(run_info.read_text()).get("numbers_only")
    what = "tables; numbers only" if numbers_only else "tables, figures, videos"
    return f"report: {out / 'index.html'} (open it in a browser: {what})"


def _parsed(argv: list[str] | None) -> argparse.Namespace:
    """The command line parsed; an option the command does not have is refused with the
    command's own usage and the nearest option it does have (``--period_ms``: did you
    mean ``--period-ms``?), not the top-level usage alone."""
    import difflib

    parser = _parser()
    args, unknown = parser.parse_known_args(argv)
    if not unknown:
        return args
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    command = sub.choices[args.command]
    options = [o for a in command._actions for o in a.option_strings if o.startswith("--")]
    word = next((u for u in unknown if u.startswith("-")), unknown[0])
    guess = difflib.get_close_matches(word.split("=")[0].replace("_", "-"), options, n=1)
    hint = f": did you mean {guess[0]}?" if guess else f" (oftimg {args.command} --help)"
    command.error(f"unrecognized argument{'s' * (len(unknown) > 1)} {' '.join(unknown)}{hint}")


def main(argv: list[str] | None = None) -> int:
    args = _parsed(argv)
    from .errors import InputError, OftimgWarning
    from .workers import WorkerLost

    warnings.simplefilter("always", OftimgWarning)
    warnings.formatwarning = lambda msg, cat, *a, **k: f"oftimg: warning: {msg}\n"
    try:
        with _sigterm_unwinds(), _logging_to(getattr(args, "log", None), args):
            return _command(args)
    except (InputError, FileNotFoundError, FileExistsError) as exc:
        _print_error(f"error: {exc}", exc)
        return 2
    except (WorkerLost, OSError) as exc:  # a lost worker; a full disk, no permission
        _print_error(f"error: {exc}", exc)
        return 1
    except KeyboardInterrupt as exc:
        _print_error("interrupted" + _nothing_written(args), exc)
        return 130
    except Terminated as exc:
        _print_error("terminated (SIGTERM)" + _nothing_written(args), exc)
        return 143
    except Exception as exc:  # the CLI's one catch-all: a clear line, not a traceback
        _print_error(f"internal error: {type(exc).__name__}: {exc}{_where(exc)}", exc)
        return 1


def _nothing_written(args) -> str:
    """What an interrupted command leaves: said of --out only by commands that have one."""
    return "; no results were written to --out" if getattr(args, "out", None) else ""


def _front_arguments(parser) -> None:
    """The wave's fronts of ``oftimg phantom`` and ``oftimg animate``: a helix, or a
    front that comes first on one side."""
    parser.add_argument(
        "--helix-starts",
        type=int,
        default=0,
        metavar="K",
        help="the wave's front winds K times round the tube (a helix; K < 0 "
        "the other way round; default 0: fronts are cross-sections)",
    )
    parser.add_argument(
        "--side-lag-ms",
        type=float,
        default=0.0,
        metavar="MS",
        help="the wave comes first on one side (--side-deg) and reaches the "
        "opposite side MS later (default 0)",
    )
    parser.add_argument(
        "--side-deg",
        type=float,
        default=0.0,
        metavar="DEG",
        help="where round the tube the wave comes first (0: the inside of the bend; default 0)",
    )


def _mesh_arguments(parser) -> None:
    """How label volumes are meshed (``run`` and ``mesh``)."""
    from .mesh.labels import MeshOptions

    default = MeshOptions()
    parser.add_argument(
        "--mesh-vertices",
        type=int,
        default=default.target_vertices,
        metavar="N",
        help="label datasets: about this many vertices per wall "
        f"and frame (default {default.target_vertices})",
    )
    parser.add_argument(
        "--mesh-smoothing",
        type=float,
        default=default.smoothing,
        metavar="VOXELS",
        help="label datasets: Gaussian sigma on each wall's "
        f"mask, in voxels (default {default.smoothing:g})",
    )
    parser.add_argument(
        "--lumen-curvature-blur",
        type=float,
        default=default.lumen_curvature_blur,
        metavar="VOXELS",
        help="label datasets: the lumen's mean curvature from its mask's level "
        "sets blurred by this Gaussian sigma, in voxels of the smallest "
        f"side (default {default.lumen_curvature_blur:g}; 0: from the mesh)",
    )


def _mesh_options(args) -> dict:
    return {
        "target_vertices": args.mesh_vertices,
        "smoothing": args.mesh_smoothing,
        "lumen_curvature_blur": args.lumen_curvature_blur,
    }


def _command(args) -> int:
    """Carry out the parsed command; errors go up to :func:`main`."""
    from . import api
    from . import demos

    if args.command == "run":
        options = {
            "n_u": args.n_u,
            "n_v": args.n_v,
            "authalic_weight": args.authalic_weight,
            "seam_method": args.seam_method,
            "warp": args.warp,
            "rough_mesh_smoothing": args.rough_mesh_smoothing,
            "map_positions": args.map_positions,
            "ridge_smoothing_ms": args.ridge_smoothing_ms,
            "field_smoothing_ms": args.field_smoothing_ms,
            "strain_smoothing_ms": args.strain_smoothing_ms,
            "tracking": args.tracking,
            "meshing": _mesh_options(args),
            "pullback": {
                "layers": args.pullback_layers,
                "shell_um": tuple(args.pullback_shell_um),
                "walls": tuple(args.pullback_walls),
            },
        }
        out = api.run(
            args.source,
            args.out,
            overwrite=args.overwrite,
            quiet=args.quiet,
            jobs=args.jobs,
            scheduler=args.scheduler,
            fps=args.fps,
            options=options,
            parallel=args.parallel,
            resume=args.resume,
            cluster_alpha=args.cluster_alpha,
            period_ms=args.period_ms,
            figures=not args.numbers_only,
        )
        print(f"results: {out}\ncohort table: {out / 'cohort.csv'}\n{_report_line(out)}")
    elif args.command == "cohort":
        out = api.cohort(
            args.results, args.out, overwrite=args.overwrite, cluster_alpha=args.cluster_alpha
        )
        n = len(json.loads((out / "run.json").read_text())["inputs"])
        print(
            f"cohort: {out} ({n} dataset{'s' * (n != 1)})\n"
            f"cohort table: {out / 'cohort.csv'}\n{_report_line(out)}"
        )
    elif args.command == "paraview":
        out = api.paraview(args.results, args.out, quiet=args.quiet, jobs=args.jobs)
        print(f"ParaView series: {out} (open each dataset's *.pvd)")
    elif args.command == "tiff":
        out = api.tiff(args.results, args.out, quiet=args.quiet)
        print(f"TIFF images: {out} (open them in Fiji / ImageJ)")
    elif args.command == "ome-zarr":
        out = api.ome_zarr(args.results, args.out, quiet=args.quiet)
        print(f"OME-Zarr images: {out} (open them in napari, Fiji or a web viewer)")
    elif args.command == "demo":
        out = demos.demo(
            args.out, full=args.full, overwrite=args.overwrite, quiet=args.quiet, jobs=args.jobs
        )
        if not args.quiet:  # before the lines naming what it wrote
            print(DEMO_WARNINGS_NOTE)
        print(
            f"demo data: {out / 'data'}\nresults: {out / 'results'}\n"
            f"cohort table: {out / 'results' / 'cohort.csv'}\n"
            f"{_report_line(out / 'results')}"
        )
    elif args.command == "phantom":
        extra = {
            "noise_mm": args.noise_mm,
            "expand_change": args.expand_change,
            "helix_starts": args.helix_starts,
            "side_lag_ms": args.side_lag_ms,
            "side_deg": args.side_deg,
        }
        if args.vertices:
            extra.update(vertices_min=args.vertices[0], vertices_max=args.vertices[1])
        out = demos.make_phantom(
            args.out,
            group=args.group,
            seed=args.seed,
            frames=args.frames,
            quiet=args.quiet,
            labels=args.labels or args.probabilities,
            voxel_size_um=tuple(args.voxel_size),
            segmentation_noise=args.segmentation_noise,
            probabilities=args.probabilities,
            intensity=args.intensity,
            **extra,
        )
        kind = "probability " if args.probabilities else "label " if args.labels else ""
        print(f"phantom {kind}dataset: {out}")
    elif args.command == "mesh":
        out = api.mesh(
            args.source, args.out, options=_mesh_options(args), jobs=args.jobs, quiet=args.quiet
        )
        print(f"mesh dataset: {out} (open its PLY files in ParaView or MeshLab)")
    elif args.command == "animate":
        from .synthetic.animate import Animation, write_animation
        from .progress import Progress

        anim = Animation(
            args.speed_mm_s,
            args.amplitude,
            args.period_ms,
            args.frames,
            twist_deg=args.twist_deg,
            shortening=args.shortening,
            helix_starts=args.helix_starts,
            side_lag_ms=args.side_lag_ms,
            side_deg=args.side_deg,
        )
        to_mm = args.scale * (1e-3 if args.unit == "um" else 1.0)
        bar = Progress(args.frames, f"animate {args.out.name}", quiet=args.quiet)
        out = write_animation(
            args.mesh,
            args.out,
            anim,
            scale_to_mm=to_mm,
            do_remesh=args.remesh,
            seed=args.seed,
            progress=bar.update,
            texture=args.texture,
        )
        bar.close()
        print(f"animated dataset: {out} (coordinates x {to_mm:g} -> mm)")
    elif args.command == "validate":
        return _validate(args.dataset, as_json=args.json, period_ms=args.period_ms)
    return 0


def _validate(path: Path, *, as_json: bool, period_ms: float | None = None) -> int:
    """Check a dataset, or every dataset of a cohort, as a run would (its period too:
    ``period_ms`` for those whose meta.json gives none); each one's problem, or its bad
    frames, printed, and the rest are checked; with ``as_json`` a bad dataset's entry
    lists its problems; 2 if any has a problem."""
    from .errors import InputError
    import tempfile

    from .inputs import _lumens_joined, validate_labels
    from .mesh.labels import MeshOptions
    from .io.dataset import (
        check_enough_frames,
        find_datasets,
        load_dataset,
        validate_dataset,
        with_period,
    )
    from .io.label_dataset import is_label_dataset
    from .progress import Progress

    folders = find_datasets(path)
    reports, problems = [], 0
    for folder in folders:
        try:
            if is_label_dataset(folder):  # meshed as a run would, then checked
                reports.append(validate_labels(folder, period_ms=period_ms))
                if not as_json:
                    _print_report(reports[-1])
                continue
            ds = with_period([load_dataset(folder)], period_ms)[0]
            check_enough_frames(ds)
            with tempfile.TemporaryDirectory(prefix="oftimg-validate-") as tmp:
                ds = _lumens_joined(ds, Path(tmp), MeshOptions(), None, quiet=False)
                bar = Progress(
                    ds.n_frames * len(ds.surfaces), f"{ds.meta.name}: checking meshes", unit="mesh"
                )
                try:
                    reports.append(validate_dataset(ds, progress=bar.advance))
                finally:
                    bar.close()
            if ds.lumen_bridged:
                reports[-1]["lumen_bridged"] = ds.lumen_bridged
        except InputError as exc:
            if len(folders) == 1:
                raise
            problems += 1
            _print_error(f"error: {exc}", exc)
            reports.append(
                {
                    "path": str(folder),
                    "problems": [
                        {"file": file, "problem": text}
                        for file, text in getattr(exc, "problems", None) or [(None, str(exc))]
                    ],
                }
            )
            continue
        if not as_json:
            _print_report(reports[-1])
    if as_json:
        print(json.dumps(reports[0] if folders == [path] else reports, indent=2))
    if problems:
        print(
            f"oftimg: error: {problems} of {len(folders)} datasets have a problem (above)",
            file=sys.stderr,
        )
        return 2
    return 0


def _where(exc: BaseException) -> str:
    """Where in oftimg an unexpected exception came from (its innermost frame in the
    package: file, line and function), for a report that can be acted on; empty when
    none is oftimg's."""
    import traceback

    package = Path(__file__).resolve().parent
    ours = [
        frame
        for frame in traceback.extract_tb(exc.__traceback__)
        if Path(frame.filename).resolve().is_relative_to(package)
    ]
    if not ours:
        return ""
    frame = ours[-1]
    where = Path(frame.filename).resolve().relative_to(package.parent)
    return f" (at {where}:{frame.lineno} in {frame.name}; please report it)"


def _print_error(line: str, exc: BaseException) -> None:
    """The error line and the notes added on the way up (e.g. what --resume reuses)."""
    for text in [line] + list(getattr(exc, "__notes__", [])):
        print(f"oftimg: {text}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
