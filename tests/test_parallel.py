"""Worker processes give the same results as the serial run."""

from types import SimpleNamespace

import numpy as np
import pytest
import threadpoolctl

from helpers import InPlace

from oftimg.workers import make_executor
from oftimg.io.dataset import load_dataset
from oftimg.io.meshfile import read_mesh_file, write_ply
from oftimg.synthetic.phantom import sample_params, write_phantom
from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset

pytestmark = [pytest.mark.long, pytest.mark.slow, pytest.mark.usefixtures("png_figures_only")]


def test_two_workers_equal_serial(tmp_path):
    path = write_phantom(
        tmp_path / "p", sample_params("normal", 5, n_frames=6, vertices_min=2000, vertices_max=2500)
    )
    ds = load_dataset(path)
    serial = analyse_dataset(ds, PipelineOptions(), quiet=True)
    executor = make_executor(2)
    try:
        parallel = analyse_dataset(ds, PipelineOptions(), quiet=True, executor=executor)
    finally:
        executor.shutdown()
    for name, g in serial["grids"].items():
        assert np.array_equal(g, parallel["grids"][name]), name
    for name, a in serial["arrays"].items():
        assert np.array_equal(a, parallel["arrays"][name], equal_nan=True), name


def test_dask_local_cluster_equals_serial(tmp_path):
    distributed = pytest.importorskip("distributed")
    path = write_phantom(
        tmp_path / "p", sample_params("normal", 6, n_frames=5, vertices_min=2000, vertices_max=2500)
    )
    ds = load_dataset(path)
    serial = analyse_dataset(ds, PipelineOptions(), quiet=True)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        executor = make_executor(None, scheduler=cluster.scheduler_address)
        try:
            remote = analyse_dataset(ds, PipelineOptions(), quiet=True, executor=executor)
        finally:
            executor.shutdown()
            executor._client.close()
    for name, g in serial["grids"].items():
        assert np.allclose(g, remote["grids"][name], atol=1e-12), name
    assert remote["summary"]["expand_fraction"] == serial["summary"]["expand_fraction"]


def test_warnings_raised_in_workers_reach_this_process_once():
    """A worker's warnings went to its own stderr in Python's format, past --log and
    the CLI's format."""
    import warnings

    from helpers import square_warning_on_odd
    from oftimg.errors import OftimgWarning
    from oftimg.analysis.per_frame import run_tasks
    from oftimg.workers import closing_executor

    pool = make_executor(2)
    with closing_executor(pool), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        squares = run_tasks(square_warning_on_odd, [(k,) for k in range(6)], executor=pool)
    assert squares == [0, 1, 4, 9, 16, 25]
    said = sorted(str(w.message) for w in caught if issubclass(w.category, OftimgWarning))
    assert said == ["odd 1", "odd 3"]


def test_jobs_must_be_positive():
    with pytest.raises(ValueError, match="--jobs"):
        make_executor(0)
    assert make_executor(1) is None


