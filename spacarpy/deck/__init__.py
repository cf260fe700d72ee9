"""Reading and writing SPACAR-style decks: text <-> statements <-> :class:`spacarpy.model.Model`.

- :func:`parse_deck` checks the syntax (Lark grammar + keyword table), evaluates SET parameters
  and ``{expressions}``, expands ranges and INCLUDEs, and returns :class:`Statement` records;
- :func:`build_model` expands the BEAMS/BEAMARC generators, gives the statements their meaning
  and validates the model;
- :func:`load_deck` does both for a file; :func:`check_deck` also summarises it
  (``spacarpy check``);
- :class:`ModelBuilder` builds the same models from Python; :func:`model_to_deck` writes a
  model back as a deck; :func:`cross_sections` reads the VISUALIZATION cross-sections.

Every problem is a :class:`spacarpy.errors.DeckError` with file:line:column. The keywords are
documented in docs/deck.md.
"""
from __future__ import annotations

from spacarpy.deck.api import ModelBuilder
from spacarpy.deck.build import build_model
from spacarpy.deck.check import DeckSummary, check_deck
from spacarpy.deck.keywords import KEYWORDS, UNSUPPORTED
from spacarpy.deck.parser import Statement, gc_paused, parse_deck, read_deck_text
from spacarpy.deck.visualization import CrossSection, CrossSections, cross_sections
from spacarpy.deck.writer import model_to_deck
from spacarpy.model import Model

__all__ = ["KEYWORDS", "UNSUPPORTED", "CrossSection", "CrossSections", "DeckSummary",
           "ModelBuilder", "Statement", "build_model", "check_deck", "cross_sections",
           "load_deck", "model_from_text", "model_to_deck", "parse_deck", "read_deck_text"]


def load_deck(path, *, deformations: str | None = None, analysis: str | None = None,
              overrides: dict | None = None) -> Model:
    """Read, parse and build a deck file.

    Parameters
    ----------
    path : str or path-like
    deformations, analysis : str, optional
        Override the deck's DEFORMATIONS / MODE lines (see :func:`build_model`).
    overrides : dict, optional
        ``--set name=value``: new values (numbers or expression text) for the deck's
        ``SET name`` lines. Naming a parameter the deck does not SET is an error.

    Returns
    -------
    Model

    Raises
    ------
    DeckError
        If the file cannot be read, or with every problem found in it.
    """
    return model_from_text(read_deck_text(path), str(path), deformations=deformations,
                           analysis=analysis, overrides=overrides)


def model_from_text(text: str, name: str = "<text>", *, deformations: str | None = None,
                    analysis: str | None = None, overrides: dict | None = None) -> Model:
    """Parse and build deck text held in memory (generated decks, tests); ``name`` stands
    for the file name in error messages. Options as in :func:`load_deck`."""
    # one pause of the garbage collector for both steps (see gc_paused), ending after the
    # statements are gone: the collection that follows has only the model to look at
    with gc_paused():
        return build_model(parse_deck(text, name, overrides=overrides), text=text, path=name,
                           deformations=deformations, analysis=analysis)
