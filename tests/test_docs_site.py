"""The documentation site: docs/ rendered by Sphinx (MyST Markdown, an API reference generated
from the docstrings) builds without a single warning (issue 35, item 6).

A broken link between pages, a page left out of the table of contents, a missing image, a
docstring that does not parse or a module that cannot be imported fails the build: ``-W``
turns every warning into an error. The build runs in a copy of docs/, so the generated API
pages never land in the checkout.
"""
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow                  # (the whole site with its ~150 API pages: about 40 s)
def test_the_documentation_site_builds_without_warnings(tmp_path):
    src = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", src, ignore=shutil.ignore_patterns("_api", "_build"))
    out = tmp_path / "html"
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-E", "-q", "-b", "html",
         str(src), str(out)],
        capture_output=True, text=True, cwd=ROOT, timeout=900)
    assert proc.returncode == 0, proc.stderr[-6000:] + proc.stdout[-2000:]
    pages = {p.stem for p in (ROOT / "docs").glob("*.md")}
    built = {p.stem for p in out.glob("*.html")}
    assert pages <= built, f"pages not rendered: {sorted(pages - built)}"
    api = out / "_api"
    # the API reference: a page per module, generated from the docstrings
    modules = {".".join(p.relative_to(ROOT).with_suffix("").parts)
               for p in (ROOT / "spacarpy").rglob("*.py")
               if p.name not in ("__init__.py", "__main__.py")}
    documented = {p.stem for p in api.glob("*.html")}
    assert modules <= documented, f"modules without an API page: {sorted(modules - documented)}"
    assert "open_results" in (api / "spacarpy.results.reader.html").read_text()


def test_the_package_declares_its_type_hints():
    """PEP 561: the installed package carries ``py.typed`` so type checkers use its hints."""
    assert (ROOT / "spacarpy" / "py.typed").is_file()
