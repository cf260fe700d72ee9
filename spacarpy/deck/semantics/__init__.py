"""Deck semantics: the meaning of checked deck statements, one part per concern.

:func:`build_job` runs the parts in order (:mod:`.build`): :mod:`.topology` (nodes, elements,
geometry), :mod:`.element_data` (DYNE/RLSE, ESTIFF, EM, EDAMP, DAMPING), :mod:`.constraints`
(FIX, INPUTX/INPUTE/INPUTR), :mod:`.loads` (XF/DELXF, XM, GRAVITY) and :mod:`.settings`
(the analysis settings), all reporting to one collector (:mod:`.errors`).
"""
from spacarpy.deck.semantics.build import build_job, build_model

__all__ = ["build_job", "build_model"]
