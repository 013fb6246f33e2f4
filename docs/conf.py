"""Sphinx configuration of the imutherm documentation.

Build (warnings are errors, as CI builds it)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The examples gallery (``examples/*.py``) is executed by sphinx-gallery during the build; set
``IMUTHERM_DOCS_NO_GALLERY=1`` to build the pages without running the examples (``plot_gallery = False``).
"""

import atexit
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

import imutherm

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS / "_ext"))   # the local extension plain_docstrings

project = "imutherm"
author = "the imutherm developers"
copyright = "2026, " + author
version = release = imutherm.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "plain_docstrings",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "gallery/*.ipynb", "gallery/*.py", "gallery/*.zip",
                    "gallery/*.md5", "gallery/*.json"]
templates_path = ["_templates"]

# -- myst: Markdown pages (dollar math, headings get anchors for cross-links)
myst_enable_extensions = ["dollarmath", "amsmath", "deflist", "colon_fence"]
myst_heading_anchors = 3

# -- API reference: autosummary writes one page per public module (docs/api/generated/)
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": False, "member-order": "bysource"}
autodoc_typehints = "none"          # the numpydoc docstrings carry the types and their units
autodoc_preserve_defaults = True    # show `mesh_size_mm=DEFAULT_MESH_MM`, not its repr
numpydoc_show_class_members = False  # autodoc lists the members; numpydoc would add a second, stub-less table
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# -- sphinx-gallery: examples/*.py, each run in the build on coarse meshes
plot_gallery = "False" if os.environ.get("IMUTHERM_DOCS_NO_GALLERY") else "True"
# the examples write under $IMUTHERM_EXAMPLES_OUT, by default the system's temporary folder, which every build on
# the machine shares (two builds side by side removed each other's sweep files): each build gets its own folder,
# removed when it ends, unless the variable is set
if "IMUTHERM_EXAMPLES_OUT" not in os.environ:
    os.environ["IMUTHERM_EXAMPLES_OUT"] = _EXAMPLES_OUT = tempfile.mkdtemp(prefix="imutherm-docs-examples-")
    atexit.register(shutil.rmtree, _EXAMPLES_OUT, ignore_errors=True)
# the attitude example reads a RepoIMU log from the shared data folder beside the repository (CI: ../shared);
# without it the example is shown but not run (run alone, it says so and stops)
SHARED = Path(os.environ.get("IMUTHERM_SHARED") or ROOT.parent / "shared")
HAVE_REPOIMU = (SHARED / "data" / "repoimu" / "Pendulum_Test02a_Trial1_Segment_1.csv.gz").is_file()
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_" if HAVE_REPOIMU else r"/plot_(?!attitude_real_log)",   # the ones executed
    "ignore_pattern": r"__init__\.py|_helpers\.py",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "show_memory": False,
    # the examples run two at a time (joblib processes; CI has two cores): the correlation example alone is
    # about 4 CPU-minutes, the other five together about 2
    "parallel": int(os.environ.get("IMUTHERM_DOCS_JOBS", "2")),
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "capture_repr": (),
}
warnings.filterwarnings("ignore", category=UserWarning,
                        message="Matplotlib is currently using agg, which is a non-GUI backend")

# -- HTML
html_theme = "pydata_sphinx_theme"
html_title = f"imutherm {version}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "header_links_before_dropdown": 7,
    "secondary_sidebar_items": ["page-toc"],
}
html_sidebars = {"**": ["sidebar-nav-bs"]}
html_static_path = []
html_show_sourcelink = False
