"""Sphinx configuration of the lieint documentation.

Build: ``sphinx-build -W -b html docs docs/_build/html`` (warnings are errors). The gallery
examples run quickly by default; ``LIEINT_FULL_EXAMPLES=1`` runs the full-size studies.
"""

import os

import lieint

project = "lieint"
author = "the lieint developers"
copyright = "2026, the lieint developers"
release = version = lieint.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = [
    "_build",
    "examples/README.txt",
    "auto_examples/*.ipynb",
    "auto_examples/*.py",
    "auto_examples/*.zip",
    "auto_examples/*.md5",
    "auto_examples/*.codeobj.json",
]
autosummary_generate = True
autodoc_default_options = {"members": True, "inherited-members": False}
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
myst_heading_anchors = 3
suppress_warnings = ["myst.header"]
html_theme = "alabaster"
html_static_path = []

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "within_subsection_order": "FileNameSortKey",
    # run the examples in as many processes as sphinx-build's -j (joblib): most of the build's time
    "parallel": True,
}
os.environ.setdefault("MPLBACKEND", "Agg")
