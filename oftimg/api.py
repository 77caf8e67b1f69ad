"""The Python API behind the command line: run, cohort, paraview, demo, make_phantom.

File access happens here and in :mod:`oftimg.io.dataset` / :mod:`oftimg.output.export`; the
science lives in :mod:`oftimg.analysis.pipeline` and the ``mesh``/``image`` modules.
"""
from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
import platform
import shutil
import sys
import time
import uuid
import warnings
from pathlib import Path

from . import __version__
from .errors import DatasetError, InputError, OftimgWarning
from .output.export import (COHORT_OUTPUTS, Finished, check_output_location, check_replaceable,
                            cohort_maps, finished_folder, link_or_copy, require_new_folder,
                            staged_output, write_cohort_maps, write_dataset_results, write_json)
from .io.dataset import (Dataset, check_enough_frames, find_datasets, load_dataset, natural_key,
                         validate_dataset, with_period)
from .io.labelfile import describe_format
from .io.label_dataset import (LabelDataset, is_label_dataset, meshing_notes,
                               load_label_dataset, mesh_label_dataset)
from .synthetic.labels import write_label_phantom
from .synthetic.phantom import sample_params, write_phantom
from .synthetic.texture import TWIST_DEG as TEXTURE_TWIST_DEG
from .progress import FramePasses, Progress
from .output.results import read_summary, result_folders, source_paths
from .workers import available_memory, closing_executor, make_executor

log = logging.getLogger("oftimg")


def _as_dataset_paths(source) -> list[Path]:
    if isinstance(source, (Dataset, LabelDataset)):
        return [source.path]
    return find_datasets(source)


def _load(path: Path) -> Dataset | LabelDataset:
    """A dataset folder opened as what it holds: label volumes or meshes."""
    return load_label_dataset(path) if is_label_dataset(path) else load_dataset(path)


def run(source, out, *, overwrite: bool = False, quiet: bool = False,
        options: dict | None = None, jobs: int | None = None,
        scheduler: str | None = None, fps: float | None = None, parallel: str = "auto",
        resume: bool = False, cluster_alpha: float = 0.05,
        period_ms: float | None = None, figures: bool = True) -> Path:
    """Process a dataset or cohort folder (or a :class:`Dataset`) into ``out``.

    Every frame of every dataset is validated before any work. The work runs
    in ``jobs`` worker processes (default: all cores this job may use) or on
    the Dask cluster at ``scheduler``, split by ``parallel``: ``"frames"``
    (each dataset's frames in the workers, one dataset after another),
    ``"embryos"`` (whole datasets in the workers, each on one core: no idle
    workers while a dataset's fields, figures and tables are made), or
    ``"auto"``: embryos when there are at least twice as many datasets as
    workers, else frames. Results are written to a temporary folder and moved
    to ``out`` at the end; a failed run leaves ``out`` as it was. Each
    dataset's complete results are also kept in :func:`finished_folder` until
    the run succeeds; with ``resume``, those whose inputs, options and oftimg
    code are unchanged are reused (neither validated nor analysed again).
    ``cluster_alpha``: the cluster-forming threshold of the cohort maps' tests
    (:func:`cohort_maps`). ``period_ms``: the beat's length of every dataset whose
    meta.json gives none (without it, such a dataset is refused: its times and speeds
    would be a guess). ``figures=False``: numbers only (arrays, summaries, tables, pages;
    no figures or videos), for sweeps and batches where the numbers are what is read.
    Returns ``out``.
    """
    from .analysis.pipeline import PipelineOptions, tracking_mode

    if parallel not in ("auto", "frames", "embryos"):
        raise InputError(f"--parallel must be auto, frames or embryos, found {parallel!r}")
    if fps is not None and not (isinstance(fps, (int, float)) and math.isfinite(fps)
                                and fps > 0):
        raise InputError(f"--fps must be a positive number of frames per second, found {fps!r}")
    _check_cluster_alpha(cluster_alpha)
    out = Path(out)
    paths = _as_dataset_paths(source)
    check_output_location(out, paths, overwrite=overwrite)
    opts = PipelineOptions(**(options or {}))
    datasets = with_period([_load(p) for p in paths], period_ms)
    _check_names([(d.meta.name, d.path) for d in datasets],
                 'set another "name" in its meta.json')
    for d in datasets:                  # --tracking texture without intensity: before any work
        tracking_mode(d, opts.tracking, d.intensity is not None)
    started = time.time()
    finished = Finished(finished_folder(out))
    with finished.locked(out):
        return _run_locked(datasets, finished, out, paths, opts, resume=resume, jobs=jobs,
                           scheduler=scheduler, parallel=parallel, overwrite=overwrite,
                           quiet=quiet, fps=fps, started=started,
                           cluster_alpha=cluster_alpha, figures=figures)


