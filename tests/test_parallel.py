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


def test_jobs_must_be_positive():
    with pytest.raises(ValueError, match="--jobs"):
        make_executor(0)
    assert make_executor(1) is None
