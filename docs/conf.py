"""Sphinx configuration of pidpipe's documentation.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` from the repository
(``tests/docs/test_docs_build.py`` runs the same build with warnings as errors).
Pages are Markdown (myst-parser); the API comes from the numpy-style docstrings (autodoc +
numpydoc). The configuration keys, the CLI, the API module list and the benchmark records are
generated at build time by ``docs/_ext/pidpipe_docs`` into ``reference/generated/``.
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
sys.path.insert(0, str(REPO))          # the pidpipe of this checkout, for autodoc
sys.path.insert(0, str(DOCS / "_ext"))

project = "pidpipe"
author = "the pidpipe authors"
copyright = "the pidpipe authors"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "numpydoc",
    "pidpipe_docs",
]

source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "figures/*.py", ".gitignore"]
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# autodoc + numpydoc: members in source order, no autosummary stubs for class members.
autodoc_member_order = "bysource"
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()
autosummary_generate = False          # numpydoc loads autosummary; nothing here uses its stubs

html_theme = "alabaster"
html_title = "pidpipe"
html_static_path: list[str] = []

# Docstrings whose sections are not numpydoc's (compiled kernels' argument lists, a
# "Parameters are those of ..., plus" list): shown verbatim after their summary line.
pidpipe_verbatim_docstrings = frozenset({
    "pidpipe.dem.kernel.run",
    "pidpipe.dem.coupled.run_coupled",
    "pidpipe.design.band.optimise_band_design",
})