def _files(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


class RecordingBar:
    """A progress bar that is always 'shown' and remembers what it was told."""

    bars = []

    def __init__(self, total, desc, *, quiet=False, unit="frame"):
        self.total, self.desc, self.unit, self.n, self.notes = total, desc, unit, 0, []
        self.bars.append(self)

    shown = reporting = True

    def advance(self, n=1):
        self.n += n

    def note(self, text):
        self.notes.append(text)

    def restart(self, stage):
        self.n = 0
        self.note(stage)

    def close(self):
        pass


def test_whole_datasets_in_workers_equal_serial(tmp_path, monkeypatch):
    """--parallel embryos: each dataset analysed whole in a worker (a local pool,
    then a Dask cluster) gives the serial run's arrays, summaries and files (its
    figures in the caller's formats: PNG only here; on the cluster --numbers-only,
    the same files but the figures and videos), its warnings reach the caller,
    and the bar counts the frames done in the workers."""
    import json
    import warnings

    from oftimg import api
    from oftimg.errors import OftimgWarning

    cohort = tmp_path / "cohort"
    for group, seed in (("normal", 7), ("banded", 8)):
        write_phantom(
            cohort / f"{group}_{seed}",
            sample_params(group, seed, n_frames=6, vertices_min=2000, vertices_max=2500),
        )
    # a frame with a duplicated vertex: its repair warns while it is analysed (in a worker)
    frame = sorted((cohort / "banded_8" / "outer").iterdir())[2]
    V, F = read_mesh_file(frame)
    F = F.copy()
    V = np.concatenate([V, V[F[0, 0]][None]])
    F[0, 0] = len(V) - 1
    write_ply(frame, V, F)
    with warnings.catch_warnings(record=True) as serial_warnings:
        warnings.simplefilter("always")
        serial = api.run(cohort, tmp_path / "serial", quiet=True, jobs=1)
    with warnings.catch_warnings(record=True) as worker_warnings:
        warnings.simplefilter("always")
        monkeypatch.setattr(api, "Progress", RecordingBar)
        whole = api.run(cohort, tmp_path / "whole", quiet=True, jobs=2, parallel="embryos")
    (bar,) = [b for b in RecordingBar.bars if b.desc == "2 datasets"]
    assert (bar.unit, bar.total, bar.n) == ("step", 2 * (6 + 6) + 8, 2 * (6 + 6) + 8)
    done = [note for note in bar.notes if "datasets done" in note]
    assert done == ["1 of 2 datasets done", "2 of 2 datasets done"]
    stages = {stage for note in bar.notes if "done" not in note for stage in note.split("; ")}
    assert {
        f"{name}: {stage}"
        for name in ("normal_7", "banded_8")  # what each
        for stage in ("fields, maps, shape modes", "figures, videos")
    } <= stages  # did
    runs = {"local pool": (whole, worker_warnings)}
    try:
        import distributed
    except ImportError:  # the optional extra oftimg[dask]
        distributed = None
    if distributed is not None:
        with (
            distributed.LocalCluster(
                n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
            ) as cluster,
            warnings.catch_warnings(record=True) as dask_warnings,
        ):
            warnings.simplefilter("always")
            dask = api.run(
                cohort,
                tmp_path / "dask",
                quiet=True,
                parallel="embryos",
                scheduler=cluster.scheduler_address,
                figures=False,
            )
        runs["Dask cluster"] = (dask, dask_warnings)
        bar = [b for b in RecordingBar.bars if b.desc == "2 datasets"][-1]
        assert (bar.unit, bar.total, bar.n) == ("step", 2 * (6 + 6) + 8, 2 * (6 + 6) + 8)

    def ours(caught):
        return sorted({str(w.message) for w in caught if issubclass(w.category, OftimgWarning)})

    drawn = ("figures/", "videos/")
    for how, (out, caught) in runs.items():
        numbers_only = how == "Dask cluster"
        assert _files(out) == [
            f for f in _files(serial) if not (numbers_only and any(d in f for d in drawn))
        ], how
        for name in ("normal_7", "banded_8"):
            a, b = np.load(serial / name / "arrays.npz"), np.load(out / name / "arrays.npz")
            assert sorted(a.files) == sorted(b.files)
            for key in a.files:
                assert np.array_equal(a[key], b[key], equal_nan=True), (how, name, key)
            s1, s2 = (json.loads((r / name / "summary.json").read_text()) for r in (serial, out))
            for s in (s1, s2):
                s.pop("timings_s"), s["validation"].pop("seconds")
            assert s2.pop("numbers_only", False) == numbers_only
            assert s1 == s2, how
        assert any("merged 1 duplicate" in m for m in ours(caught)), how
        assert ours(caught) == ours(serial_warnings), how


def test_one_dataset_bar_counts_frames_then_names_the_stages(tmp_path, monkeypatch):
    from oftimg import api

    path = write_phantom(
        tmp_path / "p", sample_params("normal", 3, n_frames=5, vertices_min=1500, vertices_max=1800)
    )
    monkeypatch.setattr(api, "Progress", RecordingBar)
    api.run(path, tmp_path / "out", jobs=1)
    (bar,) = [b for b in RecordingBar.bars if b.desc == "p"]
    assert (bar.total, bar.n) == (5, 5)  # the frames, once each pass
    assert bar.notes == [
        "seams (pass 1 of 2)",
        "grids and sections (pass 2 of 2)",
        "fields, maps, shape modes",
        "figures, videos",
    ]


def test_this_process_runs_one_blas_thread_while_its_workers_run(tmp_path, monkeypatch):
    from oftimg import api
    from oftimg.analysis import pipeline

    def blas_threads():
        return {
            p["num_threads"]
            for p in threadpoolctl.threadpool_info()  # numpy's, scipy's
            if p["user_api"] == "blas"
        }

    seen = []
    monkeypatch.setattr(
        pipeline,
        "analyse_dataset",
        lambda *a, **k: (
            seen.append(blas_threads())
            or {"summary": {"provenance": {"dataset": {"path": str(tmp_path)}}}}
        ),
    )
    monkeypatch.setattr(api, "write_dataset_results", lambda *a, **k: seen.append(blas_threads()))
    ds = SimpleNamespace(n_frames=3, meta=SimpleNamespace(name="x"))
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):
        if blas_threads() != {2}:
            pytest.skip(f"numpy's BLAS cannot be set to 2 threads here ({blas_threads()})")
        api.analyse_and_write(ds, {}, tmp_path, None, fps=30.0, executor=InPlace())
        assert seen == [{1}, {1}]  # the analysis and the figures
        assert blas_threads() == {2}  # given back afterwards
        api.analyse_and_write(ds, {}, tmp_path, None, fps=30.0)  # no workers: all threads
        assert seen[2:] == [{2}, {2}]


