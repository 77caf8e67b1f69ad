"""oftimg: beating tubes (embryonic heart outflow tract, vessels, gut) turned
into consistent (u, v) grids, images, videos and numbers."""
__version__ = "0.1.0"

import importlib

# The public names, each read from its module on first use (PEP 562): a worker
# process that imports only ``oftimg.per_frame`` then skips the image analysis,
# figures and video modules (0.83 -> 0.52 s of imports per worker process).
_WHERE = {
    "cohort": "api", "demo": "api", "make_phantom": "api", "paraview": "api", "run": "api",
    "tiff": "api",
    "InputError": "errors",
    "Dataset": "io", "DatasetError": "io", "OftimgWarning": "io", "load_dataset": "io",
    "validate_dataset": "io",
    "Results": "results", "load_cohort": "results", "load_cohort_maps": "results",
    "load_results": "results",
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