def _run_locked(datasets, finished: Finished, out, paths, opts, *, resume, jobs, scheduler,
                parallel, overwrite, quiet, fps, started, cluster_alpha, figures) -> Path:
    """:func:`run` once it holds ``finished``: what to reuse, validation, the work,
    the cohort outputs; on failure, the note on what is kept."""
    names = [d.meta.name for d in datasets]
    fingerprints = {d.meta.name: finished.fingerprint(d, opts, fps, figures) for d in datasets}
    reused = {}
    if resume:
        for name, fp in fingerprints.items():
            summary = finished.summary_if_current(name, fp)
            if summary is not None:
                reused[name] = summary
        log.info("--resume: %d of %d datasets finished before, reused", len(reused),
                 len(datasets))
    todo = [d for d in datasets if d.meta.name not in reused]
    try:
        for ds in todo:
            check_enough_frames(ds)
        executor = make_executor(jobs, scheduler) if todo else None
        with closing_executor(executor):
            todo = [_meshed(ds, finished.root / f"{ds.meta.name}.meshes", opts.meshing, executor,
                            quiet) if isinstance(ds, LabelDataset) else ds for ds in todo]
            reports = {ds.meta.name: _validated(ds, executor, quiet) for ds in todo}
            if parallel == "auto":
                parallel = ("embryos" if executor is not None
                            and len(todo) >= 2 * _n_workers(executor) else "frames")
            work = (_embryos_in_workers if parallel == "embryos" and executor is not None
                    else _frames_in_workers)
            done = work(todo, reports, finished, fingerprints, opts, executor, fps=fps,
                        figures=figures, quiet=quiet, out=out)
            summaries = [reused.get(name) or done[name] for name in names]
            _write_run(summaries, finished, out, paths, opts, overwrite=overwrite,
                       started=started, cluster_alpha=cluster_alpha, figures=figures)
    except BaseException as exc:
        kept = finished.names()
        if kept:
            what = "the dataset" if len(kept) == 1 else f"the {len(kept)} datasets"
            exc.add_note(f"{what} finished before this kept in {finished.root}: "
                         "run again with --resume to reuse")
        else:
            finished.remove()
        raise
    finished.remove()
    return out


def _meshed(lds: LabelDataset, folder: Path, options, executor, quiet: bool) -> Dataset:
    """A label dataset meshed frame by frame in the workers into ``folder`` (beside
    the kept results, removed with them), opened as the mesh dataset it becomes;
    its ``labels`` record the label files and the meshing."""
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    record = _mesh_with_bar(lds, folder, options, executor, quiet)
    with warnings.catch_warnings():             # said of the label dataset already
        warnings.simplefilter("ignore", OftimgWarning)
        ds = load_dataset(folder)
    ds.path, ds.labels, ds.intensity = lds.path, record, lds.intensity
    ds.meta = dataclasses.replace(ds.meta, period_ms=lds.meta.period_ms,   # --period-ms too
                                  period_assumed=lds.meta.period_assumed,
                                  period_from=lds.meta.period_from)
    return ds


def _mesh_with_bar(lds: LabelDataset, folder: Path, options, executor, quiet: bool) -> dict:
    """:func:`mesh_label_dataset` into ``folder`` with a progress bar over the frames."""
    bar = Progress(lds.n_frames, f"{lds.meta.name}: meshing labels", quiet=quiet, unit="frame")
    try:
        return mesh_label_dataset(lds, folder, options, executor=executor, progress=bar.advance)
    finally:
        bar.close()


def validate_labels(path, *, quiet: bool = False, period_ms: float | None = None) -> dict:
    """Check a label dataset as a run would: its headers and period (``period_ms`` as
    :func:`run` takes it), then every frame meshed (here, into a temporary folder) and
    the meshes validated. Returns the validation report of the meshes
    (:func:`validate_dataset`) for ``path``, with the volumes' shape, voxel size and
    labels."""
    import tempfile

    from .mesh.labels import MeshOptions

    lds = with_period([load_label_dataset(path)], period_ms)[0]
    check_enough_frames(lds)
    with tempfile.TemporaryDirectory(prefix="oftimg-validate-") as tmp:
        ds = _meshed(lds, Path(tmp) / "meshes", MeshOptions(), None, quiet)
        report = validate_dataset(ds)
    assert ds.labels is not None                  # meshed from the label volumes
    report["labels"] = {k: ds.labels["meshing"][k]
                        for k in ("shape_zyx", "voxel_size", "length_unit", "labels",
                                  "label_repairs", "kind", "ends_squared")}
    first = lds.sources[0]
    first = first.layers[0][1] if hasattr(first, "layers") else first
    described = describe_format(first)
    carried = described.pop("file_voxel_size")
    described.pop("file_time_step")                  # said by the period's source
    if "channels" in lds.raw_meta:
        described["channels"] = lds.raw_meta["channels"]
    report["labels"] |= described | {"voxel_size_from": (
        "meta.json, the files' own agreeing" if lds.meta.voxel_size is not None and carried
        else "meta.json" if lds.meta.voxel_size is not None else "the files' headers")}
    if lds.intensity is not None:
        seen = describe_format(lds.intensity.sources[0])
        report["labels"]["intensity_format"] = f"{seen['format']}; axes {seen['axes']}"
    return report


