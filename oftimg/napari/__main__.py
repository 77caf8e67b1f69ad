"""``python -m oftimg.napari --check``: whether napari's window can start here, in
one line (exit 0 ready, 1 not); ``--packages``: only the Debian / Ubuntu packages it
lacks, space-separated (for ``make napari``)."""

import argparse
import sys

from .check import napari_status


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m oftimg.napari", description="whether napari's window can start here"
    )
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--check", action="store_true", help="say it in one line")
    what.add_argument(
        "--packages",
        action="store_true",
        help="print the system packages (Debian / Ubuntu) it lacks",
    )
    args = parser.parse_args(argv)
    ready, line, packages = napari_status()
    print(" ".join(packages) if args.packages else line)
    return 0 if ready or args.packages else 1


if __name__ == "__main__":  # not when a tool imports every module (the docs)
    sys.exit(main())
