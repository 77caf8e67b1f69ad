"""oftimg: beating tubes (embryonic heart outflow tract, vessels, gut) turned
into consistent (u, v) grids, images, videos and numbers."""
__version__ = "0.1.0"

from .api import cohort, demo, make_phantom, paraview, run, tiff  # noqa: E402
from .errors import InputError  # noqa: E402
from .io import Dataset, DatasetError, OftimgWarning, load_dataset, validate_dataset  # noqa: E402
from .results import Results, load_cohort, load_cohort_maps, load_results  # noqa: E402

__all__ = ["Dataset", "DatasetError", "InputError", "OftimgWarning", "Results", "cohort", "demo",
           "load_cohort", "load_cohort_maps", "load_dataset", "load_results", "make_phantom",
           "paraview", "run", "tiff", "validate_dataset", "__version__"]
