"""``python -m oftimg``: the command line, as ``oftimg`` (for a program that starts it
with the Python it runs in: napari's run panel)."""

import sys

from .cli import main

if __name__ == "__main__":  # not when a tool imports every module (the docs)
    sys.exit(main())
