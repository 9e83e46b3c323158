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
# Known warnings from text these docs do not own (docstrings in fogcomp/ and sim/, help strings
# in fogbench/). Each is to be fixed in its .py file, then its line removed here; the build
# fails on every other warning. docs/_ext/known_warnings.py hides exactly these, and warns when
# an entry hides nothing in a full build (the text was fixed: remove the entry).
sys.path.insert(0, os.path.abspath("_ext"))
extensions.append("known_warnings")
extensions.append("scenario_keys")   # the scenario keys' tables, from the validator

# numpydoc's References sections whose entries the docstring's text never cites ("[1]_"):
# Sphinx warns "Citation [R...-1] is not referenced" under a hash label that changes with the
# docstring, so these are suppressed by type (no page of ours uses citations).
suppress_warnings = ["ref.citation"]

known_warnings = [
    # (where: a substring of the location, what: a substring of the message)
    # reStructuredText that docutils cannot parse:
    ("docstring of fogcomp.methods.wnn.WaveletNeuralNetwork", 'substitution referenced: "u"'),
    ("docstring of fogcomp.methods.wavelet_soft.sure_threshold", 'substitution referenced: "x_i"'),
    ("docstring of sim.fog", 'substitution referenced: "w_a"'),
    ("docstring of fogcomp.methods.temperature.Bp", 'Unknown target name: "n_epochs"'),
    ("docstring of fogcomp.methods.flnn.Flnn", 'Unknown target name: "n_iter"'),
    ("docstring of fogcomp.noise", "Malformed table"),
    ("docstring of sim.thermal.TempSensor", "Unexpected indentation"),
    # a module docstring's "References" heading, a section of the same name as another's
    ("docstring of fogcomp.calibration", "duplicate label references"),
    ("docstring of fogcomp.metrics", "duplicate label references"),
    # cross-references to names that are private, undocumented or named from another module
    ("docstring of fogcomp.allan.allan_analysis", "target not found: identify_noise_model"),
    ("docstring of fogcomp.methods.temperature.AcoBp", "target not found: aco_sample"),
    ("docstring of fogcomp.methods.temperature.AcoBp", "target not found: aco_update"),
    ("docstring of fogcomp.methods.flnn", "py:mod reference target not found: model_lstsq"),
    ("docstring of fogcomp.methods.flnn", "py:mod reference target not found: temperature"),
    ("docstring of fogcomp.methods.model_lstsq.ModelLstsq", "target not found: estimate_error"),
    ("docstring of fogcomp.noise.avar_gm", "target not found: _gm_series"),
    ("docstring of fogcomp.noise.NoiseModel.term", "target not found: gm_terms"),
    ("docstring of sim.rig.simulate_run", "target not found: Truth"),
    ("docstring of sim.motion.build_commands", "target not found: segment_commands"),
    # fogbench's command-line help, which sphinx-argparse reads as reStructuredText
    # (fogbench/cli/allan.py, allan --curve: "adev_ci_low_/high_<unit>")
    ("", 'Unknown target name: "adev_ci_low"'),
]
# Two more are printed on stderr but are not Sphinx warnings, so they neither fail the build nor
# need an entry: numpydoc's "UserWarning: Unknown section Class Attributes A Method Sets" and
# "... Methods A Subclass Implements" (fogcomp.Compensator's docstring: numpydoc drops both
# sections from the API page), and docutils' ":1: (WARNING/2) Inline emphasis start-string
# without end-string" (fogbench check's help "every *.toml in it", parsed by sphinx-argparse).
