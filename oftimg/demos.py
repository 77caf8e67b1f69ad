"""The built-in data: phantoms written (:func:`make_phantom`), the demo cohort run
(:func:`demo`) and the small analysed cohort the gallery and tests read
(:func:`example_results`)."""

from __future__ import annotations

import os
import shutil
import sys
import warnings
from pathlib import Path

from . import __version__
from .api import run
from .errors import InputError, OftimgWarning
from .output.export import (
    check_output_location,
    check_replaceable,
    require_new_folder,
    staged_output,
)
from .progress import Progress
from .synthetic.labels import write_label_phantom
from .synthetic.phantom import sample_params, write_phantom
from .synthetic.texture import TWIST_DEG as TEXTURE_TWIST_DEG


def make_phantom(
    out,
    *,
    group: str = "normal",
    seed: int = 0,
    frames: int = 195,
    quiet: bool = False,
    labels: bool = False,
    voxel_size_um: tuple[float, float, float] = (4.0, 4.0, 8.0),
    segmentation_noise: float | None = None,
    probabilities: bool = False,
    intensity: bool = False,
    **overrides,
) -> Path:
    """Write one phantom dataset (see :mod:`oftimg.synthetic.phantom`) to ``out``:
    meshes, or with ``labels`` label volumes of ``voxel_size_um`` (dx, dy, dz) with
    ``segmentation_noise`` (:mod:`oftimg.synthetic.labels`); with ``probabilities``
    too, each layer's probability map instead (``segmentation_noise``: the SD of
    the noise on their log-probabilities; None: each kind's default). With
    ``intensity`` (and ``labels``), intensity volumes too, a texture fixed in the
    tissue, which twists by
    :data:`~oftimg.synthetic.texture.TWIST_DEG` beneath the walls."""
    require_new_folder(Path(out))
    if intensity:
        if not labels:
            raise InputError(
                "--intensity needs --labels (or --probabilities): intensity "
                "volumes lie on a label dataset's voxels"
            )
        overrides.setdefault("twist_deg", TEXTURE_TWIST_DEG)
    params = sample_params(group, seed, n_frames=frames, **overrides)
    bar = Progress(frames, f"phantom {Path(out).name}", quiet=quiet)
    with staged_output(out) as tmp:
        if labels:
            write_label_phantom(
                tmp,
                params,
                voxel_size_um,
                noise=segmentation_noise,
                name=Path(out).name,
                progress=bar.update,
                probabilities=probabilities,
                intensity=intensity,
            )
        else:
            write_phantom(tmp, params, name=Path(out).name, progress=bar.update)
    bar.close()
    return Path(out)


# the demo cohorts: embryos per group, and each phantom's frames and vertices
DEMO_SMALL = (3, {"frames": 24, "vertices_min": 2000, "vertices_max": 2500})


DEMO_FULL = (4, {"frames": 195})


def demo(
    out,
    *,
    full: bool = False,
    overwrite: bool = False,
    quiet: bool = False,
    jobs: int | None = None,
) -> Path:
    """Generate the built-in phantom cohort and run the whole pipeline on it.

    Small (default): three normal and three banded embryos, enough for the
    report's group comparison to have p-values, of 24 frames and smaller meshes
    (about two minutes on 2 cores). ``full``: 4 normal + 4 banded, 195 frames, the
    paper's size.
    Returns ``out``; the generated data are in ``out/data``.
    """
    per_group, kwargs = DEMO_FULL if full else DEMO_SMALL
    return _phantom_cohort(
        Path(out), per_group, kwargs, overwrite=overwrite, quiet=quiet, jobs=jobs
    )


def _phantom_cohort(
    out: Path, per_group: int, phantom: dict, *, overwrite: bool, quiet: bool, jobs: int | None
) -> Path:
    """``per_group`` normal and banded phantoms (``make_phantom``'s ``phantom``
    arguments) in ``out/data``, analysed into ``out/results``."""
    check_output_location(out, [], overwrite=overwrite, kind=None)  # replaces only these two:
    for sub, kind in (("data", "demo data"), ("results", "results")):
        if overwrite and (out / sub).is_dir():
            check_replaceable(out / sub, kind)
    specs = [("normal", s) for s in range(per_group)] + [("banded", s) for s in range(per_group)]
    # data first, then results, each staged: the results (their provenance and
    # warnings) name the data where they stay, not a temporary folder
    with staged_output(out / "data", overwrite=overwrite, kind="demo data") as data:
        for group, seed in specs:
            make_phantom(data / f"{group}_{seed}", group=group, seed=seed, quiet=quiet, **phantom)
    run(out / "data", out / "results", quiet=quiet, jobs=jobs, overwrite=overwrite)
    return out


# the gallery's cohort: both groups, small enough to make in about a minute
EXAMPLE_COHORT = (2, {"frames": 12, "vertices_min": 1500, "vertices_max": 1800})


def example_results(cache=None) -> Path:
    """The results folder of a small analysed phantom cohort (2 normal and 2
    banded embryos of 12 frames, as ``oftimg run`` writes it), made on the first
    call (about a minute) and reused after: the gallery's examples start from it.

    ``cache``: where it is kept (default: ``$OFTIMG_CACHE``, else the user's cache
    folder, ``~/.cache/oftimg`` on Linux); made again when oftimg's code changes
    (the cohort of the code before then removed). Made in a temporary folder and moved in whole, so that a call interrupted, or
    two at once, never leave a half-made cohort to be reused.
    """
    import hashlib
    import tempfile

    root = Path(cache) if cache is not None else _cache_folder()
    code = hashlib.sha256(__version__.encode())
    for path in sorted(Path(__file__).parent.rglob("*.py")):
        code.update(path.read_bytes())
    folder = root / f"example-cohort-{code.hexdigest()[:12]}"
    if not (folder / "results" / "run.json").is_file():
        root.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=".example-cohort.partial-", dir=root))
        try:
            with warnings.catch_warnings():  # the phantoms' expected notes
                warnings.simplefilter("ignore", OftimgWarning)
                _phantom_cohort(
                    tmp / "cohort", *EXAMPLE_COHORT, overwrite=False, quiet=True, jobs=None
                )
            try:
                (tmp / "cohort").rename(folder)
            except OSError:  # another call finished first
                if not (folder / "results" / "run.json").is_file():
                    raise
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        for older in root.glob("example-cohort-*"):  # made by another oftimg: not reused
            if older != folder:
                shutil.rmtree(older, ignore_errors=True)
    return folder / "results"


def _cache_folder() -> Path:
    """Where oftimg keeps what it makes once (``$OFTIMG_CACHE``, else the
    platform's cache folder)."""
    if os.environ.get("OFTIMG_CACHE"):
        return Path(os.environ["OFTIMG_CACHE"])
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Caches"
    else:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "oftimg"
