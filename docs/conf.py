"""Sphinx configuration of spacarpy's documentation site (docs/ rendered, with an API reference).

Build it with ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (the test
``tests/test_docs_site.py`` does so in a temporary copy and fails on any warning: a broken
link, a missing page, a docstring that does not parse).
"""
import os
import sys

sys.path.insert(0, os.path.abspath(".."))

project = "spacarpy"
author = "the spacarpy developers"
copyright = "2026, the spacarpy developers"
from spacarpy import __version__ as release  # noqa: E402

version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_api/**/_templates"]
templates_path = ["_templates"]

# Markdown as the pages are written for GitHub: heading anchors as GitHub makes them, so the
# links between pages (deck.md#some-heading) resolve in both places; $...$ maths.
myst_heading_anchors = 4
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_url_schemes = ["http", "https", "mailto"]

# The API reference: one page per module of the package, from the docstrings.
autosummary_generate = True
autosummary_imported_members = False
# members defined in each module only (a name a package re-exports is documented where it lives)
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True,
                           "ignore-module-all": True}
napoleon_google_docstring = False       # the docstrings are numpydoc style
napoleon_numpy_docstring = True
napoleon_use_ivar = True                # "Attributes" as fields, not a second description
# The numpydoc type fields ("(n,) int", "str, optional") name array sizes and plain words that
# Sphinx tries as cross-references; where several classes have a field of that name (n, kind)
# it warns "more than one target". Those are not links anyone wrote: silence only them.
suppress_warnings = ["ref.python"]
autodoc_member_order = "bysource"
autodoc_typehints = "description"
# optional extras are imported lazily by the package; the API pages must build without them
autodoc_mock_imports = ["matplotlib", "meshio", "dask", "distributed", "exudyn", "control",
                        "xarray", "pandas", "vtk"]

html_theme = "alabaster"
html_title = f"spacarpy {release}"


def _deck_lexer():
    """A Pygments lexer for SPACAR decks: keywords, numbers, comments, SET names."""
    from pygments.lexer import RegexLexer, bygroups
    from pygments.token import Comment, Keyword, Name, Number, Operator, Text

    class DeckLexer(RegexLexer):
        name = "SPACAR deck"
        aliases = ["deck", "deck-fragment", "deck-file", "deck-error"]
        tokens = {"root": [
            (r"[#%!].*?$", Comment.Single),
            (r"^(\s*)([A-Za-z][A-Za-z0-9_]*)", bygroups(Text, Keyword)),
            (r"[-+]?(\d+\.?\d*|\.\d+)([eEdD][-+]?\d+)?", Number),
            (r"[{}()*/+\-^:=,]", Operator),
            (r"[A-Za-z_][A-Za-z0-9_]*", Name),
            (r"\s+", Text),
            (r".", Text),
        ]}
    return DeckLexer


def setup(app):
    lexer = _deck_lexer()
    for alias in lexer.aliases:
        app.add_lexer(alias, lexer)
