"""A failed cohort run keeps its finished datasets; --resume reuses them."""

import json
import os

import numpy as np
import pytest

from helpers import InPlace
from oftimg import api
from oftimg.cli import main
from oftimg.output.export import Finished, finished_folder
from oftimg.synthetic.phantom import sample_params, write_phantom

pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("png_figures_only")]


def _files(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


def test_failed_run_keeps_finished_datasets_and_resume_reuses_them(tmp_path, monkeypatch, capsys):
    cohort = tmp_path / "cohort"
    for group, seed in (("normal", 7), ("banded", 8)):
        write_phantom(
            cohort / f"{group}_{seed}",
            sample_params(group, seed, n_frames=6, vertices_min=2000, vertices_max=2500),
        )
    # numbers only: what is kept and reused is the same with figures (their files are not
    # what is tested; test_parallel.py compares those)
    fresh = api.run(cohort, tmp_path / "fresh", quiet=True, jobs=1, figures=False)
    assert not finished_folder(fresh).exists()  # removed after a good run

    real = api.analyse_and_write
    analysed, validated = [], []

    def analyse(ds, *args, **kwargs):
        analysed.append(ds.meta.name)
        if ds.meta.name == "normal_7" and fail[0]:
            raise RuntimeError("disk full")
        return real(ds, *args, **kwargs)

    real_validate = api.validate_dataset
    monkeypatch.setattr(api, "analyse_and_write", analyse)
    monkeypatch.setattr(
        api,
        "validate_dataset",
        lambda ds, **kw: validated.append(ds.meta.name) or real_validate(ds, **kw),
    )
    fail = [True]
    out = tmp_path / "out"
    kept = finished_folder(out)
    # through the command line: the error, and where the finished dataset is kept
    assert (
        main(["run", str(cohort), "--out", str(out), "--quiet", "--jobs", "1", "--numbers-only"])
        == 1
    )
    err = capsys.readouterr().err
    assert "disk full" in err and str(kept) in err and "--resume" in err
    assert not out.exists()
    assert (kept / "banded_8" / "summary.json").is_file() and not (kept / "normal_7").exists()

    # an input of the finished dataset changed since: analysed again, not reused
    frame = sorted((cohort / "banded_8" / "outer").iterdir())[0]
    os.utime(frame, ns=(frame.stat().st_atime_ns, frame.stat().st_mtime_ns + 10**9))
    analysed.clear()
    with pytest.raises(RuntimeError, match="disk full") as failed:
        api.run(cohort, out, quiet=True, jobs=1, resume=True, figures=False)
    assert analysed == ["banded_8", "normal_7"] and "--resume" in failed.value.__notes__[0]

    # resumed: only the dataset that failed is validated and analysed
    fail[0] = False
    analysed.clear(), validated.clear()
    assert (
        main(
            [
                "run",
                str(cohort),
                "--out",
                str(out),
                "--quiet",
                "--jobs",
                "1",
                "--resume",
                "--numbers-only",
            ]
        )
        == 0
    )
    assert analysed == ["normal_7"] and validated == ["normal_7"]
    assert not kept.exists()
    # the same results as the run that never failed
    assert _files(out) == _files(fresh)
    for name in _files(fresh):
        if name.endswith(".npz"):
            a, b = np.load(fresh / name), np.load(out / name)
            assert all(
                np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f") for k in a.files
            ), name  # (names: strings)
        elif name.endswith("summary.json"):
            a, b = (json.loads((r / name).read_text()) for r in (fresh, out))
            for s in (a, b):  # seconds differ between runs
                s.pop("timings_s"), s["validation"].pop("seconds")
            assert a == b, name
        elif not name.endswith(("run.json", "index.html", ".mp4", ".png")):
            assert (fresh / name).read_bytes() == (out / name).read_bytes(), name


def test_by_embryo_the_datasets_running_when_one_fails_are_kept(tmp_path, monkeypatch):
    cohort = tmp_path / "cohort"
    for k in range(3):
        write_phantom(
            cohort / f"e{k}",
            sample_params("normal", k, n_frames=5, vertices_min=1500, vertices_max=1800),
        )
    real = api.embryo_task

    def task(ds, *args):
        if ds.meta.name == "e0":
            raise RuntimeError("node lost")
        return real(ds, *args)

    monkeypatch.setattr(api, "embryo_task", task)
    # three workers, all three datasets running (InPlace runs each as it is submitted)
    monkeypatch.setattr(api, "make_executor", lambda jobs, scheduler: InPlace())
    monkeypatch.setattr(api, "_n_workers", lambda executor: 3)
    out = tmp_path / "out"
    with pytest.raises(RuntimeError, match="node lost") as failed:
        api.run(cohort, out, quiet=True, parallel="embryos", figures=False)
    assert "the 2 datasets finished before this kept in" in failed.value.__notes__[0]
    assert Finished(finished_folder(out)).names() == ["e1", "e2"]
    assert not out.exists()


def test_fingerprint_changes_with_inputs_options_and_code(tmp_path, monkeypatch):
    from helpers import tube_mesh, write_series
    from oftimg.output import export
    from oftimg.io.dataset import load_dataset
    from oftimg.analysis.pipeline import PipelineOptions

    folder = write_series(tmp_path / "emb", [tube_mesh(0.2, 0.12, n_theta=16, n_s=6)] * 3)
    (folder / "meta.json").write_text(json.dumps({"period_ms": 3.0}))
    ds = load_dataset(folder)
    base = Finished.fingerprint(ds, PipelineOptions(), 30.0)
    assert Finished.fingerprint(load_dataset(folder), PipelineOptions(), 30.0) == base
    assert Finished.fingerprint(ds, PipelineOptions(warp=True), 30.0) != base
    assert Finished.fingerprint(ds, PipelineOptions(n_u=64), 30.0) != base
    assert Finished.fingerprint(ds, PipelineOptions(), 25.0) != base
    assert Finished.fingerprint(ds, PipelineOptions(), 30.0, figures=False) != base  # numbers only
    (folder / "meta.json").write_text(json.dumps({"period_ms": 3.5}))
    assert Finished.fingerprint(ds, PipelineOptions(), 30.0) != base
    (folder / "meta.json").write_text(json.dumps({"period_ms": 3.0}))
    os.utime(folder / "meta.json", ns=(base["inputs"][-1][2],) * 2)
    assert Finished.fingerprint(ds, PipelineOptions(), 30.0) == base
    monkeypatch.chdir(tmp_path)  # the dataset named from another folder: the same
    assert Finished.fingerprint(load_dataset("emb"), PipelineOptions(), 30.0) == base
    monkeypatch.setattr(export, "_source_digest", lambda: "changed code")
    assert Finished.fingerprint(ds, PipelineOptions(), 30.0) != base


def test_a_second_run_into_the_same_out_stops_at_once(tmp_path, capsys):
    import fcntl

    from helpers import tube_mesh, write_series

    folder = write_series(tmp_path / "emb", [tube_mesh(0.2, 0.12, n_theta=16, n_s=6)] * 3)
    (folder / "meta.json").write_text(json.dumps({"period_ms": 3.0}))
    out = tmp_path / "out"
    kept = finished_folder(out)
    kept.mkdir()
    (kept / "emb.writing").mkdir()  # the other run's dataset in progress
    with open(kept / ".lock", "w") as other_run:
        fcntl.flock(other_run, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert main(["run", str(folder), "--out", str(out), "--quiet", "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert "another oftimg run is writing" in err and str(out) in err
    assert (kept / "emb.writing").is_dir() and not out.exists()


def test_a_kept_dataset_is_reused_only_with_a_whole_record_of_the_same_fingerprint(tmp_path):
    """A run killed while writing a dataset's record leaves it cut short: --resume
    must analyse that dataset again, not fail on the record or trust it."""
    finished = Finished(tmp_path / "kept")
    (finished.writing("e1") / "summary.json").write_text("{}")
    fingerprint = {"inputs": [["f0.ply", 10, 1]], "options": {"warp": False}}
    finished.keep("e1", fingerprint, {"n_frames": 5, "speed": float("nan")})
    summary = finished.summary_if_current("e1", fingerprint)
    assert summary["n_frames"] == 5 and np.isnan(summary["speed"])
    assert finished.summary_if_current("e1", {**fingerprint, "options": {"warp": True}}) is None
    record = finished.root / "e1.json"
    record.write_text(record.read_text()[:40])  # cut short
    assert finished.summary_if_current("e1", fingerprint) is None
    record.unlink()
    assert finished.summary_if_current("e1", fingerprint) is None
