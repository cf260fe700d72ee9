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

from spacarpy.deck.api_keywords import KEYWORD_METHODS, check_field
from spacarpy.deck.keywords import KEYWORDS, VISUALIZATION_KEYWORDS
from spacarpy.deck.parser import parse_deck
from spacarpy.deck.semantics import build_job
from spacarpy.deck.writer import format_value
from spacarpy.errors import DeckError, SourceLoc
from spacarpy.job import Job
from spacarpy.model import Model

__all__ = ["ModelBuilder"]

_DECK_NAME = "<ModelBuilder>"
#: The modules whose frames are the builder's own (a location names the caller's line).
_INTERNAL = ("spacarpy.deck.api", "spacarpy.deck.api_keywords", "spacarpy.scripting")
_ALL_MODES = (1, 2, 3, 4, 5, 6)


def _caller() -> tuple[str, int]:
    """File and line of the first frame outside this module."""
    frame = sys._getframe(1)
    while frame is not None and frame.f_globals.get("__name__") in _INTERNAL:
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


def _element_list(elements) -> list:
    if isinstance(elements, Iterable) and not isinstance(elements, (str, bytes)):
        return list(elements)
    return [elements]


@dataclasses.dataclass
class _Line:
    text: str
    file: str
    line: int


class ModelBuilder:
    """Build a :class:`~spacarpy.model.Model` in Python, keyword by keyword.

    Every deck keyword has a method of its name in lower case (``x``, ``beam``, ``hinge``,
    ``rbeam``, ``plbeam``, ``pltruss``, ``plhinge``, ``truss``, ``pinbody``, ``wheel``,
    ``beamw``, ``beamc``, ``fix``, ``dyne``, ``rlse``, ``kine``, ``kinx``, ``dynx``,
    ``inputx``, ``inpute``, ``inputr``, ``estiff``, ``em``, ``edamp``, ``xm``, ``xf``,
    ``delxf``, ``xfl``, ``delxfl``, ``qe``, ``delqe``, ``qel``, ``delqel``, ``esig``,
    ``delinpx``, ``delinpe``, ``delinpr``, ``gravity``, ``timestep``, ``substeps``, ``error``,
    ``rhoinf``, ``damping``, ``velocity``, ``start``, ``startde``, ``timefunction``,
    ``loadtf``, ``iterstep``, ``arclength``, ``mode``, ``modes``, ``bifurcation``,
    ``deformations``, ``rotaryinertia``, ``set``, ``inputf``, ``inputs``, ``outx``, ``outxp``,
    ``oute``, ``outep``, ...: :data:`~spacarpy.deck.api_keywords.KEYWORD_METHODS`), made from
    the keyword table, so a deck reads as a script; :meth:`cross_section` gives the
    VISUALIZATION section's cross-sections. The older descriptive names stay (``node``,
    ``flexible``, ``released``, ``stiffness``, ``mass``, ``nodal_mass``, ``load``,
    ``analysis``, ``beam_arc``, ``beam_c``).

    Every method returns the builder, so calls chain. Node, element, coordinate and mode
    numbers follow the deck conventions (docs/deck.md); units are SI. A field may also be an
    ``"{expression}"`` string of :meth:`set` parameters, as in a deck.

    Parameters
    ----------
    title : str, optional
        A comment line at the top of :meth:`to_deck`.
    """

    def __init__(self, title: str | None = None):
        self.title = title
        self._parts: dict[str, list[_Line]] = {part: [] for part in _PARTS}

    # ---------------------------------------------------------------- recording
    @property
    def _head(self) -> list:
        return self._parts["head"]

    @property
    def _kinematics(self) -> list:
        return self._parts["kinematics"]

    @property
    def _data(self) -> list:
        return self._parts["data"]

    def _add(self, part: list, keyword: str, *fields, first: str | None = None) \
            -> ModelBuilder:
        words = [keyword] + ([first] if first is not None else []) + [_field(f) for f in fields]
        part.append(_Line(" ".join(words), *_caller()))
        return self

    def _emit(self, part: str, keyword: str, first, fields) -> ModelBuilder:
        """Record ``keyword [first] fields`` in ``part`` (one line per entry of an element
        selection ``first``)."""
        if first is None:
            return self._add(self._parts[part], keyword, *fields)
        for spec in _element_spec(first):
            self._add(self._parts[part], keyword, *fields, first=spec)
        return self

    def _refuse(self, message: str):
        """Raise a :class:`DeckError` located at the script line of the offending call."""
        file, line = _caller()
        raise DeckError([(SourceLoc(file, line), message, None)])

    # ---------------------------------------------------------------- descriptive names
    def node(self, n: int, x: float, y: float, z: float | None = None) -> ModelBuilder:
        """``X n x y [z]``: a position node at (x, y, z) (m); ``z`` may be left out in a
        planar model."""
        return self.x(n, x, y, z)

    def beam_arc(self, e: int, p: int, r: int, q: int, s: int, count: int, center,
                 orientation=None, shape=None) -> ModelBuilder:
        """``BEAMARC``: ``count`` equal beams on the circular arc from p to q about
        ``center`` (the shorter arc); ``shape="curved"``: initially curved BEAMC elements
        (then ``orientation`` is required by the deck's positional fields: the arc's normal
        ``(q - c) x (p - c)``)."""
        center = tuple(center) if isinstance(center, Iterable) else center
        if not isinstance(center, tuple) or len(center) != 3:
            return self._refuse(f"ModelBuilder.beam_arc(): center must be three numbers "
                                f"(cx, cy, cz), got {center!r}")
        return self.beamarc(e, p, r, q, s, count, *center, orientation=orientation,
                            shape=shape)

    def beam_c(self, e: int, p: int, r: int, q: int, s: int, center) -> ModelBuilder:
        """``BEAMC e p r q s cx cy cz``: an initially curved beam on the circular arc from p
        to q about ``center`` (docs/curved-beam.md)."""
        return self.beamc(e, p, r, q, s, center)

    def flexible(self, elements, modes=_ALL_MODES) -> ModelBuilder:
        """``DYNE``: deformation modes (1..6) of the elements (a number, a range or a list)
        are flexible."""
        return self.dyne(elements, *modes)

    def released(self, elements, modes) -> ModelBuilder:
        """``RLSE``: deformation modes of the elements are released (free)."""
        return self.rlse(elements, *modes)

    def stiffness(self, elements, EA: float, GJ: float | None = None,
                  EIy: float | None = None, EIz: float | None = None, cy: float = 0.0,
                  cz: float = 0.0, extra: float | None = None) -> ModelBuilder:
        """``ESTIFF``: stiffness of the elements (a BEAM: EA (N), GJ, EIy, EIz (N m^2), shear
        flexibilities cy, cz (m^2); a HINGE, TRUSS or PLBEAM: the fields their kind takes,
        see :meth:`estiff`, which writes exactly the fields given)."""
        if EIz is None:
            return self.estiff(elements, EA, GJ, EIy)
        return self.estiff(elements, EA, GJ, EIy, EIz, cy, cz, extra)

    def mass(self, elements, rhoA: float, rhoIp: float = 0.0, rhoIy: float = 0.0,
             rhoIz: float = 0.0, rhoIyz: float = 0.0) -> ModelBuilder:
        """``EM``: mass per unit length (kg/m) and inertias per unit length (kg m)."""
        return self.em(elements, rhoA, rhoIp, rhoIy, rhoIz, rhoIyz)

    def nodal_mass(self, node: int, *values: float) -> ModelBuilder:
        """``XM``: a point mass ``m`` on a position node or the inertia tensor
        ``Ixx Ixy Ixz Iyy Iyz Izz`` on an orientation node."""
        if len(values) not in (1, 6):
            return self._refuse(f"ModelBuilder.nodal_mass(): give a mass m (1 value) or the "
                                f"inertia tensor Ixx Ixy Ixz Iyy Iyz Izz (6 values), got "
                                f"{len(values)}")
        return self.xm(node, *values)

    def load(self, node: int, f1: float, f2: float | None = None, f3: float | None = None, *,
             initial: bool = False) -> ModelBuilder:
        """``DELXF`` (default: applied over the load steps) or, with ``initial=True``, ``XF``
        (present from the start): a force (position node, N) or moment (orientation node,
        N m) in global axes (a planar model: fx fy, or the moment m)."""
        return (self.xf if initial else self.delxf)(node, f1, f2, f3)

    def iterstep(self, max_iter: int = 10, n_steps: int = 1, tol: float = 5e-7, *,
                 n_init: int | None = None, extra=(1.0, 3.0)) -> ModelBuilder:
        """``ITERSTEP``: Newton iterations per step, load steps, tolerance; ``n_init``
        sub-steps for the initial load (then fields 4 and 5 are ``extra``)."""
        if n_init is None:
            return _ITERSTEP(self, max_iter, n_steps, tol)
        return _ITERSTEP(self, max_iter, n_steps, tol, *extra, n_init)

    def analysis(self, name) -> ModelBuilder:
        """``MODE``: static, eigen, buckling, transient, check or a SPACAR mode number."""
        return self.mode(name)

    def inputx(self, n: int, *coords: int, value=None, velocity=None,
               acceleration=None) -> ModelBuilder:
        """``INPUTX n c...`` (kinematics module): coordinates ``c`` of node ``n`` are
        prescribed. With ``value`` (one coordinate), also the data module's ``INPUTX n c
        value [velocity [acceleration]]``: its initial value and rates."""
        _INPUTX(self, n, *coords)
        if value is None:
            return self
        if len(coords) != 1:
            return self._refuse("ModelBuilder.inputx(): value needs exactly one coordinate "
                                f"c, got {len(coords)}")
        return self._data_form("INPUTX", "inputx", n, coords[0], value, velocity, acceleration)

    def inpute(self, e: int, *modes: int, value=None, velocity=None,
               acceleration=None) -> ModelBuilder:
        """``INPUTE e k...`` (kinematics module): deformation modes ``k`` of element ``e``
        are prescribed. With ``value`` (one mode), also the data module's ``INPUTE e k value
        [velocity [acceleration]]``."""
        _INPUTE(self, e, *modes)
        if value is None:
            return self
        if len(modes) != 1:
            return self._refuse("ModelBuilder.inpute(): value needs exactly one mode k, got "
                                f"{len(modes)}")
        return self._data_form("INPUTE", "inpute", e, modes[0], value, velocity, acceleration)

    def _data_form(self, keyword, method, n, c, *rates) -> ModelBuilder:
        spec = KEYWORDS[keyword].data_form
        given = list(rates)
        while given and given[-1] is None:
            given.pop()
        if None in given:
            return self._refuse(f"ModelBuilder.{method}(): acceleration needs velocity "
                                f"({spec.usage})")
        names = ("n", "c", "value", "velocity", "acceleration")
        try:
            fields = [check_field(method, nm, f, v)
                      for nm, f, v in zip(names, spec.fields, [n, c, *given])]
        except ValueError as exc:
            return self._refuse(str(exc))
        return self._add(self._data, keyword, *fields)

    def cross_section(self, elements, shape: str, w: float, t: float | None = None) \
            -> ModelBuilder:
        """The VISUALIZATION section's ``BEAMPROPS elements`` / ``CROSSTYPE shape`` /
        ``CROSSDIM w [t]``: the cross-section of the elements for stresses and drawings
        (``"RECT"``: width w and thickness t; ``"CIRC"``: diameter w; m)."""
        if str(shape).upper() not in ("RECT", "CIRC"):
            return self._refuse(f"ModelBuilder.cross_section(): shape must be RECT or CIRC, "
                                f"got {shape!r}")
        specs = VISUALIZATION_KEYWORDS
        try:
            for e in _element_list(elements):
                check_field("cross_section", "elements", specs["BEAMPROPS"].required[0], e)
            dims = [check_field("cross_section", "w", specs["CROSSDIM"].required[0], w)]
            if t is not None:
                dims.append(check_field("cross_section", "t", specs["CROSSDIM"].fields[1], t))
        except ValueError as exc:
            return self._refuse(str(exc))
        vis = self._parts["visualization"]
        self._add(vis, "BEAMPROPS", *_element_spec(elements))
        self._add(vis, "CROSSTYPE", str(shape).upper())
        return self._add(vis, "CROSSDIM", *dims)

    # ---------------------------------------------------------------- output
    def _lines(self) -> list[_Line]:
        file, line = _caller()

        def mark(*texts):
            return [_Line(t, file, line) for t in texts]

        parts = self._parts
        title = mark(f"# {self.title}") if self.title else []
        out = title + parts["head"] + parts["kinematics"] + mark("END", "HALT") + parts["data"]
        if parts["output"]:
            out += mark("END", "HALT") + parts["output"]
        out += mark("END", "END")
        if parts["visualization"]:
            out += mark("VISUALIZATION") + parts["visualization"]
        return out

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
        n = sum(len(lines) for lines in self._parts.values())
        return f"ModelBuilder({n} deck lines)"


_PARTS = ("head", "kinematics", "data", "output", "visualization")
_ITERSTEP = KEYWORD_METHODS["ITERSTEP"]
_INPUTX = KEYWORD_METHODS["INPUTX"]
_INPUTE = KEYWORD_METHODS["INPUTE"]

# the generated keyword methods: every one the class does not define by hand under that name
for _keyword, _method in KEYWORD_METHODS.items():
    if not hasattr(ModelBuilder, _method.__name__):
        setattr(ModelBuilder, _method.__name__, _method)
del _keyword, _method

