"""Whether napari's window can start here, said in one line: napari and one Qt
binding installed, Qt's own libraries and its xcb platform plugin's loadable (the
system libraries a pip-installed Qt does not bring, named as Debian / Ubuntu
packages), and a screen (or Xvfb) to open on. ``python -m oftimg.napari --check``.

Why: Qt names the first library it misses and aborts (exit 134), and pip cannot
install system libraries; a lab on a fresh Linux machine met that one library at a
time.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
from pathlib import Path

QT_BINDINGS = ("PySide6", "PyQt6", "PyQt5", "PySide2")
# a library's soname -> its Debian / Ubuntu package, where the package's name is not
# the soname's stem and version run together (libxcb-icccm.so.4 -> libxcb-icccm4)
PACKAGE_OF = {
    "libEGL.so.1": "libegl1",
    "libGL.so.1": "libgl1",
    "libOpenGL.so.0": "libopengl0",
    "libGLX.so.0": "libglx0",
    "libglib-2.0.so.0": "libglib2.0-0",
    "libgthread-2.0.so.0": "libglib2.0-0",
    "libX11-xcb.so.1": "libx11-xcb1",
    "libX11.so.6": "libx11-6",
    "libfreetype.so.6": "libfreetype6",
}
SCREENLESS_PACKAGES = ("xvfb", "xauth")


def package_of(soname: str) -> str:
    """The Debian package that holds the library ``soname`` (``libxcb-keysyms.so.1``
    -> ``libxcb-keysyms1``; ``libdbus-1.so.3`` -> ``libdbus-1-3``)."""
    if soname in PACKAGE_OF:
        return PACKAGE_OF[soname]
    match = re.fullmatch(r"(lib[\w.+-]*?)\.so\.(\d+)(?:\.\d+)*", soname)
    if match is None:
        return soname
    stem, version = match.groups()
    return (stem + ("-" if stem[-1].isdigit() else "") + version).lower()


def not_found(ldd_output: str) -> list[str]:
    """The sonames ``ldd`` could not find (its ``libx.so.1 => not found`` lines)."""
    return list(dict.fromkeys(re.findall(r"^\s*(\S+) => not found", ldd_output, re.M)))


def installed_bindings() -> list[str]:
    """The Qt bindings importable here, in qtpy's order of preference for them."""
    return [b for b in QT_BINDINGS if importlib.util.find_spec(b) is not None]


def missing_libraries() -> tuple[list[str], str]:
    """The system libraries Qt's widgets and its xcb platform plugin lack here, and
    the Qt in use (``"PySide6 6.12.0"``); ``([], "")`` when no binding is installed."""
    try:
        from qtpy import API_NAME, QT_VERSION
    except Exception:  # qtpy: no binding it can use
        return [], ""
    missing = []
    try:
        from qtpy import QtWidgets  # noqa: F401
    except ImportError as exc:  # "libEGL.so.1: cannot open ..."
        missing += re.findall(r"(lib[\w.+-]+\.so[\d.]*): cannot open", str(exc))
    plugin = _xcb_plugin()
    if plugin is not None and shutil.which("ldd"):
        out = subprocess.run(["ldd", str(plugin)], capture_output=True, text=True).stdout
        missing += not_found(out)
    return list(dict.fromkeys(missing)), f"{API_NAME} {QT_VERSION}"


def _xcb_plugin() -> Path | None:
    """Qt's xcb platform plugin (the library napari's window loads on X11)."""
    try:
        from qtpy.QtCore import QLibraryInfo

        where = (
            QLibraryInfo.path(QLibraryInfo.LibraryPath.PluginsPath)
            if hasattr(QLibraryInfo, "path")
            else QLibraryInfo.location(QLibraryInfo.PluginsPath)
        )
    except Exception:
        return None
    plugin = Path(where) / "platforms" / "libqxcb.so"
    return plugin if plugin.is_file() else None


def has_screen() -> bool:
    """A screen to open a window on: an X or Wayland display (or macOS / Windows)."""
    if os.name == "nt" or os.uname().sysname == "Darwin":
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def napari_status() -> tuple[bool, str, list[str]]:
    """``(ready, one line saying so or what is missing, Debian packages to install)``."""
    if importlib.util.find_spec("napari") is None:
        return False, "napari is not installed: pip install 'oftimg[napari]'", []
    bindings = installed_bindings()
    if not bindings:
        return (
            False,
            (
                "napari has no Qt binding to draw its window with: pip install "
                "'oftimg[napari]' (it brings PySide6)"
            ),
            [],
        )
    libraries, qt = missing_libraries()
    packages = list(dict.fromkeys(package_of(s) for s in libraries))
    if packages:
        return (
            False,
            (
                f"napari's window cannot start: Qt ({qt}) lacks the system libraries "
                f"{', '.join(libraries)}: sudo apt-get install {' '.join(packages)} "
                "(Debian / Ubuntu; or `make napari`)"
            ),
            packages,
        )
    import napari

    more = (
        f" (also installed: {', '.join(bindings[1:])}; QT_API chooses)" if len(bindings) > 1 else ""
    )
    if not has_screen():
        extra = [
            p for p in SCREENLESS_PACKAGES if shutil.which(p.replace("xvfb", "xvfb-run")) is None
        ]
        how = "run napari under `xvfb-run -a napari`" + (
            f" (sudo apt-get install {' '.join(extra)})" if extra else ""
        )
        return (
            False,
            (
                f"napari {napari.__version__} with {qt}{more} is ready, but there is no "
                f"screen here (no DISPLAY): {how}"
            ),
            extra,
        )
    return True, f"napari {napari.__version__} with {qt}{more}: ready", []
