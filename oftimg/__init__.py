"""oftimg: beating tubes (embryonic heart outflow tract, vessels, gut) turned
into consistent (u, v) grids, images, videos and numbers."""
__version__ = "0.1.0"

from .api import demo, make_phantom, run  # noqa: E402
from .errors import InputError  # noqa: E402
from .io import Dataset, DatasetError, OftimgWarning, load_dataset, validate_dataset  # noqa: E402

__all__ = ["Dataset", "DatasetError", "InputError", "OftimgWarning", "demo", "load_dataset",
           "make_phantom", "run", "validate_dataset", "__version__"]
