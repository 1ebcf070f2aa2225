# SPDX-License-Identifier: GPL-3.0-or-later
"""Sphinx configuration of the rbc documentation site.

Built by `cmake --build build --target docs` or `.ci/docs.sh [BUILD_DIR]`, always with warnings
as errors (`sphinx-build -W --keep-going -n`). It reads the build tree named by the environment
variable RBC_BUILD_DIR (default: ../build beside this folder):

- `RBC_BUILD_DIR/rbc <command> --help` gives the option tables of the user guide (gen_cli.py);
- `RBC_BUILD_DIR/python` holds the compiled Python package that autodoc imports;
- Doxygen writes the XML of the C++ headers to `RBC_BUILD_DIR/docs/doxygen` for Breathe.
"""
from __future__ import annotations

import os
import re
import pathlib
import subprocess
import sys

DOCS = pathlib.Path(__file__).resolve().parent
ROOT = DOCS.parent
BUILD = pathlib.Path(os.environ.get("RBC_BUILD_DIR", ROOT / "build")).resolve()

sys.path.insert(0, str(DOCS))  # gen_cli (the option-table directive)
sys.path.insert(0, str(BUILD / "python"))  # the compiled `rbc` package

project = "rbc"
author = "the rbc authors"
copyright = "the rbc authors; GPL-3.0-or-later"
release = "0.1.0"
version = "0.1"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx_copybutton",
    "sphinxcontrib.bibtex",
    "breathe",
    "gen_cli",
    "rbc_api",
]

source_suffix = {".md": "markdown"}
root_doc = "index"
smartquotes = False  # "--option" must not become an en dash
exclude_patterns = ["_build", "README.md"]
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

html_theme = "furo"
html_title = "rbc 0.1.0"
html_static_path = ["_static"]
html_css_files = ["rbc.css"]

bibtex_bibfiles = ["references.bib"]
bibtex_default_style = "plain"
bibtex_reference_style = "author_year"

copybutton_prompt_text = "$ "

# --- gen_cli: the `rbc` executable whose --help the option tables come from
rbc_executable = str(BUILD / "rbc")

# --- autodoc (the Python package, imported from the build tree)
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_default_options = {"members": True, "undoc-members": False}

# --- Doxygen + Breathe: every header of the library folders, one API page per folder (rbc_api.py)
DOXYGEN_XML = BUILD / "docs" / "doxygen"
API_FOLDERS = ["core", "discrete", "homogenise", "continuum", "compare", "calibrate"]
rbc_source_root = str(ROOT)
PUBLIC_HEADERS = [str(p.relative_to(ROOT)) for f in API_FOLDERS for p in sorted((ROOT / f).glob("*.hpp"))]


def _run_doxygen() -> None:
    """Writes the Doxygen XML of PUBLIC_HEADERS (re-run on every build: seconds)."""
    DOXYGEN_XML.parent.mkdir(parents=True, exist_ok=True)
    config = "\n".join([
        "PROJECT_NAME = rbc",
        f"OUTPUT_DIRECTORY = {DOXYGEN_XML.parent}",
        "XML_OUTPUT = doxygen",
        "GENERATE_XML = YES",
        "GENERATE_HTML = NO",
        "GENERATE_LATEX = NO",
        "EXTRACT_ALL = YES",
        "EXTRACT_PRIVATE = NO",
        "EXTRACT_STATIC = YES",
        "HIDE_UNDOC_MEMBERS = NO",
        "HIDE_UNDOC_CLASSES = NO",
        "JAVADOC_AUTOBRIEF = YES",
        "QUIET = YES",
        "WARNINGS = NO",
        "ENABLE_PREPROCESSING = YES",
        "MACRO_EXPANSION = YES",
        "AUTOLINK_SUPPORT = NO",
        "STRIP_FROM_PATH = " + str(ROOT),
        "INPUT = " + " ".join(str(ROOT / h) for h in PUBLIC_HEADERS),
    ])
    # Doxygen also notes HTML-like words in comments ("<data>") on stderr; they are not errors.
    subprocess.run(["doxygen", "-"], input=config, text=True, check=True, cwd=ROOT,
                   stderr=subprocess.DEVNULL)


_run_doxygen()
breathe_projects = {"rbc": str(DOXYGEN_XML)}
breathe_default_project = "rbc"
breathe_domain_by_extension = {"hpp": "cpp"}
breathe_show_include = False

# Nitpicky mode (-n) resolves every cross-reference. Names the site cannot document because
# they belong to other libraries (the standard library, Eigen, numpy, scipy, pybind11's
# rendering of array shapes) are listed here; the project's own names must all resolve.
nitpick_ignore_regex = [
    # The project's namespaces: Sphinx's C++ domain declares no namespace objects, so the
    # qualifier of a declaration such as rbc::run_stretch has nothing to link to.
    (r"cpp:identifier", r"(rbc::)?(rbc|units|defaults|detail)"),
    (r"cpp:identifier", r"(std|Eigen|CLI|nlohmann|H5|hid_t|hsize_t|herr_t|cholmod_.*)(::.*)?"),
    (r"cpp:identifier", r"gsl_.*"),  # GSL's random number generators
    (r"cpp:identifier", r"Vec3::(Zero|Ones|UnitX|UnitY|UnitZ)"),  # Eigen's, through the alias
    (r"cpp:identifier", r"(size_t|uint64_t|int64_t|uint32_t|int32_t|ptrdiff_t)"),
    (r"py:class", r"(numpy|np|scipy|meshio|collections|typing|enum|os|io)\..*"),
    (r"py:class", r"(numpy\.)?ndarray.*|NDArray.*|ArrayLike|Callable.*|Optional.*|Sequence.*"),
    (r"py:class", r"(float|int|str|bool|object|dict|list|tuple|None|Any)"),
    (r"py:class", r"handle"),  # pybind11's name for an argument of any Python type
]


def _escape_bars(app, what, name, obj, options, lines):
    """Docstrings write |G| for a group's order; reStructuredText would read a substitution."""
    for i, line in enumerate(lines):
        lines[i] = re.sub(r"(?<![\\|])\|(\w[^|]*?)\|(?!_)", r"\\|\1\\|", line)


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars)
