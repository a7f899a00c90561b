"""Sphinx configuration of the maglev-ocp documentation (``make docs``).

The settings reference is generated from the pydantic models (autodoc-pydantic),
the command-line reference from :func:`maglev_ocp.cli.build_parser`
(sphinx-argparse), the API reference from the docstrings (autosummary +
numpydoc), and the gallery from the scripts in ``examples/`` (sphinx-gallery),
which run during the build. Warnings are errors (``-W``).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display: every figure is rendered to a file

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "docs" / "_ext"))  # cli_parser: the maglev parser for sphinx-argparse

import maglev_ocp  # noqa: E402

project = "maglev-ocp"
author = "the maglev-ocp developers"
copyright = "2026, the maglev-ocp developers"
release = maglev_ocp.__version__
version = release


def _commit() -> str:
    """The code's commit (short hash), shown on every page; ``unknown`` outside a git checkout."""
    try:
        out = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=10
        )
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


COMMIT = _commit()

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.intersphinx",
    "sphinx.ext.viewcode",
    "numpydoc",
    "sphinxcontrib.autodoc_pydantic",
    "sphinxarg.ext",
    "sphinx_gallery.gen_gallery",
    "myst_parser",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "**.ipynb_checkpoints", "auto_examples/*.ipynb", "auto_examples/*.py"]
templates_path = ["_templates"]
root_doc = "index"

# -- MyST (the Markdown pages) -------------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
suppress_warnings = ["myst.xref_missing"]

# -- autodoc / autosummary / numpydoc ------------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()
numpydoc_xref_param_type = False

# -- autodoc-pydantic (the settings reference) ---------------------------------------------------------------
autodoc_pydantic_model_show_json = False
autodoc_pydantic_model_show_config_summary = False
autodoc_pydantic_model_show_validator_summary = False
autodoc_pydantic_model_show_validator_members = False
autodoc_pydantic_model_show_field_summary = True
autodoc_pydantic_model_member_order = "bysource"
autodoc_pydantic_model_undoc_members = True
autodoc_pydantic_model_members = True
autodoc_pydantic_field_list_validators = False
autodoc_pydantic_field_show_constraints = True
autodoc_pydantic_model_signature_prefix = "settings"
autodoc_pydantic_settings_show_json = False

# -- intersphinx ---------------------------------------------------------------------------------------------
# Off by default: the build must pass without network access (CI, offline machines).
intersphinx_mapping: dict[str, tuple[str, None]] = {}

# -- sphinx-gallery ------------------------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": [str(ROOT / "examples")],
    "gallery_dirs": ["auto_examples"],
    "filename_pattern": r"/plot_",  # run every plot_*.py at build time
    "ignore_pattern": r"__init__\.py|/_",
    "abort_on_example_error": True,  # a failing example fails the build
    "only_warn_on_example_error": False,
    "download_all_examples": False,
    "within_subsection_order": "FileNameSortKey",
    "plot_gallery": "True",
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "show_memory": False,
    "min_reported_time": 0,
}

# -- HTML ----------------------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"maglev-ocp {release}"
html_static_path: list[str] = []
html_theme_options = {
    "navigation_depth": 2,
    "show_toc_level": 2,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
    "secondary_sidebar_items": ["page-toc"],
}
html_context = {"commit": COMMIT}
rst_epilog = f"\n.. |commit| replace:: ``{COMMIT}``\n"
os.environ.setdefault("MPLBACKEND", "Agg")


def _literal_constraints() -> None:
    """Show each field constraint's value as an inline literal (autodoc-pydantic writes it as plain reST).

    A pattern such as ``^[A-Za-z0-9_.\\-]{1,80}$`` is otherwise read as reST markup (``0-9_`` as a link target),
    which fails the build under ``-W``.
    """
    from sphinxcontrib.autodoc_pydantic.directives.autodocumenters import PydanticFieldDocumenter

    def add_constraints(self) -> None:
        constraints = self.pydantic.inspect.fields.get_constraints(self.pydantic_field_name)
        if constraints:
            source_name = self.get_sourcename()
            self.add_line(":Constraints:", source_name)
            for key, value in constraints.items():
                self.add_line(f"   - **{key}** = ``{value}``", source_name)
            self.add_line("", source_name)

    PydanticFieldDocumenter.add_constraints = add_constraints


_literal_constraints()
