"""``python -m oftimg``: the command line, as ``oftimg`` (for a program that starts it
with the Python it runs in: napari's run panel)."""
import sys

from .cli import main

sys.exit(main())
