"""Python API for scripted models: :class:`ModelBuilder`, one method per deck keyword.

For users who build their models in Python (parameter studies, optimisation loops) rather than
in a text deck. Every method appends the deck line it stands for; :meth:`ModelBuilder.build`
reads those lines with the deck parser and model builder, so a scripted model is validated
exactly like a deck and is identical to the model of the equivalent deck
(:meth:`ModelBuilder.to_deck` gives that deck). Error messages name the line of the Python
script that made the offending call and show the deck line it stands for::

    from spacarpy.deck import ModelBuilder

    R = 100.0
    mb = (ModelBuilder()
          .node(1, 0, 0, 0)
          .beam_arc(1, 1, 2, 3, 4, count=8, center=(0, 0, R), orientation=(0, 1, 0))
          .node(3, R * math.sin(math.pi / 4), 0, R * (1 - math.cos(math.pi / 4)))
          .flexible(range(1, 9))
          .fix(1).fix(2)
          .stiffness(range(1, 9), 1e7, 1e7 / 12, 1e7 / 12, 1e7 / 12)
          .load(3, 0, 600, 0)
          .iterstep(20, 10, 1e-9))
    model = mb.build()
"""
from __future__ import annotations

import dataclasses
import sys
from collections.abc import Iterable

from spacarpy.deck.parser import parse_deck
from spacarpy.deck.semantics import build_job
from spacarpy.deck.writer import format_value
from spacarpy.errors import DeckError, SourceLoc
from spacarpy.job import Job
from spacarpy.model import Model

__all__ = ["ModelBuilder"]

_DECK_NAME = "<ModelBuilder>"
_ALL_MODES = (1, 2, 3, 4, 5, 6)


def _caller() -> tuple[str, int]:
    """File and line of the first frame outside this module."""
    frame = sys._getframe(1)
    while frame is not None and frame.f_code.co_filename == __file__:
        frame = frame.f_back
    if frame is None:                  # pragma: no cover - always called from somewhere
        return "<python>", 1
    return frame.f_code.co_filename, frame.f_lineno


def _field(value) -> str:
    """A field as deck text; values a deck cannot hold come out as text the parser reports."""
    try:
        return format_value(value)
    except ValueError:
        return repr(value).replace(" ", "")


def _element_spec(elements) -> list[str]:
    """Deck text for an element selection: '7', '1:48', '1:2:47', or one entry per element."""
    if isinstance(elements, Iterable) and not isinstance(elements, (str, bytes)):
        items = list(elements)
    else:
        return [_field(elements)]
    if not items:
        return []
    if isinstance(elements, range) and len(elements) > 1 and elements.step > 0:
        step = "" if elements.step == 1 else f"{elements.step}:"
        return [f"{elements.start}:{step}{elements[-1]}"]
    return [_field(e) for e in items]


@dataclasses.dataclass
class _Line:
    text: str
    file: str
    line: int


