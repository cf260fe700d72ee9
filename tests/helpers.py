"""Helpers shared by the test modules (pytest puts tests/ on sys.path)."""
import pytest

from spacarpy.deck import model_from_text
from spacarpy.errors import DeckError


def deck_errors(text: str, name: str = "t.dat") -> list[tuple[int, str]]:
    """(line, message) of every problem building the deck text must report."""
    with pytest.raises(DeckError) as info:
        model_from_text(text, name)
    return [(loc.line, msg) for loc, msg, _ in info.value.items]
