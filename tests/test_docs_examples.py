"""Every example in docs/deck.md is executed.

Fenced blocks by info string:

- ``deck``: a complete deck; it must build into a model (written to deck.dat in a scratch
  directory, so INCLUDEs of earlier ``deck-file`` blocks work);
- ``deck-fragment``: must parse;
- ``deck-error``: must fail, with exactly the message of the ``text`` block that follows;
- ``deck-file NAME``: written to NAME for the blocks after it;
- ``python``: executed;
- ``console``: ``$ spacarpy ...`` lines are run, and their output must be the lines below.

Any other fenced block fails the test, so that no example goes unchecked.
"""
from __future__ import annotations

import contextlib
import io
import re
import shlex
from pathlib import Path

import pytest

from spacarpy.cli import main
from spacarpy.deck import load_deck, parse_deck
from spacarpy.errors import DeckError

DOC = Path(__file__).resolve().parents[1] / "docs" / "deck.md"
_FENCE = re.compile(r"^```([^\n`]*)\n(.*?)^```$", re.S | re.M)


def blocks() -> list[tuple[int, str, str]]:
    text = DOC.read_text()
    return [(text[:m.start()].count("\n") + 1, m.group(1).strip(), m.group(2))
            for m in _FENCE.finditer(text)]


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
