"""Check that the built docs site documents every public function and class.

Usage: ``python scripts/check_api_reference.py [docs/_build/html]`` after ``make docs``
(which runs it). Public: defined in an oftimg module (not imported into it) with a
name not starting with ``_``. Prints each one missing from the API reference's
pages and exits 1 when any is; else prints how many it found.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import sys
from pathlib import Path

import oftimg


def public_objects() -> list[str]:
    """Dotted names of every public function and class defined in oftimg's modules."""
    names = []
    modules = [oftimg.__name__] + [
        m.name
        for m in pkgutil.walk_packages(oftimg.__path__, "oftimg.")
        if not m.name.endswith("__main__")
    ]  # runs the CLI
    for module_name in modules:
        module = importlib.import_module(module_name)
        for name, obj in vars(module).items():
            if name.startswith("_") or not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            if obj.__module__ == module_name:
                names.append(f"{module_name}.{name}")
    return sorted(names)


def documented(html_root: Path) -> set[str]:
    """Every anchor id of the API reference's pages."""
    ids = set()
    for page in (html_root / "api").glob("*.html"):
        ids |= set(re.findall(r'id="(oftimg\.[\w.]+)"', page.read_text(encoding="utf-8")))
    return ids


def main(argv: list[str]) -> int:
    html_root = Path(argv[0] if argv else "docs/_build/html")
    if not (html_root / "api").is_dir():
        print(f"{html_root / 'api'}: no API reference pages; build the docs first (make docs)")
        return 2
    wanted = public_objects()
    missing = [name for name in wanted if name not in documented(html_root)]
    for name in missing:
        print(f"not in the API reference: {name}")
    if missing:
        return 1
    print(f"API reference: all {len(wanted)} public functions and classes documented")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
