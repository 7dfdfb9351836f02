"""Sphinx configuration for the precise_impact documentation.

Build (from the repository root, with ``pip install -e '.[docs]'``):

    sphinx-build -W --keep-going -b html -d docs/_build/doctrees docs docs/_build/html
    sphinx-build -W --keep-going -b doctest -d docs/_build/doctrees docs docs/_build/doctest

(the doctest build runs every example, on the html build's parse: one doctree directory).
"""

import sys
from importlib import metadata
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "_ext"))

project = "precise_impact"
author = "precise_impact developers"
copyright = "2026, precise_impact developers"
release = metadata.version("precise_impact")
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.doctest",
    "sphinx.ext.mathjax",
    # MathJax 3 shipped in the [docs] extra and copied into _static/: formulas render
    # without a network (tests/test_docs_build.py checks that no page loads a remote script)
    "sphinx-mathjax-offline",
    "numpydoc",
    # docs/_ext: figures made by the package's own code at build time, and the tables of the
    # circuit-builders page generated from the code
    "docfigures",
    "componenttables",
]

# The API pages document what is installed (autodoc imports the package).
autodoc_member_order = "bysource"
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autodoc_typehints = "none"  # types are in the numpydoc sections
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
# Validation: every documented object (public API and module helpers alike) must have a
# summary line and parameter sections that match its signature: no documented parameter
# that does not exist (PR02), the signature's order (PR03), "name : type" (PR10).
# The curated public API (precise_impact.__all__, precise_impact.testing.__all__ and the
# solvers' solve methods) is held to more in tests/test_docs.py: every parameter
# documented (PR01) and a Returns section (RT01).
numpydoc_validation_checks = {"SS01", "PR02", "PR03", "PR10"}

# The examples in the user guide run under `sphinx-build -b doctest`; each page's setup
# imports the package and makes figures without a display.
doctest_global_setup = """
import math
import numpy as np
import precise_impact as pi
"""

exclude_patterns = ["_build"]
html_theme = "alabaster"
# Wide enough for the code blocks (alabaster's default 940 px column hid everything past
# ~55 characters of a code line behind a scroll bar); below 1240 px the theme's narrow
# layout uses the whole window, and longer lines wrap (_static/custom.css).
html_theme_options = {"page_width": "1240px", "sidebar_width": "230px", "body_max_width": "none"}
html_static_path = ["_static"]
html_css_files = ["custom.css"]  # code lines wrap rather than scroll out of sight
nitpicky = False


def _skip_undocumented_slots(app, what, name, obj, skip, options):
    # ``__slots__`` entries (tuples here, no docstrings of their own) are not API.
    if repr(obj) in ("SLOTS_ATTR", "SLOTSATTR") or type(obj).__name__ == "member_descriptor":
        return True
    return None


def setup(app):
    app.connect("autodoc-skip-member", _skip_undocumented_slots)
