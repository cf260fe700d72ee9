"""Reading and writing SPACAR-style decks: text <-> statements <-> :class:`spacarpy.job.Job`.

A deck means a structure (:class:`spacarpy.model.Model`) and the analysis settings to run on it
(:class:`spacarpy.settings.AnalysisSettings`); a :class:`~spacarpy.job.Job` holds both side
by side.

- :func:`parse_deck` checks the syntax (Lark grammar + keyword table), evaluates SET parameters
  and ``{expressions}``, expands ranges and INCLUDEs, and returns :class:`Statement` records;
- :func:`build_job` expands the BEAMS/BEAMARC generators, gives the statements their meaning
  and validates the model and the settings (:func:`build_model`: the model only);
- :func:`load` does both for a file and returns the job; :func:`load_deck` returns its model
  only, for scripts that want the structure; :func:`check_deck` also summarises a deck
  (``spacarpy check``);
- :class:`ModelBuilder` builds the same models from Python; :func:`model_to_deck` writes a
  model back as a deck; :func:`cross_sections` reads the VISUALIZATION cross-sections.

Every problem is a :class:`spacarpy.errors.DeckError` with file:line:column. The keywords are
documented in docs/deck.md.
"""
from __future__ import annotations

from spacarpy.deck.api import ModelBuilder
from spacarpy.deck.check import DeckSummary, check_deck
from spacarpy.deck.keywords import KEYWORDS, UNSUPPORTED
from spacarpy.deck.parser import gc_paused, parse_deck, parse_deck_tables
from spacarpy.deck.semantics import arrays as _arrays
from spacarpy.deck.semantics import build_job, build_model
from spacarpy.deck.semantics.build import build_job_parsed
from spacarpy.deck.statement import Statement
from spacarpy.deck.textfile import read_deck_text
from spacarpy.deck.visualization import CrossSection, CrossSections, cross_sections
from spacarpy.deck.writer import model_to_deck
from spacarpy.job import Job
from spacarpy.model import Model

__all__ = ["KEYWORDS", "UNSUPPORTED", "CrossSection", "CrossSections", "DeckSummary", "Job",
           "ModelBuilder", "Statement", "build_job", "build_model", "check_deck",
           "cross_sections", "job_from_text", "load", "load_deck", "model_from_text",
           "model_to_deck", "parse_deck", "read_deck_text"]


def load(path, *, deformations: str | None = None, analysis: str | None = None,
         overrides: dict | None = None) -> Job:
    """Read, parse and build a deck file: its model and its analysis settings.

    Parameters
    ----------
    path : str or path-like
    deformations, analysis : str, optional
        Override the deck's DEFORMATIONS / MODE lines (see :func:`build_job`).
    overrides : dict, optional
        ``--set name=value``: new values (numbers or expression text) for the deck's
        ``SET name`` lines. Naming a parameter the deck does not SET is an error.

    Returns
    -------
    Job
        ``job.model`` (the structure) and ``job.settings`` (what to compute).

    Raises
    ------
    DeckError
        If the file cannot be read, or with every problem found in it.
    """
    return job_from_text(read_deck_text(path), str(path), deformations=deformations,
                         analysis=analysis, overrides=overrides)


def load_deck(path, **kw) -> Model:
    """The model of a deck file: ``load(path, ...).model``, for scripts that want the
    structure only (the deck's analysis settings are checked, then dropped)."""
    return load(path, **kw).model


def job_from_text(text: str, name: str = "<text>", *, deformations: str | None = None,
                  analysis: str | None = None, overrides: dict | None = None) -> Job:
    """Parse and build deck text held in memory (generated decks, tests); ``name`` stands
    for the file name in error messages. Options as in :func:`load`."""
    # one pause of the garbage collector for both steps (see gc_paused), ending after the
    # statements are gone: the collection that follows has only the model to look at
    with gc_paused():
        if text.count("\n") >= _arrays.MIN_LINES:
            # the nodes, elements, DYNE and ESTIFF lines of a large deck as arrays (see
            # spacarpy.deck.semantics.arrays)
            parsed = parse_deck_tables(text, name, overrides=overrides,
                                       keywords=_arrays.TABLE_KEYWORDS)
            return build_job_parsed(parsed, text=text, path=name, deformations=deformations,
                                    analysis=analysis)
        return build_job(parse_deck(text, name, overrides=overrides), text=text, path=name,
                         deformations=deformations, analysis=analysis)


def model_from_text(text: str, name: str = "<text>", **kw) -> Model:
    """The model of deck text held in memory: ``job_from_text(text, name, ...).model``."""
    return job_from_text(text, name, **kw).model