def test_parallel_mode_is_checked(tmp_path):
    from oftimg import api

    with pytest.raises(ValueError, match="--parallel"):
        api.run(tmp_path, tmp_path / "out", parallel="datasets")


def test_embryos_at_once_fits_the_memory_left(monkeypatch):
    """A worker grows by ~60 MB + 3 MB per frame while it analyses an embryo: with
    1.5 GB free, 2 embryos of 195 frames fit (0.645 GB each, 10 % kept spare)."""
    from oftimg import api
    from oftimg.errors import OftimgWarning

    pool = SimpleNamespace(_max_workers=8)
    datasets = [SimpleNamespace(n_frames=195), SimpleNamespace(n_frames=49)]
    monkeypatch.setattr(api, "available_memory", lambda: 1.5e9)
    with pytest.warns(OftimgWarning, match="memory for 2 of 8 embryos at once"):
        assert api.embryos_at_once(datasets, pool) == 2
    monkeypatch.setattr(api, "available_memory", lambda: 0.1e9)
    with pytest.warns(OftimgWarning, match="memory for 1 of 8"):
        assert api.embryos_at_once(datasets, pool) == 1  # one at least
    monkeypatch.setattr(api, "available_memory", lambda: 64e9)
    assert api.embryos_at_once(datasets, pool) == 8
    monkeypatch.setattr(api, "available_memory", lambda: None)  # not Linux: no limit known
    assert api.embryos_at_once(datasets, pool) == 8


def test_by_embryo_no_more_run_at_once_than_fit(tmp_path, monkeypatch):
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor

    from oftimg import api
    from oftimg.output.export import Finished

    running, most = [0], [0]
    lock = threading.Lock()

    def task(ds, report, opts, fps, frames_done, vector_suffixes, results_at, figures):
        with lock:
            running[0] += 1
            most[0] = max(most[0], running[0])
        time.sleep(0.05)
        with lock:
            running[0] -= 1
        return (
            {"name": ds.meta.name, "expand_fraction": 0.4, "wave_speed_mm_s": {"cycle": 10.0}},
            {"summary.json": b"{}"},
            [],
        )

    monkeypatch.setattr(api, "embryo_task", task)
    monkeypatch.setattr(api, "embryos_at_once", lambda datasets, executor: 2)
    datasets = [SimpleNamespace(meta=SimpleNamespace(name=f"e{k}"), n_frames=3) for k in range(7)]
    with ThreadPoolExecutor(4) as pool:
        done = api._embryos_in_workers(
            datasets,
            {f"e{k}": {} for k in range(7)},
            Finished(tmp_path / "kept"),
            {f"e{k}": {} for k in range(7)},
            None,
            pool,
            fps=30.0,
            figures=True,
            quiet=True,
            out=tmp_path / "out",
        )
    assert sorted(done) == [f"e{k}" for k in range(7)]
    assert most[0] == 2
    assert Finished(tmp_path / "kept").names() == [f"e{k}" for k in range(7)]
