"""Reading SPACAR-style decks: text -> statements -> :class:`spacarpy.model.Model`.

- :func:`parse_deck` checks the syntax (Lark grammar + keyword table) and returns
  :class:`Statement` records;
- :func:`build_model` gives them their meaning and validates the model;
- :func:`load_deck` does both for a file.

Every problem is a :class:`spacarpy.errors.DeckError` with file:line:column. The keywords are
documented in docs/deck.md.
"""
from __future__ import annotations

from pathlib import Path

from spacarpy.deck.build import build_model
from spacarpy.deck.keywords import KEYWORDS, UNSUPPORTED
from spacarpy.deck.parser import Statement, parse_deck
from spacarpy.errors import DeckError
from spacarpy.model import Model

__all__ = ["KEYWORDS", "UNSUPPORTED", "Statement", "build_model", "load_deck", "parse_deck",
           "read_deck_text"]


def read_deck_text(path) -> str:
    """Read a deck file as text: UTF-8 (a byte-order mark is dropped), else latin-1.

    Raises
    ------
    DeckError
        If the file cannot be read.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise DeckError((None, f"cannot read deck '{path}': no such file")) from None
    except IsADirectoryError:
        raise DeckError((None, f"cannot read deck '{path}': it is a directory")) from None
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise DeckError((None, f"cannot read deck '{path}': {reason}")) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    return text.removeprefix("\ufeff")


def load_deck(path, *, deformations: str | None = None, analysis: str | None = None) -> Model:
    """Read, parse and build a deck file.

    Parameters
    ----------
    path : str or path-like
    deformations, analysis : str, optional
        Override the deck's DEFORMATIONS / MODE lines (see :func:`build_model`).

    Returns
    -------
    Model

    Raises
    ------
    DeckError
        If the file cannot be read, or with every problem found in it.
    """
    text = read_deck_text(path)
    statements = parse_deck(text, str(path))
    return build_model(statements, text=text, path=str(path), deformations=deformations,
                       analysis=analysis)
