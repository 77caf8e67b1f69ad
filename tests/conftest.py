import contextlib
import os
import warnings

import pytest

from oftimg.errors import OftimgWarning
from oftimg.synthetic.phantom import sample_params, write_phantom

SMALL = dict(n_frames=36, vertices_min=2500, vertices_max=3500)

# Qt (the napari tests) without a screen draws off screen; make test gives one (Xvfb),
# on which napari's own window is tested too (tests/test_napari_window.py)
if not os.environ.get("DISPLAY"):
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")


@pytest.fixture(scope="session")
def phantom_normal(tmp_path_factory):
    """A small normal phantom (36 frames, 2.5-3.5k vertices per mesh)."""
    path = tmp_path_factory.mktemp("ph") / "normal"
    return write_phantom(path, sample_params("normal", 3, **SMALL))


@pytest.fixture(scope="session")
def phantom_banded(tmp_path_factory):
    path = tmp_path_factory.mktemp("ph") / "banded"
    return write_phantom(path, sample_params("banded", 1, **SMALL))


@pytest.fixture(scope="module")
def png_figures_only():
    """Runs write each figure as PNG only, without the PDF beside it, for the rest of
    the module: for files that test runs for their numbers, files and pages, not their
    PDFs (a PDF costs about 0.5 s, 45 % of a 6-frame cohort's run). The output contract,
    tests/test_figure_style.py and the documented demo keep the PDFs."""
    from oftimg.output.style import vector_formats

    with vector_formats(()):
        yield


@contextlib.contextmanager
def _oftimg_warnings_expected():
    """oftimg's own warnings are what it tells a user about the data; the phantoms and
    damaged inputs the suite feeds it make them on purpose, so they stay out of the
    run's warnings summary. Every one is raised ('always': a test that is about one
    catches it with pytest.warns or catch_warnings(record=True)); any other warning
    is passed on to the summary."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", OftimgWarning)
        try:
            yield
        finally:
            others = [w for w in caught if not issubclass(w.category, OftimgWarning)]
    for w in others:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


# around each phase of each test, inside pytest's own recording: fixtures of any scope too
@pytest.hookimpl(wrapper=True)
def pytest_runtest_setup(item):
    with _oftimg_warnings_expected():
        return (yield)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item):
    with _oftimg_warnings_expected():
        return (yield)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_teardown(item, nextitem):
    with _oftimg_warnings_expected():
        return (yield)


@pytest.fixture(scope="session")
def analysed_normal(phantom_normal):
    """(model, truth, analyse_dataset result) for the small normal phantom."""
    from oftimg.io.dataset import load_dataset
    from oftimg.synthetic.phantom import read_truth
    from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset

    ph, truth = read_truth(phantom_normal)
    return ph, truth, analyse_dataset(load_dataset(phantom_normal), PipelineOptions(), quiet=True)


@pytest.fixture(scope="session")
def analysed_banded(phantom_banded):
    from oftimg.io.dataset import load_dataset
    from oftimg.synthetic.phantom import read_truth
    from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset

    ph, truth = read_truth(phantom_banded)
    return ph, truth, analyse_dataset(load_dataset(phantom_banded), PipelineOptions(), quiet=True)


@pytest.fixture(scope="session")
def run_out(phantom_normal, tmp_path_factory):
    """The small normal phantom run through the command line: a results folder."""
    from oftimg.cli import main

    out = tmp_path_factory.mktemp("run") / "results"
    assert main(["run", str(phantom_normal), "--out", str(out), "--quiet"]) == 0
    return out
