"""Runs: one dataset or a cohort analysed into a results folder (:func:`run`), in this
process or in workers, resumed, and checked on the way.

The command line's other jobs are beside it, one module a concern: what a run reads
(:mod:`oftimg.inputs`: datasets found and opened, label volumes meshed), cohorts
(:mod:`oftimg.cohorts`), exports for other tools (:mod:`oftimg.exports`) and the
built-in data (:mod:`oftimg.demos`); this module also gives their public functions by
name (``oftimg.api.cohort`` is :func:`oftimg.cohorts.cohort`). File access happens here
and in :mod:`oftimg.io.dataset` / :mod:`oftimg.output.export`; the science lives in
:mod:`oftimg.analysis.pipeline` and the ``mesh``/``image`` modules.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import time
import uuid
import warnings
from pathlib import Path

from .cohorts import (
    _check_cluster_alpha,
    _check_names,
    _datasets_seconds,
    _run_info,
    cohort,
    write_cohort_outputs,
)
from .exports import ome_zarr, paraview, tiff
from .errors import InputError, OftimgWarning
from .inputs import _as_dataset_paths, _load, _lumens_joined, _meshed, mesh, validate_labels
from .io.dataset import Dataset, check_enough_frames, validate_dataset, with_period
from .io.label_dataset import LabelDataset
from .output.export import (
    Finished,
    check_output_location,
    finished_folder,
    staged_output,
    write_dataset_results,
)
from .progress import FramePasses, Progress
from .workers import available_memory, closing_executor, make_executor

log = logging.getLogger("oftimg")

# given here by name too (the split modules' public functions; see the docstring)
__all__ = [
    "run",
    "analyse_and_write",
    "embryo_task",
    "embryos_at_once",
    "cohort",
    "write_cohort_outputs",
    "paraview",
    "tiff",
    "ome_zarr",
    "mesh",
    "validate_labels",
    "_datasets_seconds",
]


def run(
    source,
    out,
    *,
    overwrite: bool = False,
    quiet: bool = False,
    options: dict | None = None,
    jobs: int | None = None,
    scheduler: str | None = None,
    fps: float | None = None,
    parallel: str = "auto",
    resume: bool = False,
    cluster_alpha: float = 0.05,
    period_ms: float | None = None,
    figures: bool = True,
) -> Path:
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
    if fps is not None and not (isinstance(fps, (int, float)) and math.isfinite(fps) and fps > 0):
        raise InputError(f"--fps must be a positive number of frames per second, found {fps!r}")
    _check_cluster_alpha(cluster_alpha)
    out = Path(out)
    paths = _as_dataset_paths(source)
    check_output_location(out, paths, overwrite=overwrite)
    opts = PipelineOptions(**(options or {}))
    datasets = with_period([_load(p) for p in paths], period_ms)
    _check_names([(d.meta.name, d.path) for d in datasets], 'set another "name" in its meta.json')
    for d in datasets:  # --tracking texture without intensity: before any work
        tracking_mode(d, opts.tracking, d.intensity is not None)
    started = time.time()
    finished = Finished(finished_folder(out))
    with finished.locked(out):
        return _run_locked(
            datasets,
            finished,
            out,
            paths,
            opts,
            resume=resume,
            jobs=jobs,
            scheduler=scheduler,
            parallel=parallel,
            overwrite=overwrite,
            quiet=quiet,
            fps=fps,
            started=started,
            cluster_alpha=cluster_alpha,
            figures=figures,
        )


def _run_locked(
    datasets,
    finished: Finished,
    out,
    paths,
    opts,
    *,
    resume,
    jobs,
    scheduler,
    parallel,
    overwrite,
    quiet,
    fps,
    started,
    cluster_alpha,
    figures,
) -> Path:
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
        log.info("--resume: %d of %d datasets finished before, reused", len(reused), len(datasets))
    todo = [d for d in datasets if d.meta.name not in reused]
    try:
        for ds in todo:
            check_enough_frames(ds)
        executor = make_executor(jobs, scheduler) if todo else None
        with closing_executor(executor):
            todo = [
                _meshed(ds, finished.root / f"{ds.meta.name}.meshes", opts.meshing, executor, quiet)
                if isinstance(ds, LabelDataset)
                else _lumens_joined(
                    ds, finished.root / f"{ds.meta.name}.lumens", opts.meshing, executor, quiet
                )
                for ds in todo
            ]
            reports = {ds.meta.name: _validated(ds, executor, quiet) for ds in todo}
            if parallel == "auto":
                parallel = (
                    "embryos"
                    if executor is not None and len(todo) >= 2 * _n_workers(executor)
                    else "frames"
                )
            work = (
                _embryos_in_workers
                if parallel == "embryos" and executor is not None
                else _frames_in_workers
            )
            done = work(
                todo,
                reports,
                finished,
                fingerprints,
                opts,
                executor,
                fps=fps,
                figures=figures,
                quiet=quiet,
                out=out,
            )
            summaries = [reused.get(name) or done[name] for name in names]
            _write_run(
                summaries,
                finished,
                out,
                paths,
                opts,
                overwrite=overwrite,
                started=started,
                cluster_alpha=cluster_alpha,
                figures=figures,
            )
    except BaseException as exc:
        kept = finished.names()
        if kept:
            what = "the dataset" if len(kept) == 1 else f"the {len(kept)} datasets"
            exc.add_note(
                f"{what} finished before this kept in {finished.root}: "
                "run again with --resume to reuse"
            )
        else:
            finished.remove()
        raise
    finished.remove()
    return out


def _validated(ds: Dataset, executor, quiet: bool) -> dict:
    """:func:`validate_dataset` with a progress bar; the report records its seconds."""
    tick = time.time()
    bar = Progress(
        ds.n_frames * len(ds.surfaces), f"{ds.meta.name}: checking meshes", quiet=quiet, unit="mesh"
    )
    try:
        report = validate_dataset(ds, executor=executor, progress=bar.advance)
    finally:
        bar.close()
    report["seconds"] = round(time.time() - tick, 2)
    return report


def _n_workers(executor) -> int:
    """Worker processes of a local pool, or worker threads of a Dask cluster."""
    client = getattr(executor, "_client", None)  # Dask's ClientExecutor
    if client is not None:
        return max(1, sum(client.nthreads().values()))
    return executor._max_workers


def analyse_and_write(
    ds: Dataset,
    report: dict,
    folder: Path,
    opts,
    *,
    fps: float,
    quiet: bool = True,
    executor=None,
    progress=None,
    stage=None,
    results_at: Path | None = None,
    figures: bool = True,
) -> dict:
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
                    result = analyse_dataset(
                        ds,
                        opts,
                        quiet=True,
                        executor=executor,
                        progress=progress,
                        on_aligned=aligned,
                    )
            finally:
                raised = _raise_again(caught)
            summary = result["summary"]
            summary["provenance"]["dataset"]["from_results"] = os.path.relpath(
                summary["provenance"]["dataset"]["path"], Path(results_at or folder).resolve()
            )
            summary["warnings"] = raised
            summary["validation"] = report
            stage("figures, videos" if figures else "files")
            write_dataset_results(
                folder,
                result,
                fps=fps,
                executor=executor,
                early_videos=early,
                started=started,
                figures=figures,
            )
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


def embryo_task(
    ds: Dataset,
    report: dict,
    opts,
    fps: float,
    frames_done=None,
    vector_suffixes=None,
    results_at: Path | None = None,
    figures: bool = True,
):
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

    formats = (
        contextlib.nullcontext() if vector_suffixes is None else vector_formats(vector_suffixes)
    )
    with (
        tempfile.TemporaryDirectory() as tmp,
        warnings.catch_warnings(record=True) as caught,
        formats,
    ):
        warnings.simplefilter("always")
        folder = Path(tmp) / ds.meta.name
        folder.mkdir()
        report_frames = _Reports(frames_done)
        progress = stage = None
        tail = _tail_frames(ds.n_frames)
        if frames_done is not None:
            steps = iter((0, tail // 3))  # the fields, then the files: a third of the tail

            def progress():
                report_frames.put(1)

            def stage(text):
                report_frames.put(next(steps, 0))
                report_frames.put((ds.meta.name, text))

        summary = analyse_and_write(
            ds,
            report,
            folder,
            opts,
            fps=fps,
            progress=progress,
            stage=stage,
            results_at=results_at,
            figures=figures,
        )
        report_frames.put(tail - tail // 3)
        report_frames.put((ds.meta.name, None))
        files = {
            p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*"))
            if p.is_file()
        }
    raised = list({(type(w.message), str(w.message)): w.message for w in caught}.values())
    return summary, files, raised


def _embryos_in_workers(
    datasets,
    reports,
    finished: Finished,
    fingerprints,
    opts,
    executor,
    *,
    fps,
    figures,
    quiet,
    out: Path,
) -> dict:
    """Every dataset as one :func:`embryo_task`, each kept in ``finished`` as it
    ends; returns the summaries by name. At most :func:`embryos_at_once` run at
    a time. After a dataset fails, no more are started, those running are still
    kept, then the error is raised. The bar counts the frames of the two
    per-frame passes done in all workers, and each embryo's remaining work as
    :data:`TAIL_PASSES` more passes.
    """
    from concurrent.futures import FIRST_COMPLETED, wait

    from .output.style import vector_suffixes

    bar = Progress(
        sum(2 * ds.n_frames + _tail_frames(ds.n_frames) for ds in datasets),
        f"{len(datasets)} datasets",
        quiet=quiet,
        unit="step",
    )  # a frame's pass
    log.info("%d datasets, each analysed whole in a worker", len(datasets))
    at_once = embryos_at_once(datasets, executor)
    summaries = {}
    error = None
    waiting = list(datasets)
    running: set = set()

    def top_up():  # none started after a failure
        while waiting and len(running) < at_once and error is None:
            ds = waiting.pop(0)
            running.add(
                executor.submit(
                    embryo_task,
                    ds,
                    reports[ds.meta.name],
                    opts,
                    fps,
                    frames_done,
                    vector_suffixes(),
                    out / ds.meta.name,
                    figures,
                )
            )

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
                top_up()  # the next start before these are written
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
        warnings.warn(
            f"memory for {fit} of {workers} embryos at once ({room / 1e9:.1f} GB "
            f"free, about {each / 1e9:.2f} GB each for {frames} frames): the "
            "others wait their turn",
            OftimgWarning,
            stacklevel=2,
        )
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
        except (OSError, EOFError):  # BrokenPipe, ConnectionRefused, ...
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
            deadline = time.time() + 2.0  # events may trail the tasks' results
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


def _frames_in_workers(
    datasets,
    reports,
    finished: Finished,
    fingerprints,
    opts,
    executor,
    *,
    fps,
    figures,
    quiet,
    out: Path,
) -> dict:
    """One dataset after another, each one's frames in ``executor``'s workers, each
    kept in ``finished`` as it ends; returns the summaries by name."""
    summaries = {}
    for k, ds in enumerate(datasets):
        name = ds.meta.name
        log.info(
            "%s: analysing %d frames (%d of %d datasets)", name, ds.n_frames, k + 1, len(datasets)
        )
        summary = analyse_and_write(
            ds,
            reports[name],
            finished.writing(name),
            opts,
            fps=fps,
            quiet=quiet,
            executor=executor,
            results_at=out / name,
            figures=figures,
        )
        finished.keep(name, fingerprints[name], summary)
        summaries[name] = summary
        _log_done(summary)
    return summaries


def _log_done(summary: dict) -> None:
    log.info(
        "%s: done; expand %.3f, cycle wave speed %.2f mm/s",
        summary["name"],
        summary["expand_fraction"],
        summary["wave_speed_mm_s"]["cycle"],
    )


def _write_run(
    summaries, finished: Finished, out, paths, opts, *, overwrite, started, cluster_alpha, figures
):
    """The finished datasets and the cohort tables, figures and pages, staged into ``out``."""
    with staged_output(out, overwrite=overwrite) as tmp:
        for s in summaries:
            finished.copy_into(s["name"], tmp)
        run_info = _run_info(paths, opts.as_dict(), started)
        if not figures:
            run_info["numbers_only"] = True
        write_cohort_outputs(tmp, summaries, run_info, cluster_alpha=cluster_alpha, figures=figures)
    return out
