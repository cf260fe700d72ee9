"""Every example in docs/*.md is executed.

docs/deck.md runs block after block in one scratch directory (below). In every other page, each
``python`` block and each ``deck-fragment`` block is a test of its own; a python block runs in
a scratch directory holding the result files it names (``"bend.h5"``), made by running the
deck that page is about (``DOC_RESULTS``). A block that is deliberately not runnable carries a
``<!-- no-test: reason -->`` line right before its fence; those are counted.

Blocks of docs/deck.md,

Fenced blocks by info string:

- ``deck``: a complete deck; it must build into a model (written to deck.dat in a scratch
  directory, so INCLUDEs of earlier ``deck-file`` blocks work);
- ``deck-fragment``: must parse;
- ``deck-error``: must fail, with exactly the message of the ``text`` block that follows;
- ``deck-file NAME``: written to NAME for the blocks after it;
- ``python``: executed;
- ``console``: ``$ spacarpy ...`` lines are run, and their output must be the lines below.

Any other fenced block of docs/deck.md fails the test, so that no example goes unchecked.
"""
from __future__ import annotations

import contextlib
import io
import re
import shlex
import shutil
from pathlib import Path

import pytest

from spacarpy.cli import main
from spacarpy.deck import load_deck, parse_deck
from spacarpy.errors import DeckError

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
DOC = DOCS / "deck.md"
_FENCE = re.compile(r"^```([^\n`]*)\n(.*?)^```$", re.S | re.M)
_NO_TEST = re.compile(r"<!--\s*no-test:\s*(.*?)\s*-->\s*\Z")


def blocks(doc: Path = DOC) -> list[tuple[int, str, str]]:
    """(line, info string, body) of every fenced block of ``doc``."""
    text = doc.read_text()
    return [(text[:m.start()].count("\n") + 1, m.group(1).strip(), m.group(2))
            for m in _FENCE.finditer(text)]


def no_test_reason(doc: Path, line: int) -> str | None:
    """The reason of a ``<!-- no-test: reason -->`` line right before the fence at ``line``;
    None when there is none. An empty reason fails: a skipped example must say why."""
    lines = doc.read_text().splitlines()
    m = _NO_TEST.search(lines[line - 2]) if line >= 2 else None
    if m is None:
        return None
    assert m.group(1), f"{doc.name}:{line}: no-test needs a reason"
    return m.group(1)


def test_every_block_is_an_executable_kind():
    kinds = [info.split()[0] if info else "" for _, info, _ in blocks()]
    allowed = {"deck", "deck-fragment", "deck-error", "deck-file", "python", "console", "text"}
    assert set(kinds) <= allowed, sorted(set(kinds) - allowed)
    # a text block only shows the output of the deck-error before it
    for prev, kind in zip([""] + kinds, kinds):
        if kind == "text":
            assert prev == "deck-error"
    assert kinds.count("deck") >= 5 and kinds.count("deck-error") >= 3


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, blanks to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_internal_links_point_at_headings():
    text = _FENCE.sub("", DOC.read_text())
    anchors = {_slug(m.group(1)) for m in re.finditer(r"^#+ (.*)$", text, re.M)}
    links = set(re.findall(r"\]\(#([^)]+)\)", text))
    assert links and links <= anchors, sorted(links - anchors)


