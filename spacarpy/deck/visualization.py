"""Cross-section data of the VISUALIZATION section: BEAMPROPS / CROSSTYPE / CROSSDIM per element.

SPAVISUAL (SPACAR's plotting tool) reads the VISUALIZATION section after the final END. Its
cross-section data are kept because they are useful for stresses and plots:

``BEAMPROPS e ...`` selects elements; the ``CROSSTYPE`` and ``CROSSDIM`` lines that follow apply
to them, until the next BEAMPROPS. ``CROSSTYPE RECT`` with ``CROSSDIM w t`` is a w x t rectangle,
w along the local y-axis and t along the local z-axis (so EIy = E w t^3 / 12, as SPACAR Light
writes it); ``CROSSTYPE CIRC`` with ``CROSSDIM d`` a solid circle of diameter d. Colours,
opacity and the other SPAVISUAL lines are checked by the parser and not kept.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from spacarpy.errors import DeckError, SourceLoc

__all__ = ["CROSS_TYPES", "CrossSection", "CrossSections", "collect_cross_sections",
           "cross_sections"]

logger = logging.getLogger(__name__)

#: Cross-section types and the CROSSDIM values each takes.
CROSS_TYPES = {"RECT": ("width w (along local y)", "thickness t (along local z)"),
               "CIRC": ("diameter d",)}


@dataclass(frozen=True)
class CrossSection:
    """The cross-section of one element.

    Attributes
    ----------
    shape : str
        ``"RECT"`` or ``"CIRC"``.
    dims : tuple of float
        RECT: ``(w, t)`` (m), w along the local y-axis, t along the local z-axis.
        CIRC: ``(d,)`` (m), the diameter.
    loc : SourceLoc or None
        The CROSSDIM line.
    """

    shape: str
    dims: tuple
    loc: SourceLoc | None = None

    @property
    def area(self) -> float:
        """Cross-section area (m^2)."""
        if self.shape == "RECT":
            return self.dims[0] * self.dims[1]
        return math.pi * self.dims[0] ** 2 / 4

    @property
    def second_moments(self) -> tuple[float, float]:
        """``(Iy, Iz)`` (m^4): second moments about the local y- and z-axes."""
        if self.shape == "RECT":
            w, t = self.dims
            return w * t**3 / 12, t * w**3 / 12
        i = math.pi * self.dims[0] ** 4 / 64
        return i, i

    @property
    def extreme_fibre(self) -> tuple[float, float]:
        """``(y_max, z_max)`` (m): largest distances from the centroid along local y and z,
        for the bending stresses ``M z_max / Iy`` and ``M y_max / Iz``."""
        if self.shape == "RECT":
            return self.dims[0] / 2, self.dims[1] / 2
        return self.dims[0] / 2, self.dims[0] / 2


@dataclass
class CrossSections:
    """Cross-sections by element number (elements without one are absent)."""

    by_element: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.by_element)

    def __contains__(self, element: int) -> bool:
        return element in self.by_element

    def get(self, element: int) -> CrossSection | None:
        return self.by_element.get(element)

    def arrays(self, element_ids) -> tuple[np.ndarray, np.ndarray]:
        """Cross-section data aligned with ``element_ids`` (e.g. ``model.elements["BEAM"].ids``).

        Returns
        -------
        shape : (n_elem,) str
            ``"RECT"``, ``"CIRC"`` or ``""`` (none given).
        dims : (n_elem, 2) float
            RECT ``(w, t)``, CIRC ``(d, NaN)``, NaN where none is given.
        """
        ids = np.asarray(element_ids, dtype=np.int64).reshape(-1)
        shape = np.full(ids.size, "", dtype="<U4")
        dims = np.full((ids.size, 2), np.nan)
        for i, e in enumerate(ids):
            cs = self.by_element.get(int(e))
            if cs is not None:
                shape[i] = cs.shape
                dims[i, :len(cs.dims)] = cs.dims
        return shape, dims


def collect_cross_sections(statements):
    """Read the cross-section data of the VISUALIZATION section.

    Parameters
    ----------
    statements : list of Statement
        From :func:`spacarpy.deck.parse_deck` (only the VISUALIZATION statements are used).

    Returns
    -------
    sections : CrossSections
    errors : list of (SourceLoc, str, str)
        An unknown CROSSTYPE, a wrong number of CROSSDIM values, a dimension that is not
        positive, CROSSDIM without CROSSTYPE.
    warnings : list of str
        CROSSTYPE/CROSSDIM that apply to no element (no BEAMPROPS before them), an element
        given a cross-section twice (the later one counts).
    """
    out: dict = {}
    errors: list = []
    warnings: list = []
    group: tuple | None = None          # elements of the last BEAMPROPS
    shape: str | None = None
    for st in statements:
        if st.module >= 0:
            continue
        kw = st.keyword
        if kw == "BEAMPROPS":
            group, shape = tuple(st.fields), None
        elif kw == "CROSSTYPE":
            value = str(st.fields[0]).upper()
            if value not in CROSS_TYPES:
                errors.append((st.field_locs[0], f"CROSSTYPE: unknown cross-section type "
                                                 f"'{st.fields[0]}'; expected RECT or CIRC",
                               st.source_line))
                shape = None
                continue
            shape = value
            if group is None:
                warnings.append(f"{st.loc}: CROSSTYPE applies to no element: no BEAMPROPS "
                                "line comes before it")
        elif kw == "CROSSDIM":
            if shape is None:
                if not any(loc == st.loc for loc, _, _ in errors):
                    errors.append((st.loc, "CROSSDIM without a CROSSTYPE before it (after "
                                           "BEAMPROPS, give CROSSTYPE RECT or CIRC first)",
                                   st.source_line))
                continue
            names = CROSS_TYPES[shape]
            dims = tuple(float(v) for v in st.fields)
            if len(dims) != len(names):
                errors.append((st.loc, f"CROSSDIM: a {shape} cross-section takes "
                                       f"{len(names)} value{'s' if len(names) > 1 else ''} "
                                       f"({', '.join(names)}), got {len(dims)}", st.source_line))
                continue
            bad = [i for i, v in enumerate(dims) if not v > 0]
            if bad:
                i = bad[0]
                errors.append((st.field_locs[i], f"CROSSDIM: the {names[i]} must be positive, "
                                                 f"got {dims[i]:g}", st.source_line))
                continue
            if group is None:
                continue
            for e in group:
                if e in out:
                    warnings.append(f"{st.loc}: element {e} already has a cross-section (line "
                                    f"{out[e].loc.line}); the later one counts")
                out[e] = CrossSection(shape=shape, dims=dims, loc=st.loc)
    return CrossSections(out), errors, warnings


def cross_sections(statements) -> CrossSections:
    """The cross-sections of a parsed deck, by element number.

    Parameters
    ----------
    statements : list of Statement

    Returns
    -------
    CrossSections

    Raises
    ------
    DeckError
        If the cross-section data are inconsistent (see :func:`collect_cross_sections`).
    """
    sections, errors, warnings = collect_cross_sections(statements)
    for msg in warnings:
        logger.warning(msg)
    if errors:
        raise DeckError(errors)
    return sections
