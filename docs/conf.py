"""Sphinx configuration of oftimg's documentation site (``make docs``)."""

from __future__ import annotations

import os

import oftimg

os.environ.setdefault("MPLBACKEND", "Agg")

project = "oftimg"
author = "the oftimg developers"
copyright = "the oftimg developers, BSD-3-Clause"
release = version = oftimg.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinxarg.ext",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "examples"]
myst_heading_anchors = 3

autosummary_generate = True
autodoc_default_options = {"members": True, "undoc-members": False}
numpydoc_show_class_members = False
numpydoc_validation_checks = set()

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
}

html_theme = "pydata_sphinx_theme"
html_title = f"oftimg {release}"
html_theme_options = {"navigation_with_keys": False}


def _only_oftimg_members(app, what, name, obj, skip, options):
    """Leave out what a module imported from elsewhere (SciPy's cKDTree, say)."""
    module = getattr(obj, "__module__", None)
    if what == "module" and isinstance(module, str) and not module.startswith("oftimg"):
        return True
    return skip


def setup(app):
    app.connect("autodoc-skip-member", _only_oftimg_members)
