"""Sphinx configuration of daebench's documentation site (PyData theme, MyST pages,
executed notebooks). Built in CI with warnings as errors: ``sphinx-build -W -b html docs
docs/_build/html``."""

from __future__ import annotations

import os

import daebench

project = "daebench"
author = "daebench developers"
copyright = "2026, daebench developers"
release = version = getattr(daebench, "__version__", "0.1.0")

extensions = [
    "myst_nb",                 # MyST Markdown pages and executed notebooks (.md with code cells)
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",     # numpy-style docstrings
    "sphinx.ext.mathjax",
    "sphinx_click",            # the CLI reference, generated from the commands
]

source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
exclude_patterns = ["_build", "examples", "**/.ipynb_checkpoints"]

myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

# notebooks (the how-to pages with code cells) run at every build, each within a time limit;
# a cell that raises fails the build
nb_execution_mode = os.environ.get("DAEBENCH_DOCS_EXECUTE", "force")
nb_execution_timeout = 300
nb_execution_raise_on_error = True
nb_merge_streams = True

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
napoleon_numpy_docstring = True
napoleon_google_docstring = False

html_theme = "pydata_sphinx_theme"
html_title = "daebench"
html_static_path = ["_static"]
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
