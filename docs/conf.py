"""Sphinx configuration of hexatissue's documentation site.

Build (from the repository root, with the ``docs`` extra installed)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The pages are the Markdown files of this folder (myst-parser), the API reference is generated from the
numpydoc docstrings (autosummary), and the gallery (sphinx-gallery) runs the scripts of ``docs/examples/``
on the bundled samples.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # the gallery runs headless

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS.parent))  # the package of this tree, before any installed copy
os.environ.setdefault("HEXATISSUE_PROGRESS", "0")  # no progress bars in the gallery's captured output

import hexatissue  # noqa: E402

project = "hexatissue"
author = "the hexatissue developers"
copyright = "the hexatissue developers, BSD-3-Clause"
release = hexatissue.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
# _build: the output; figures: data files the pages link to (PNG, CSV, JSON), not pages
exclude_patterns = ["_build", "figures", "examples"]

# --- Markdown (myst-parser) ---------------------------------------------------------------------------------
# the pages stay plain GitHub Markdown; headings get anchors, for links such as simulate.md#advection
myst_heading_anchors = 3

# --- API reference (autosummary + numpydoc) -----------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = True  # a package's members are defined in its submodules
autosummary_ignore_module_all = False  # a module's public names are its __all__
templates_path = ["_templates"]
autodoc_default_options = {"members": True, "inherited-members": False}
numpydoc_show_class_members = False  # members are listed by autodoc, once
numpydoc_xref_param_type = False
numpydoc_validation_checks = set()  # the docstrings' own checks are the tests'; numpydoc renders them

# --- gallery (sphinx-gallery) -------------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",  # every plot_*.py is executed
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": True,  # a failing example fails the build
    "only_warn_on_example_error": False,
}

# --- HTML ---------------------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"hexatissue {release}"
html_theme_options = {
    "navigation_depth": 2,
    "show_toc_level": 2,
}
html_static_path: list[str] = []

# --- link check (python -m sphinx -b linkcheck docs docs/_build/linkcheck) ------------------------------------
linkcheck_timeout = 15
linkcheck_retries = 2
# the project's own repository address is set with the first release (pyproject.toml, [project.urls])
linkcheck_ignore = [r"https://github\.com/hexatissue/hexatissue.*"]
