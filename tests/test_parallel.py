"""Worker processes give the same results as the serial run."""
import numpy as np
import pytest

from oftimg.api import make_executor
from oftimg.io import load_dataset
from oftimg.phantom import sample_params, write_phantom
from oftimg.pipeline import PipelineOptions, analyse_dataset

pytestmark = pytest.mark.slow


def test_two_workers_equal_serial(tmp_path):
    path = write_phantom(tmp_path / "p", sample_params("normal", 5, n_frames=6,
                                                       vertices_min=2000, vertices_max=2500))
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
    path = write_phantom(tmp_path / "p", sample_params("normal", 6, n_frames=5,
                                                       vertices_min=2000, vertices_max=2500))
    ds = load_dataset(path)
    serial = analyse_dataset(ds, PipelineOptions(), quiet=True)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        executor = make_executor(None, scheduler=cluster.scheduler_address)
        try:
            remote = analyse_dataset(ds, PipelineOptions(), quiet=True, executor=executor)
        finally:
            executor.shutdown()
            executor._client.close()
    for name, g in serial["grids"].items():
        assert np.allclose(g, remote["grids"][name], atol=1e-12), name
    assert remote["summary"]["expand_fraction"] == serial["summary"]["expand_fraction"]


def test_jobs_must_be_positive():
    with pytest.raises(ValueError, match="--jobs"):
        make_executor(0)
    assert make_executor(1) is None