def _validated(ds: Dataset, executor, quiet: bool) -> dict:
    """:func:`validate_dataset` with a progress bar; the report records its seconds."""
    tick = time.time()
    bar = Progress(ds.n_frames * len(ds.surfaces), f"{ds.meta.name}: checking meshes",
                   quiet=quiet, unit="mesh")
    try:
        report = validate_dataset(ds, executor=executor, progress=bar.advance)
    finally:
        bar.close()
    report["seconds"] = round(time.time() - tick, 2)
    return report


def _check_cluster_alpha(cluster_alpha) -> None:
    """:func:`oftimg.analysis.stats.check_cluster_alpha` as an :class:`InputError`, before any work."""
    from .analysis.stats import check_cluster_alpha

    try:
        check_cluster_alpha(cluster_alpha)
    except ValueError as exc:
        raise InputError(str(exc)) from None


def _check_names(named: list[tuple[str, Path]], fix: str) -> None:
    """Each dataset's results go to ``out/<name>``: the names of ``(name, folder)``
    must differ and must not be those of the cohort's own outputs; ``fix`` says
    how to rename one."""
    seen: dict[str, Path] = {}
    for name, path in named:
        if name in COHORT_OUTPUTS:
            raise InputError(f"{path}: the dataset name {name!r} is that of the cohort's "
                             f"own {name} in --out; {fix}")
        if name in seen:
            raise InputError(f"{seen[name]} and {path} have the same dataset name {name!r} "
                             f"(their results would go to one folder); {fix}")
        seen[name] = path


def _n_workers(executor) -> int:
    """Worker processes of a local pool, or worker threads of a Dask cluster."""
    client = getattr(executor, "_client", None)  # Dask's ClientExecutor
    if client is not None:
        return max(1, sum(client.nthreads().values()))
    return executor._max_workers


def analyse_and_write(ds: Dataset, report: dict, folder: Path, opts, *, fps: float,
                      quiet: bool = True, executor=None, progress=None, stage=None,
                      results_at: Path | None = None, figures: bool = True) -> dict:
    """One validated dataset end to end: its results into ``folder`` (which
    exists); returns its summary, which records the warnings of the analysis
    (``warnings``, raised again too). ``progress``: see :func:`analyse_dataset`;
    without it, a bar over the frames that then names the stages still to come.
    ``stage(text)``: called as each stage after the frames begins (with ``progress``).
    ``results_at``: where the results will be read from (``--out/<name>``; default
    ``folder``), so that the provenance gives the dataset's path from there too.
    ``figures=False``: no figures or videos."""
    from .analysis.pipeline import FRAME_PASSES, analyse_dataset
    from .output.video import EARLY_VIDEOS, start_videos

    started = time.perf_counter()
    bar = None
    if progress is None:
        bar = Progress(ds.n_frames, ds.meta.name, quiet=quiet)
        progress = FramePasses(bar, FRAME_PASSES)
        stage = bar.note
    stage = stage or (lambda text: None)
    early = None

    def aligned(arrays, grids):
        nonlocal early
        stage("fields, maps, shape modes")
        if executor is not None and figures:  # the workers render while this process goes on
            early = start_videos(arrays, grids, fps=fps, executor=executor, kinds=EARLY_VIDEOS)

    caught = []
    try:
        with _own_threads_limited(executor):
            try:
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    result = analyse_dataset(ds, opts, quiet=True, executor=executor,
                                             progress=progress, on_aligned=aligned)
            finally:
                raised = _raise_again(caught)
            summary = result["summary"]
            summary["provenance"]["dataset"]["from_results"] = os.path.relpath(
                summary["provenance"]["dataset"]["path"], Path(results_at or folder).resolve())
            summary["warnings"] = raised
            summary["validation"] = report
            stage("figures, videos" if figures else "files")
            write_dataset_results(folder, result, fps=fps, executor=executor, early_videos=early,
                                  started=started, figures=figures)
    finally:
        if bar is not None:
            bar.close()
    return summary


def _raise_again(caught: list) -> list[str]:
    """Raise the warnings ``caught`` (``warnings.WarningMessage``) again, each text
    once, where they were first raised; returns the texts of oftimg's own
    (:class:`OftimgWarning`), in order, for the summary."""
    once = {(w.category, str(w.message)): w for w in caught}
    for w in once.values():
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return [text for category, text in once if issubclass(category, OftimgWarning)]


def _own_threads_limited(executor):
    """One BLAS / OpenMP thread in this process while ``executor``'s workers fill the
    cores (a no-op without one). This process's linear algebra (shape modes,
    strain) then runs beside 2 busy workers, and OpenBLAS's own threads, waiting on
    each other, made the shape modes 3-5x slower (0.4 s alone, 1.2-2.8 s so)."""
    if executor is None:
        return contextlib.nullcontext()
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1)


# by embryo, the bar counts an embryo's fields, figures, videos and files as this many
# passes over its frames (measured with --jobs 1, 195 frames: the two per-frame passes
# 31.5 s, the rest 10.4 s), so that the time left includes them
TAIL_PASSES = 0.67