class ModelBuilder:
    """Build a :class:`~spacarpy.model.Model` in Python, keyword by keyword.

    Every method returns the builder, so calls chain. Node, element, coordinate and mode
    numbers follow the deck conventions (docs/deck.md); units are SI.

    Parameters
    ----------
    title : str, optional
        A comment line at the top of :meth:`to_deck`.
    """

    def __init__(self, title: str | None = None):
        self.title = title
        self._head: list[_Line] = []
        self._kinematics: list[_Line] = []
        self._data: list[_Line] = []

    # ---------------------------------------------------------------- recording
    def _add(self, part: list, keyword: str, *fields, first: str | None = None) \
            -> ModelBuilder:
        words = [keyword] + ([first] if first is not None else []) + [_field(f) for f in fields]
        part.append(_Line(" ".join(words), *_caller()))
        return self

    def _per_elements(self, part: list, keyword: str, elements, *fields) -> ModelBuilder:
        for spec in _element_spec(elements):
            self._add(part, keyword, *fields, first=spec)
        return self

    # ---------------------------------------------------------------- kinematics
    def node(self, n: int, x: float, y: float, z: float) -> ModelBuilder:
        """``X n x y z``: a position node at (x, y, z) (m)."""
        return self._add(self._kinematics, "X", n, x, y, z)

    def beam(self, e: int, p: int, r: int, q: int, s: int, orientation=None) -> ModelBuilder:
        """``BEAM e p r q s [ox oy oz]``: a beam from position node p to q; r and s are the
        orientation nodes at p and q; ``orientation`` is the initial local y-axis."""
        return self._add(self._kinematics, "BEAM", e, p, r, q, s, *(orientation or ()))

    def beams(self, e: int, p: int, r: int, q: int, s: int, count: int,
              orientation=None) -> ModelBuilder:
        """``BEAMS``: the straight line p-q divided into ``count`` equal beams, elements
        e .. e+count-1, intermediate nodes numbered by the rule of docs/deck.md."""
        return self._add(self._kinematics, "BEAMS", e, p, r, q, s, count, *(orientation or ()))

    def beam_arc(self, e: int, p: int, r: int, q: int, s: int, count: int, center,
                 orientation=None, shape=None) -> ModelBuilder:
        """``BEAMARC``: ``count`` equal beams on the circular arc from p to q about
        ``center`` (the shorter arc); ``shape="curved"``: initially curved BEAMC elements
        (then ``orientation`` is required by the deck's positional fields: the arc's normal
        ``(q - c) x (p - c)``)."""
        return self._add(self._kinematics, "BEAMARC", e, p, r, q, s, count, *center,
                         *(orientation or ()), *((shape,) if shape else ()))

    def beam_c(self, e: int, p: int, r: int, q: int, s: int, center) -> ModelBuilder:
        """``BEAMC e p r q s cx cy cz``: an initially curved beam on the circular arc from p
        to q about ``center`` (docs/curved-beam.md)."""
        return self._add(self._kinematics, "BEAMC", e, p, r, q, s, *center)

    def flexible(self, elements, modes=_ALL_MODES) -> ModelBuilder:
        """``DYNE``: deformation modes (1..6) of the elements (a number, a range or a list)
        are flexible."""
        return self._per_elements(self._kinematics, "DYNE", elements, *modes)

    def released(self, elements, modes) -> ModelBuilder:
        """``RLSE``: deformation modes of the elements are released (free)."""
        return self._per_elements(self._kinematics, "RLSE", elements, *modes)

    def fix(self, node: int, *coords: int) -> ModelBuilder:
        """``FIX node [c ...]``: hold coordinates (all if none are given) of a node."""
        return self._add(self._kinematics, "FIX", node, *coords)

    # ---------------------------------------------------------------- data
    def stiffness(self, elements, EA: float, GJ: float, EIy: float, EIz: float,
                  cy: float = 0.0, cz: float = 0.0) -> ModelBuilder:
        """``ESTIFF``: stiffness of the elements (N, N m^2; shear flexibilities cy, cz in m^2)."""
        return self._per_elements(self._data, "ESTIFF", elements, EA, GJ, EIy, EIz, cy, cz)

    def mass(self, elements, rhoA: float, rhoIp: float = 0.0, rhoIy: float = 0.0,
             rhoIz: float = 0.0, rhoIyz: float = 0.0) -> ModelBuilder:
        """``EM``: mass per unit length (kg/m) and inertias per unit length (kg m)."""
        return self._per_elements(self._data, "EM", elements, rhoA, rhoIp, rhoIy, rhoIz, rhoIyz)

    def nodal_mass(self, node: int, *values: float) -> ModelBuilder:
        """``XM``: a point mass ``m`` on a position node or the inertia tensor
        ``Ixx Ixy Ixz Iyy Iyz Izz`` on an orientation node."""
        return self._add(self._data, "XM", node, *values)

    def load(self, node: int, f1: float, f2: float, f3: float, *,
             initial: bool = False) -> ModelBuilder:
        """``DELXF`` (default: applied over the load steps) or, with ``initial=True``, ``XF``
        (present from the start): a force (position node, N) or moment (orientation node,
        N m) in global axes."""
        return self._add(self._data, "XF" if initial else "DELXF", node, f1, f2, f3)

    def iterstep(self, max_iter: int = 10, n_steps: int = 1, tol: float = 5e-7, *,
                 n_init: int | None = None, extra=(1.0, 3.0)) -> ModelBuilder:
        """``ITERSTEP``: Newton iterations per step, load steps, tolerance; ``n_init``
        sub-steps for the initial load (then fields 4 and 5 are ``extra``)."""
        fields = [max_iter, n_steps, tol]
        if n_init is not None:
            fields += [*extra, n_init]
        return self._add(self._data, "ITERSTEP", *fields)

    def analysis(self, name) -> ModelBuilder:
        """``MODE``: static, eigen, buckling, transient, check or a SPACAR mode number."""
        return self._add(self._head, "MODE", name)

    def deformations(self, variant: str) -> ModelBuilder:
        """``DEFORMATIONS``: ``modified`` (default) or ``basic``."""
        return self._add(self._head, "DEFORMATIONS", variant)

    # ---------------------------------------------------------------- output
    def _lines(self) -> list[_Line]:
        file, line = _caller()
        structure = [_Line(t, file, line) for t in ("END", "HALT")]
        tail = [_Line(t, file, line) for t in ("END", "END")]
        title = [_Line(f"# {self.title}", file, line)] if self.title else []
        return title + self._head + self._kinematics + structure + self._data + tail

    def to_deck(self) -> str:
        """The deck these calls stand for (generator lines and element ranges kept)."""
        return "\n".join(ln.text for ln in self._lines()) + "\n"

    def build(self, *, deformations: str | None = None,
              analysis: str | None = None) -> Model:
        """Validate and build the model (the structure only; :meth:`build_job` also returns
        the analysis settings). Arguments as :meth:`build_job`."""
        return self.build_job(deformations=deformations, analysis=analysis).model

    def build_job(self, *, deformations: str | None = None,
                  analysis: str | None = None) -> Job:
        """Validate and build the model and the analysis settings.

        Parameters
        ----------
        deformations, analysis : str, optional
            Override :meth:`deformations` / :meth:`analysis` (like the command line).

        Returns
        -------
        Job
            The model (``source_text`` is :meth:`to_deck`; locations point at the script
            lines) and the settings of :meth:`iterstep`, :meth:`analysis`, ....

        Raises
        ------
        DeckError
            With every problem, located at the script line of the call that caused it.
        """
        lines = self._lines()
        text = "\n".join(ln.text for ln in lines) + "\n"
        where = {i + 1: (ln.file, ln.line) for i, ln in enumerate(lines)}

        def remap(loc):
            if not isinstance(loc, SourceLoc) or loc.file != _DECK_NAME:
                return loc
            file, line = where.get(loc.line, (loc.file, loc.line))
            return SourceLoc(file, line, loc.column)

        try:
            statements = parse_deck(text, _DECK_NAME)
            statements = [st.replace(loc=remap(st.loc),
                                     field_locs=tuple(remap(f) for f in st.field_locs))
                          for st in statements]
            job = build_job(statements, text=text, path=_caller()[0],
                            deformations=deformations, analysis=analysis)
        except DeckError as exc:
            raise DeckError([(remap(loc), msg, src) for loc, msg, src in exc.items]) from None
        return job

    def __repr__(self) -> str:
        n = len(self._head) + len(self._kinematics) + len(self._data)
        return f"ModelBuilder({n} deck lines)"

