"""Model -> deck text: the inverse of reading a deck.

:func:`model_to_deck` writes a :class:`spacarpy.model.Model` as a deck that reads back into an
equal model (every array and field, floats to the last bit: numbers are written with Python's
shortest round-trip representation). By default the deck uses only SPACAR keywords plus the two
spacarpy lines MODE and DEFORMATIONS; ``compact=True`` also writes element ranges
(``DYNE 1:48 1 2 3 4 5 6``), a spacarpy extension. :func:`format_record` writes one record.
"""
from __future__ import annotations

import math

import numpy as np

from spacarpy.elements.base import FLEXIBLE, RELEASED

__all__ = ["format_record", "format_value", "model_to_deck"]


def format_value(value) -> str:
    """One field as deck text: ints as digits, floats in shortest round-trip form.

    Raises
    ------
    ValueError
        For a float that is not finite (a deck cannot hold it).
    """
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"a deck field cannot be a boolean: {value!r}")
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if not math.isfinite(v):
            raise ValueError(f"a deck field must be a finite number, got {v!r}")
        return repr(v)
    return str(value)


def format_record(keyword: str, *fields) -> str:
    """``keyword`` and its fields as one deck line (no line end)."""
    return " ".join([keyword] + [format_value(f) for f in fields])


def _runs(ids: np.ndarray, lines: list[tuple]) -> list[tuple[int, int, tuple]]:
    """Group consecutive element numbers (first, last) that share the same data."""
    out: list = []
    for e, data in zip(ids.tolist(), lines):
        if out and out[-1][2] == data and out[-1][1] + 1 == e:
            out[-1] = (out[-1][0], e, data)
        else:
            out.append((e, e, data))
    return out


def _element_lines(keyword: str, ids: np.ndarray, data: list[tuple], compact: bool) -> list[str]:
    """One line per element, or with compact=True one line per run of equal data."""
    lines = []
    if compact:
        for first, last, values in _runs(ids, data):
            if values is None:
                continue
            head = str(first) if first == last else f"{first}:{last}"
            lines.append(" ".join([keyword, head] + [format_value(v) for v in values]))
        return lines
    for e, values in zip(ids.tolist(), data):
        if values is not None:
            lines.append(format_record(keyword, e, *values))
    return lines


def model_to_deck(model, *, cross_sections=None, compact: bool = False,
                  title: str | None = None) -> str:
    """Write a model as deck text that reads back into an equal model.

    Parameters
    ----------
    model : Model
    cross_sections : CrossSections, optional
        Written as a VISUALIZATION section (BEAMPROPS / CROSSTYPE / CROSSDIM).
    compact : bool
        Write element ranges (``ESTIFF 1:48 ...``), a spacarpy extension, instead of one
        line per element.
    title : str, optional
        A comment line at the top (default: where the model came from).

    Returns
    -------
    str
        The deck, ending with a newline.

    Notes
    -----
    The round trip is exact for models read from decks. A model built in Python with an
    ``IterStep`` whose ``extra`` is empty but ``n_init != 1`` cannot be written exactly (SPACAR's
    ITERSTEP needs fields 4 and 5 before n_init); fields 4 and 5 are then written as 0.
    """
    from spacarpy.model import ElementSet
    b = model.elements.get("BEAM") or ElementSet.empty("BEAM")
    out = [f"# {title if title is not None else 'spacarpy model from ' + model.source_path}",
           f"DEFORMATIONS {model.deformations}", f"MODE {model.analysis}", ""]
    out += [format_record("X", int(n), *x) for n, x in
            zip(model.position_ids.tolist(), model.position_x0.tolist())]
    for e, nodes, o in zip(b.ids.tolist(), b.nodes.tolist(), b.vector.tolist()):
        vector = () if any(math.isnan(v) for v in o) else tuple(o)
        out.append(format_record("BEAM", e, *nodes, *vector))
    for cls, keyword in ((FLEXIBLE, "DYNE"), (RELEASED, "RLSE")):
        data = [tuple(int(k) + 1 for k in np.flatnonzero(row == cls)) or None
                for row in b.def_class]
        out += _element_lines(keyword, b.ids, data, compact)
    position_nodes = set(model.position_ids.tolist())
    for fix in model.fixes:
        size = 3 if fix.node in position_nodes else 4
        coords = () if tuple(fix.coords) == tuple(range(1, size + 1)) else fix.coords
        out.append(format_record("FIX", fix.node, *coords))
    out += ["END", "HALT", ""]
    data = [tuple(float(v) for v in row) if has else None
            for row, has in zip(b.stiffness, b.has_stiffness)]
    out += _element_lines("ESTIFF", b.ids, data, compact)
    data = [tuple(float(v) for v in row) if np.any(row != 0) else None for row in b.mass]
    out += _element_lines("EM", b.ids, data, compact)
    for xm in model.nodal_masses:
        out.append(format_record("XM", xm.node, *[float(v) for v in xm.values]))
    for load in model.loads:
        out.append(format_record(load.kind, load.node, *[float(v) for v in load.value]))
    it = model.iterstep
    fields = [it.max_iter, it.n_steps, float(it.tol)]
    if it.extra or it.n_init != 1:
        extra = tuple(float(v) for v in it.extra) + (0.0,) * (2 - len(it.extra))
        fields += [*extra[:2], it.n_init]
    out.append(format_record("ITERSTEP", *fields))
    out += ["END", "END"]
    if cross_sections is not None and len(cross_sections):
        out += ["", "VISUALIZATION"]
        groups: dict = {}
        for e, cs in cross_sections.by_element.items():
            groups.setdefault((cs.shape, cs.dims), []).append(e)
        for (shape, dims), elements in groups.items():
            out.append(format_record("BEAMPROPS", *sorted(elements)))
            out.append(f"CROSSTYPE {shape}")
            out.append(format_record("CROSSDIM", *dims))
    return "\n".join(out) + "\n"
