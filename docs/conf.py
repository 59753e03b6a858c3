"""Sphinx configuration of the navfilters documentation (``sphinx-build -W docs
docs/_build``: every warning is an error)."""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
sys.path.insert(0, str(HERE.parent))

project = "navfilters"
author = "navfilters contributors"
copyright = "navfilters contributors"
extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "myst_parser",
    "generated_pages",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "generated/figures-*.md", "generated/worlds-list.md"]
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3
autosummary_generate = True
autodoc_default_options = {"members": True, "ignore-module-all": True}
# a package re-exports its modules' names: document each where it is defined, once
napoleon_use_ivar = True  # "Attributes" sections as fields, not duplicate attribute entries
autodoc_typehints = "none"
napoleon_numpy_docstring = True
napoleon_google_docstring = False
html_theme = "alabaster"
# wide enough for the world-file reference's six columns
html_theme_options = {"page_width": "1240px", "sidebar_width": "230px", "body_max_width": "none"}
html_title = "navfilters"