def test_docs_examples(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    items = blocks()
    ran = 0
    for i, (line, info, body) in enumerate(items):
        kind, *args = info.split()
        where = f"docs/deck.md:{line}"
        if no_test_reason(DOC, line) is not None:
            continue
        if kind == "deck-file":
            (tmp_path / args[0]).write_text(body)
        elif kind == "deck":
            Path("deck.dat").write_text(body)
            try:
                load_deck("deck.dat")
            except DeckError as exc:
                pytest.fail(f"{where}: the example deck does not build:\n{exc}")
        elif kind == "deck-fragment":
            try:
                parse_deck(body, where)
            except DeckError as exc:
                pytest.fail(f"{where}: the example fragment does not parse:\n{exc}")
        elif kind == "deck-error":
            Path("deck.dat").write_text(body)
            with pytest.raises(DeckError) as info_:
                load_deck("deck.dat")
            expected = items[i + 1][2]
            assert str(info_.value) + "\n" == expected, where
        elif kind == "python":
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                exec(compile(body, where, "exec"), {"__name__": "__doc_example__"})
        elif kind == "console":
            lines = body.splitlines()
            assert lines[0].startswith("$ spacarpy "), where
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                code = main(shlex.split(lines[0][len("$ spacarpy "):]))
            assert code == 0, where
            assert out.getvalue().splitlines() == lines[1:], where
        else:
            continue
        ran += 1
    assert ran >= 40


def test_every_keyword_is_documented():
    """Every keyword of the table has a heading (or, in the VISUALIZATION section, a row of
    the keyword table) in docs/deck.md, and the page's keyword index names it."""
    from spacarpy.deck.keywords import KEYWORDS, SECTIONS, VISUALIZATION_KEYWORDS

    text = DOC.read_text()
    headings = re.findall(r"^#{2,4} .*$", text, re.M)
    index = text[text.index("## Keyword index"):text.index("## Kinematics")]
    for name, spec in KEYWORDS.items():
        assert spec.section in SECTIONS
        assert f"`{name}" in index, f"{name} is missing from the keyword index"
        if name not in ("END", "HALT", "VISUALIZATION"):
            assert any(f"`{name} " in h or f"`{name}`" in h for h in headings), name
    for name, spec in VISUALIZATION_KEYWORDS.items():
        assert spec.section in SECTIONS
        assert f"| `{name}` |" in text, name


# --- every other page: python blocks and deck fragments -------------------------------------

RUN_KINDS = ("python", "deck-fragment")

# Result files the python examples name, and the runs that make them: (deck, deck edits,
# extra ``spacarpy run`` arguments). docs/results.md's listing reads every quantity of the
# Table 2 bend, so its run adds a mass (eigenfrequencies), a cross-section (stresses) and a
# compliance; docs/batch.md's sweep file comes from the column_sweep fixture.
DOC_RESULTS = {
    "bend.h5": ("table2_bend_8el_modified.dat",
                [("ITERSTEP", "EM 1:8 1 0.01 0.01 0.01\nITERSTEP")],
                "VISUALIZATION\nBEAMPROPS 1:8\nCROSSTYPE RECT\nCROSSDIM 1 1\n",
                ["--modes-per-step", "--compliance", "3", "4"]),
    "cantilever.h5": ("table1_cantilever_8el_modified.dat", [], "", []),
}
#: Result files the examples name that the shared ``result_files`` fixture (conftest.py) makes.
SHARED_RESULTS = {"frame.h5": "frame", "column.h5": "column", "pendulum.h5": "transient"}
SLOW_FILES = {"column_sweep.h5"}


def other_blocks() -> list[tuple[Path, int, str, str]]:
    """(page, line, kind, body) of the runnable blocks of every page but deck.md."""
    return [(doc, line, info.split()[0], body)
            for doc in sorted(DOCS.glob("*.md")) if doc != DOC
            for line, info, body in blocks(doc) if info and info.split()[0] in RUN_KINDS]


def _param(doc: Path, line: int, kind: str, body: str):
    names = set(re.findall(r"[\"']([\w.-]+\.h5)[\"']", body))
    marks = [pytest.mark.slow] if names & SLOW_FILES else []
    return pytest.param(doc, line, kind, body, marks=marks, id=f"{doc.name}:{line}")


@pytest.fixture(scope="session")
def doc_result_file(tmp_path_factory, request):
    """name -> path of a result file a documentation example reads, made on first request."""
    made: dict[str, Path] = {}
    tmp = tmp_path_factory.mktemp("doc-results")

    def get(name: str) -> Path:
        if name == "column_sweep.h5":
            return request.getfixturevalue("column_sweep")
        if name in SHARED_RESULTS:
            return request.getfixturevalue("result_files")[SHARED_RESULTS[name]]
        if name not in made:
            assert name in DOC_RESULTS, f"no run makes {name}: add it to DOC_RESULTS"
            deck, edits, appendix, extra = DOC_RESULTS[name]
            text = (REPO / "decks" / deck).read_text()
            for old, new in edits:
                text = text.replace(old, new)
            path = tmp / deck
            path.write_text(text + ("\n" + appendix if appendix else ""))
            assert main(["run", str(path), "-o", str(tmp / name), "-q", *extra]) == 0
            made[name] = tmp / name
        return made[name]
    return get


@pytest.mark.parametrize("doc, line, kind, body",
                         [_param(*b) for b in other_blocks()])
def test_other_pages_examples(doc, line, kind, body, doc_result_file, tmp_path, monkeypatch):
    where = f"docs/{doc.name}:{line}"
    reason = no_test_reason(doc, line)
    if reason is not None:
        pytest.skip(f"{where}: {reason}")
    if kind == "deck-fragment":
        try:
            parse_deck(body, where)
        except DeckError as exc:
            pytest.fail(f"{where}: the example fragment does not parse:\n{exc}")
        return
    written = set(re.findall(r"# writes: ([\w.-]+\.h5)", body))     # files the block makes
    for name in sorted(set(re.findall(r"[\"']([\w.-]+\.h5)[\"']", body)) - written):
        shutil.copy(doc_result_file(name), tmp_path / name)
    monkeypatch.chdir(tmp_path)
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(body, where, "exec"), {"__name__": "__doc_example__"})


# Deliberately not runnable python blocks (``<!-- no-test: reason -->``), all pages together.
# Changing this number is a deliberate act: say why in the markdown.
NO_TEST_PYTHON_BLOCKS = 0


def test_every_python_block_is_run_or_marked():
    pages = sorted(DOCS.glob("*.md"))
    python = [(doc, line) for doc in pages for line, info, _ in blocks(doc)
              if info.split()[:1] == ["python"]]
    marked = [(doc.name, line) for doc, line in python if no_test_reason(doc, line)]
    assert len(marked) == NO_TEST_PYTHON_BLOCKS, marked
    run_elsewhere = [b for b in other_blocks() if b[2] == "python"]
    in_deck_md = [b for b in python if b[0] == DOC]
    assert len(run_elsewhere) + len(in_deck_md) == len(python)
    assert len(python) >= 4
