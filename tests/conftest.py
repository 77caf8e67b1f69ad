import warnings

import pytest

from oftimg.io import OftimgWarning
from oftimg.phantom import sample_params, write_phantom

SMALL = dict(n_frames=10, vertices_min=2500, vertices_max=3500)


@pytest.fixture(scope="session")
def phantom_normal(tmp_path_factory):
    """A small normal phantom (10 frames, 2.5-3.5k vertices per mesh)."""
    path = tmp_path_factory.mktemp("ph") / "normal"
    return write_phantom(path, sample_params("normal", 3, **SMALL))


@pytest.fixture(scope="session")
def phantom_banded(tmp_path_factory):
    path = tmp_path_factory.mktemp("ph") / "banded"
    return write_phantom(path, sample_params("banded", 1, **SMALL))


@pytest.fixture(autouse=True)
def _oftimg_warnings_visible():
    with warnings.catch_warnings():
        warnings.simplefilter("always", OftimgWarning)
        yield