def _tail_frames(n_frames: int) -> int:
    return round(TAIL_PASSES * n_frames)


def embryo_task(ds: Dataset, report: dict, opts, fps: float, frames_done=None,
                vector_suffixes=None, results_at: Path | None = None, figures: bool = True):
    """:func:`analyse_and_write` in a worker, into a folder of its own.

    Returns the summary, the files ``{path relative to the dataset's folder:
    bytes}`` (so that a cluster worker need not see the output folder) and the
    warnings raised, each once, for the caller to raise again. ``frames_done``:
    a queue that gets a 1 for each frame of each per-frame pass and
    :data:`TAIL_PASSES` x the frames for the rest (a third as the files begin),
    and ``(name, stage)`` as each stage begins (``(name, None)`` at the end), for
    the bar to say what the workers are doing; or None.
    ``results_at``, ``figures``: as :func:`analyse_and_write` has them. ``vector_suffixes``: the
    figures' vector formats, the caller's
    :func:`~oftimg.output.style.vector_formats` (a worker does not share it), or
    None for the default.
    """
    import contextlib
    import tempfile

    from .output.style import vector_formats

    formats = (contextlib.nullcontext() if vector_suffixes is None
               else vector_formats(vector_suffixes))
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings(record=True) as caught, \
            formats:
        warnings.simplefilter("always")
        folder = Path(tmp) / ds.meta.name
        folder.mkdir()
        report_frames = _Reports(frames_done)
        progress = stage = None
        tail = _tail_frames(ds.n_frames)
        if frames_done is not None:
            steps = iter((0, tail // 3))       # the fields, then the files: a third of the tail

            def progress():
                report_frames.put(1)

            def stage(text):
                report_frames.put(next(steps, 0))
                report_frames.put((ds.meta.name, text))
        summary = analyse_and_write(ds, report, folder, opts, fps=fps, progress=progress,
                                    stage=stage, results_at=results_at, figures=figures)
        report_frames.put(tail - tail // 3)
        report_frames.put((ds.meta.name, None))
        files = {p.relative_to(folder).as_posix(): p.read_bytes()
                 for p in sorted(folder.rglob("*")) if p.is_file()}
    raised = list({(type(w.message), str(w.message)): w.message for w in caught}.values())
    return summary, files, raised


def _embryos_in_workers(datasets, reports, finished: Finished, fingerprints, opts, executor, *,
                        fps, figures, quiet, out: Path) -> dict:
    """Every dataset as one :func:`embryo_task`, each kept in ``finished`` as it
    ends; returns the summaries by name. At most :func:`embryos_at_once` run at
    a time. After a dataset fails, no more are started, those running are still
    kept, then the error is raised. The bar counts the frames of the two
    per-frame passes done in all workers, and each embryo's remaining work as
    :data:`TAIL_PASSES` more passes.
    """
    from concurrent.futures import FIRST_COMPLETED, wait

    from .output.style import vector_suffixes

    bar = Progress(sum(2 * ds.n_frames + _tail_frames(ds.n_frames) for ds in datasets),
                   f"{len(datasets)} datasets", quiet=quiet, unit="step")   # a frame's pass
    log.info("%d datasets, each analysed whole in a worker", len(datasets))
    at_once = embryos_at_once(datasets, executor)
    summaries = {}
    error = None
    waiting = list(datasets)
    running: set = set()

    def top_up():                                        # none started after a failure
        while waiting and len(running) < at_once and error is None:
            ds = waiting.pop(0)
            running.add(executor.submit(embryo_task, ds, reports[ds.meta.name], opts, fps,
                                        frames_done, vector_suffixes(), out / ds.meta.name,
                                        figures))

    try:
        with _frame_counter(executor, bar) as frames_done:
            top_up()
            while running:
                done, running = wait(running, return_when=FIRST_COMPLETED)
                results = []
                for fut in done:
                    try:
                        results.append(fut.result())
                    except Exception as exc:  # the datasets already running go on: keep them
                        error = error or exc
                top_up()                          # the next start before these are written
                for summary, files, raised in results:
                    for message in raised:
                        warnings.warn(message, stacklevel=2)
                    name = summary["name"]
                    folder = finished.writing(name)
                    for relpath, data in files.items():
                        path = folder / relpath
                        path.parent.mkdir(parents=True, exist_ok=True)
                        path.write_bytes(data)
                    finished.keep(name, fingerprints[name], summary)
                    summaries[name] = summary
                    bar.note(f"{len(summaries)} of {len(datasets)} datasets done")
                    _log_done(summary)
            if error is not None:
                raise error
    finally:
        bar.close()
    return summaries


# growth of a worker's memory while it analyses one embryo, beyond its idle ~0.3 GB
# (peak RSS of embryo_task, 3 walls: 0.48 / 0.62 / 0.9 GB for 49 / 98 / 195 frames,
# the same for 2k, 5.5k and 20k vertices)
EMBRYO_BYTES = 60e6
EMBRYO_BYTES_PER_FRAME = 3e6


def embryos_at_once(datasets, executor) -> int:
    """How many embryos a local pool may analyse at once: one per worker, or
    fewer when the memory left (:func:`~oftimg.workers.available_memory`, with
    10 % to spare) would not hold that many of the largest (then with a warning).
    A Dask cluster's workers manage their own memory: one per worker thread."""
    workers = _n_workers(executor)
    if getattr(executor, "_client", None) is not None:
        return workers
    room = available_memory()
    if room is None:
        return workers
    frames = max(ds.n_frames for ds in datasets)
    each = EMBRYO_BYTES + EMBRYO_BYTES_PER_FRAME * frames
    fit = max(1, int(0.9 * room // each))
    if fit < workers:
        warnings.warn(f"memory for {fit} of {workers} embryos at once ({room / 1e9:.1f} GB "
                      f"free, about {each / 1e9:.2f} GB each for {frames} frames): the "
                      "others wait their turn", OftimgWarning, stacklevel=2)
        return fit
    return workers


class _Reports:
    """``put(n)`` to a progress queue that may be gone (its manager process killed):
    the first failure ends the reports, not the task; progress is only shown."""

    def __init__(self, queue):
        self.queue = queue

    def put(self, report) -> None:
        if self.queue is None:
            return
        try:
            self.queue.put(report)
        except (OSError, EOFError):                 # BrokenPipe, ConnectionRefused, ...
            self.queue = None


def _drain(queue, bar: Progress) -> None:
    """Take each report on ``queue`` (:func:`_show_report`) until None, or until the
    queue is gone (its manager killed): the bar then stops, the run goes on."""
    running: dict = {}
    try:
        for report in iter(queue.get, None):
            _show_report(report, bar, running)
    except (OSError, EOFError):
        pass


def _show_report(report, bar: Progress, running: dict) -> None:
    """One report of :func:`embryo_task`'s: steps done advance ``bar``; a dataset's
    stage, ``(name, text)``, is shown with the others' under way (``running``, name:
    stage, kept between reports), so that a bar waiting on the files of two embryos
    says so instead of looking stuck."""
    if not isinstance(report, (tuple, list)):
        bar.advance(report)
        return
    name, text = report
    if text is None:
        running.pop(name, None)
    else:
        running[name] = text
    if running:
        bar.note("; ".join(f"{n}: {t}" for n, t in running.items()))


@contextlib.contextmanager
def _frame_counter(executor, bar: Progress):
    """Yield what :func:`embryo_task` reports its frames to (``put(n)``), each
    report advancing ``bar`` here: a spawn Manager's queue for a local pool, an
    event topic on a Dask cluster; None when the bar is not shown."""
    if not bar.reporting:
        yield None
        return
    client = getattr(executor, "_client", None)  # Dask's ClientExecutor
    if client is not None:
        topic = f"oftimg-frames-{uuid.uuid4().hex}"
        running: dict = {}
        client.subscribe_topic(topic, lambda event: _show_report(event[1], bar, running))
        try:
            yield _DaskTopic(topic)
            deadline = time.time() + 2.0       # events may trail the tasks' results
            while bar.n < bar.total and time.time() < deadline:
                time.sleep(0.02)
        finally:
            client.unsubscribe_topic(topic)
        return
    import multiprocessing as mp
    import threading

    manager = mp.get_context("spawn").Manager()
    queue = manager.Queue()
    drain = threading.Thread(target=_drain, args=(queue, bar))
    drain.start()
    try:
        yield queue
    finally:
        _Reports(queue).put(None)
        drain.join()
        manager.shutdown()


class _DaskTopic:
    """``put(n)`` from a task on a Dask worker: an event on the client's topic."""

    def __init__(self, topic: str):
        self.topic = topic

    def put(self, report) -> None:
        from distributed import get_worker

        get_worker().log_event(self.topic, report)


def _frames_in_workers(datasets, reports, finished: Finished, fingerprints, opts, executor, *,
                       fps, figures, quiet, out: Path) -> dict:
    """One dataset after another, each one's frames in ``executor``'s workers, each
    kept in ``finished`` as it ends; returns the summaries by name."""
    summaries = {}
    for k, ds in enumerate(datasets):
        name = ds.meta.name
        log.info("%s: analysing %d frames (%d of %d datasets)", name, ds.n_frames, k + 1,
                 len(datasets))
        summary = analyse_and_write(ds, reports[name], finished.writing(name), opts, fps=fps,
                                    quiet=quiet, executor=executor, results_at=out / name,
                                    figures=figures)
        finished.keep(name, fingerprints[name], summary)
        summaries[name] = summary
        _log_done(summary)
    return summaries


def _log_done(summary: dict) -> None:
    log.info("%s: done; expand %.3f, cycle wave speed %.2f mm/s", summary["name"],
             summary["expand_fraction"], summary["wave_speed_mm_s"]["cycle"])


def _write_run(summaries, finished: Finished, out, paths, opts, *, overwrite, started,
               cluster_alpha, figures):
    """The finished datasets and the cohort tables, figures and pages, staged into ``out``."""
    with staged_output(out, overwrite=overwrite) as tmp:
        for s in summaries:
            finished.copy_into(s["name"], tmp)
        run_info = _run_info(paths, opts.as_dict(), started)
        if not figures:
            run_info["numbers_only"] = True
        write_cohort_outputs(tmp, summaries, run_info, cluster_alpha=cluster_alpha,
                             figures=figures)
    return out


def _run_info(inputs: list[Path], options: dict, started: float) -> dict:
    """What ``run.json`` records: oftimg, Python, platform, inputs, options, seconds."""
    return {"oftimg_version": __version__, "python": sys.version.split()[0],
            "platform": platform.platform(), "inputs": [str(Path(p).resolve()) for p in inputs],
            "options": options, "seconds": round(time.time() - started, 2)}


def write_cohort_outputs(folder: Path, summaries: list[dict], run_info: dict, *,
                         cluster_alpha: float = 0.05, figures: bool = True) -> None:
    """Cohort table (csv, md), group comparison, the area maps on one grid
    (``cohort_maps.npz``, clusters formed at ``cluster_alpha``), group figures (two
    groups or more), every dataset's page and the cohort's, ``run.json``
    (``run_info`` and ``cluster_alpha``), into ``folder``, which holds each
    dataset's results in ``folder/<name>``. ``figures=False``: no group figures."""
    from .output.figures import group_figures
    from .output.html import cohort_page, dataset_page
    from .output.report import (field_smoothing_caveat, group_comparison, map_comparison_rows,
                                smoothing_caveat, write_cohort_tables, write_groups_table,
                                write_table1_markdown)

    caveats = [c for c in (smoothing_caveat(summaries), field_smoothing_caveat(summaries),
                           field_smoothing_caveat(summaries, "strain_smoothing_ms")) if c]
    for caveat in caveats:
        warnings.warn(caveat, OftimgWarning, stacklevel=2)
    run_info = {**run_info, "cluster_alpha": cluster_alpha}
    if caveats:
        run_info["notes"] = caveats
    write_cohort_tables(folder, summaries)
    comparison = group_comparison(summaries)
    write_table1_markdown(folder, summaries, comparison)
    write_groups_table(folder, summaries, comparison)
    maps = cohort_maps(folder, summaries, cluster_alpha=cluster_alpha)
    write_cohort_maps(folder, maps)
    group_figs = []
    if figures and len({s["group"] for s in summaries}) >= 2:
        (folder / "figures").mkdir()
        group_figs = group_figures(folder, summaries, folder / "figures", maps=maps)
    for s in summaries:
        dataset_page(folder / s["name"], s)
    write_json(folder / "run.json", run_info)
    cohort_page(folder, summaries, run_info, group_figs, comparison, map_comparison_rows(maps))


def cohort(sources, out, *, overwrite: bool = False, cluster_alpha: float = 0.05) -> Path:
    """Gather datasets analysed separately (say one cluster job each, ``oftimg run
    embryo_k --out results/embryo_k``) into one cohort in ``out``, with the tables,
    group comparison, figures and pages that :func:`run` writes for a cohort.

    Each source is one dataset's results (a folder with ``summary.json``) or a
    folder of them (a run's ``--out``). All must have been analysed with the
    same options. Their files reach ``out`` by hard links where possible (or
    copies); the sources are never written to. ``cluster_alpha`` as in :func:`run`.
    Returns ``out``.
    """
    _check_cluster_alpha(cluster_alpha)
    started = time.time()
    out = Path(out)
    pairs = sorted(((read_summary(f), f) for f in result_folders(sources)),
                   key=lambda sf: natural_key(sf[0]["name"]))     # as run orders a cohort
    summaries, folders = [s for s, _ in pairs], [f for _, f in pairs]
    _check_names([(s["name"], f) for s, f in zip(summaries, folders)],
                 "analyse one again with another \"name\" in its meta.json")
    check_output_location(out, folders, overwrite=overwrite)
    options = summaries[0]["provenance"]["options"]
    for s, f in zip(summaries[1:], folders[1:]):
        a, b = _flat(options), _flat(s["provenance"]["options"])
        differ = [f"{k} {a.get(k)} and {b.get(k)}" for k in sorted(set(a) | set(b))
                  if a.get(k) != b.get(k)]
        if differ:
            raise InputError(f"{folders[0]} and {f} were analysed with different options "
                             f"({'; '.join(differ)}): a cohort compares like with like; "
                             "analyse them again with the same options")
    _warn_unfinished_beside(folders)
    versions = {s["provenance"]["oftimg_version"] for s in summaries}
    if len(versions) > 1:
        warnings.warn(f"the datasets were analysed by different oftimg versions "
                      f"({', '.join(sorted(versions))})", OftimgWarning, stacklevel=2)
    with staged_output(out, overwrite=overwrite) as tmp:
        for s, folder in zip(summaries, folders):
            shutil.copytree(folder, tmp / s["name"], copy_function=link_or_copy)
        run_info = _run_info(folders, options, started)
        run_info["datasets_seconds"] = _datasets_seconds(summaries)
        write_cohort_outputs(tmp, summaries, run_info, cluster_alpha=cluster_alpha)
    return out


def paraview(sources, out, *, quiet: bool = False, jobs: int | None = None) -> Path:
    """Every dataset's results among ``sources`` (as :func:`cohort` takes them) as
    ParaView time series in ``out/<name>/`` (:mod:`oftimg.output.paraview`): the
    grids with their node fields, and the section contours; each series in one of
    ``jobs`` worker processes (default: all cores). ``out`` must be new or empty;
    it appears only when complete. Returns ``out``."""
    from .output.paraview import series_names, write_series
    from .analysis.pipeline import run_tasks

    out = Path(out)
    names, folders = _exported(sources, out, (
        ("grids.npz", "the grids are what ParaView shows"),
        ("arrays.json", "it says which arrays lie on the grids")))
    with staged_output(out) as tmp:
        tasks = [(f, series, tmp / name) for name, f in zip(names, folders)
                 for series in series_names(f)]
        bar = Progress(len(tasks), "ParaView series", quiet=quiet, unit="series")
        with closing_executor(make_executor(jobs)) as executor:
            run_tasks(write_series, tasks, executor=executor, progress=bar.advance)
        bar.close()
    return out


def tiff(sources, out, *, quiet: bool = False) -> Path:
    """Every dataset's maps and fields among ``sources`` (as :func:`cohort` takes
    them) as TIFF images that Fiji / ImageJ open, in ``out/<name>/``, and the cohort
    maps of a run's ``--out`` among them in ``out/cohort_maps/`` (with several runs,
    ``cohort_maps_<its folder name>/``; :mod:`oftimg.output.tiff`). ``out`` must be new
    or empty; it appears only when complete. Returns ``out``."""
    from .output.tiff import write_cohort_map_images, write_tiff_images

    out = Path(out)
    names, folders = _exported(sources, out, (
        ("arrays.json", "it says which arrays are images"),))
    runs = [s for s in source_paths(sources) if (s / "cohort_maps.json").is_file()]
    with staged_output(out) as tmp:
        bar = Progress(len(folders) + len(runs), "TIFF images", quiet=quiet, unit="folder")
        for name, folder in zip(names, folders):
            write_tiff_images(folder, tmp / name)
            bar.advance()
        for run in runs:
            write_cohort_map_images(run, tmp / ("cohort_maps" if len(runs) == 1
                                                else f"cohort_maps_{run.name}"))
            bar.advance()
        bar.close()
    return out


def ome_zarr(sources, out, *, quiet: bool = False) -> Path:
    """Every dataset's fields, phase maps and pullbacks among ``sources`` (as
    :func:`cohort` takes them) as OME-Zarr images with their axes and units, in
    ``out/<name>/<array>.ome.zarr`` (:mod:`oftimg.output.omezarr`; the (v, t) maps
    :func:`tiff` writes). ``out`` must be new or empty; it appears only when complete.
    Returns ``out``."""
    from .output.omezarr import write_ome_zarr_images

    try:
        import zarr  # noqa: F401
    except ImportError:
        raise InputError("writing OME-Zarr needs zarr: pip install 'oftimg[ome]'") from None
    out = Path(out)
    names, folders = _exported(sources, out, (
        ("arrays.json", "it says which arrays are images"),))
    with staged_output(out) as tmp:
        bar = Progress(len(folders), "OME-Zarr images", quiet=quiet, unit="folder")
        for name, folder in zip(names, folders):
            write_ome_zarr_images(folder, tmp / name)
            bar.advance()
        bar.close()
    return out


def _exported(sources, out: Path, needed: tuple[tuple[str, str], ...]
              ) -> tuple[list[str], list[Path]]:
    """The names and folders of the datasets' results among ``sources`` to export
    into ``out``; refused where two share a name, one lacks a file of ``needed``
    ((file, why it is needed) each), or ``out`` is not new and empty or lies inside
    one of them."""
    folders = result_folders(sources)
    names = [read_summary(f)["name"] for f in folders]
    _check_names(list(zip(names, folders)), "export them one at a time")
    for f in folders:
        for file, why in needed:
            if not (f / file).is_file():
                raise DatasetError(f"{f}: has no {file} ({why})")
    require_new_folder(out)
    check_output_location(out, folders, overwrite=False)
    return names, folders


def _datasets_seconds(summaries: list[dict]) -> float | None:
    """Seconds the datasets' own runs took (validation, analysis, writing), summed;
    None when a summary does not record them (written by an older oftimg)."""
    try:
        return round(sum(s["validation"]["seconds"] + s["timings_s"]["total_s"]
                         for s in summaries), 2)
    except (KeyError, TypeError):
        return None


def _warn_unfinished_beside(folders: list[Path]) -> None:
    """Warn about runs that did not finish beside the gathered results (say a cluster
    job killed at its time limit): ``.<name>.finished`` folders, which
    :func:`finished_folder` removes once a run succeeds. Their datasets are not in
    the cohort."""
    unfinished = sorted({p for parent in {f.parent for f in folders}
                         for p in parent.glob(".*.finished") if p.is_dir()})
    if unfinished:
        names = ", ".join(p.name[1:-len(".finished")] for p in unfinished)
        warnings.warn(f"{unfinished[0].parent}: {len(unfinished)} run(s) into {names} did not "
                      "finish (or are still going), so their datasets are not in this cohort; "
                      "run them again with --resume, then gather again", OftimgWarning,
                      stacklevel=3)


def _flat(options: dict, prefix: str = "") -> dict:
    """``{"grid": {"n_u": 80}}`` -> ``{"grid.n_u": 80}``."""
    out = {}
    for key, value in options.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[prefix + key] = value
    return out


def make_phantom(out, *, group: str = "normal", seed: int = 0, frames: int = 195,
                 quiet: bool = False, labels: bool = False,
                 voxel_size_um: tuple[float, float, float] = (4.0, 4.0, 8.0),
                 segmentation_noise: float | None = None, probabilities: bool = False,
                 intensity: bool = False, **overrides) -> Path:
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
            raise InputError("--intensity needs --labels (or --probabilities): intensity "
                             "volumes lie on a label dataset's voxels")
        overrides.setdefault("twist_deg", TEXTURE_TWIST_DEG)
    params = sample_params(group, seed, n_frames=frames, **overrides)
    bar = Progress(frames, f"phantom {Path(out).name}", quiet=quiet)
    with staged_output(out) as tmp:
        if labels:
            write_label_phantom(tmp, params, voxel_size_um, noise=segmentation_noise,
                                name=Path(out).name, progress=bar.update,
                                probabilities=probabilities, intensity=intensity)
        else:
            write_phantom(tmp, params, name=Path(out).name, progress=bar.update)
    bar.close()
    return Path(out)


def mesh(source, out, *, options: dict | None = None, jobs: int | None = None,
         quiet: bool = False) -> Path:
    """Mesh a label dataset (or each of a cohort's) into a mesh dataset in ``out``
    (``out/<name>`` for a cohort): ``outer/``, ``inner/``, ``lumen/`` PLY files in
    the volumes' length unit and meta.json carried over, to look at in ParaView or
    MeshLab. ``options``: :class:`~oftimg.mesh.labels.MeshOptions` fields. Nothing
    is written when a frame cannot be meshed."""
    from .mesh.labels import MeshOptions

    meshing = MeshOptions(**(options or {}))
    out = Path(out)
    paths = [p for p in _as_dataset_paths(source) if is_label_dataset(p)]
    if not paths:
        raise DatasetError(f"{source}: no label dataset (a folder with labels/) to mesh")
    check_output_location(out, paths, overwrite=False)
    datasets = [load_label_dataset(p) for p in paths]
    _check_names([(d.meta.name, d.path) for d in datasets], 'set another "name" in its meta.json')
    single = len(paths) == 1 and paths[0] == Path(source)
    executor = make_executor(jobs, None)
    with closing_executor(executor), staged_output(out) as tmp:
        for lds in datasets:
            folder = tmp if single else tmp / lds.meta.name
            folder.mkdir(parents=True, exist_ok=True)
            record = _mesh_with_bar(lds, folder, meshing, executor, quiet)
            write_json(folder / "meshing.json", record)
            for note in meshing_notes(lds.path, record["meshing"]):
                warnings.warn(note, OftimgWarning, stacklevel=2)
    return out


# the demo cohorts: embryos per group, and each phantom's frames and vertices
DEMO_SMALL = (3, {"frames": 24, "vertices_min": 2000, "vertices_max": 2500})
DEMO_FULL = (4, {"frames": 195})


def demo(out, *, full: bool = False, overwrite: bool = False, quiet: bool = False,
         jobs: int | None = None) -> Path:
    """Generate the built-in phantom cohort and run the whole pipeline on it.

    Small (default): three normal and three banded embryos, enough for the
    report's group comparison to have p-values, of 24 frames and smaller meshes
    (about two minutes on 2 cores). ``full``: 4 normal + 4 banded, 195 frames, the
    paper's size.
    Returns ``out``; the generated data are in ``out/data``.
    """
    per_group, kwargs = DEMO_FULL if full else DEMO_SMALL
    return _phantom_cohort(Path(out), per_group, kwargs, overwrite=overwrite, quiet=quiet,
                           jobs=jobs)


def _phantom_cohort(out: Path, per_group: int, phantom: dict, *, overwrite: bool, quiet: bool,
                    jobs: int | None) -> Path:
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
            with warnings.catch_warnings():     # the phantoms' expected notes
                warnings.simplefilter("ignore", OftimgWarning)
                _phantom_cohort(tmp / "cohort", *EXAMPLE_COHORT, overwrite=False, quiet=True,
                                jobs=None)
            try:
                (tmp / "cohort").rename(folder)
            except OSError:                     # another call finished first
                if not (folder / "results" / "run.json").is_file():
                    raise
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        for older in root.glob("example-cohort-*"):     # made by another oftimg: not reused
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
