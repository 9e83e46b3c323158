"""Sphinx configuration of the fogbench documentation (``make docs``; CI builds it with -W)."""

import os
import sys

# The packages are installed in the project's .venv (``pip install -e '.[docs]'``); the path is
# for a build run from a checkout without the editable install.
sys.path.insert(0, os.path.abspath(".."))

project = "fogbench"
author = "the fogbench authors"
copyright = "the fogbench authors"

extensions = [
    "myst_parser",          # Markdown pages
    "sphinx.ext.autodoc",   # API reference from the docstrings ...
    "numpydoc",             # ... which are numpydoc
    "sphinx.ext.mathjax",   # the theory pages' equations
    "sphinxarg.ext",        # the command line, from fogbench.cli.build_parser()
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build"]

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# Every cross-reference must resolve: a renamed function or a broken link fails the -W build.
nitpicky = True
# Types are in the numpydoc docstrings (with shapes and units); signatures stay plain.
autodoc_typehints = "none"
autodoc_member_order = "bysource"
numpydoc_show_class_members = False

# Command lines and flags are quoted as typed: no "--" turned into a dash, no curly quotes.
smartquotes = False

html_theme = "furo"
html_title = "fogbench"
html_static_path = []

# ---------------------------------------------------------------------------------------------
# The docs' own extensions, in docs/_ext/.
sys.path.insert(0, os.path.abspath("_ext"))
extensions.append("scenario_keys")   # the scenario keys' tables, from the validator
extensions.append("citation_labels")  # numpydoc's "[1]_" shown as [1] on the MyST API pages
