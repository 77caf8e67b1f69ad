"""oftimg: beating tubes (embryonic heart outflow tract, vessels, gut) turned
into consistent (u, v) grids, images, videos and numbers.

The package is cut in layers (:data:`LAYERS`, lowest first): a module imports only
from its own layer or lower ones (``tests/test_layers.py`` checks it).
"""

__version__ = "0.1.0"

# the layers, lowest first: the leaves (errors, a progress bar, memory), per-frame mesh
# geometry, the dataset contract and files, maps and fields as images, the stages of
# one dataset, results written and read back, synthetic data with a known truth, the
# orchestration of runs (API, worker pools), and the command line (python -m oftimg
# too) and the napari plugin on top
LAYERS = (
    ("errors", "progress", "memory"),
    ("mesh",),
    ("io",),
    ("image",),
    ("analysis",),
    ("output",),
    ("synthetic",),
    ("api", "cohorts", "demos", "exports", "inputs", "workers"),
    ("cli", "napari", "__main__"),
)

import importlib

# The public names, each read from its module on first use (PEP 562): a worker
# process that imports only ``oftimg.analysis.per_frame`` then skips the image analysis,
# figures and video modules (0.83 -> 0.52 s of imports per worker process).
_WHERE = {
    "run": "api",
    "cohort": "cohorts",
    "demo": "demos",
    "example_results": "demos",
    "make_phantom": "demos",
    "paraview": "exports",
    "ome_zarr": "exports",
    "tiff": "exports",
    "InputError": "errors",
    "Dataset": "io.dataset",
    "DatasetError": "errors",
    "OftimgWarning": "errors",
    "load_dataset": "io.dataset",
    "validate_dataset": "io.dataset",
    "Results": "output.results",
    "load_cohort": "output.results",
    "load_cohort_maps": "output.results",
    "load_results": "output.results",
}
__all__ = sorted(_WHERE) + ["__version__"]


def __getattr__(name: str):
    if name in _WHERE:
        value = getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_WHERE))
