"""A job: one structural model and the analysis settings to run on it, side by side.

What a deck means as a whole (:func:`spacarpy.deck.load` returns one): the structure
(:class:`spacarpy.model.Model`) and what to compute on it
(:class:`spacarpy.settings.AnalysisSettings`). Neither holds the other, so one model can be
run with several settings and the solvers get the settings they need as arguments.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

from spacarpy.model import Model
from spacarpy.settings import AnalysisSettings

__all__ = ["Job"]


@dataclass(frozen=True, eq=False)
class Job:
    """``model`` (the structure) and ``settings`` (what to compute on it)."""

    model: Model
    settings: AnalysisSettings = field(default_factory=AnalysisSettings)

    def with_settings(self, settings: AnalysisSettings) -> Job:
        """The same model with other settings."""
        return replace(self, settings=settings)

    def __iter__(self):
        """``model, settings = job``."""
        return iter((self.model, self.settings))
