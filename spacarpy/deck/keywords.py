"""The table of SPACAR deck keywords: which fields each record takes, in which order.

This module is data only. :mod:`spacarpy.deck.parser` checks every record of a deck against
:data:`KEYWORDS` (field count and field types, with the user-facing field names used in error
messages); :mod:`spacarpy.deck.build` gives the records their meaning. A keyword marked
``supported=False`` is recognised and parsed leniently (any number of fields) so that every
real SPACAR deck parses, but :func:`spacarpy.deck.build_model` refuses it with
"not supported yet: KEYWORD".
"""
from __future__ import annotations

from dataclasses import dataclass

#: Field kinds: "int" (a whole number; ``5.000000`` is accepted as 5), "float" (any number),
#: "word" (a bare word or a quoted string), "value" (a number or a word, kept as written).
FIELD_KINDS = ("int", "float", "word", "value")

#: How each field kind is described in error messages.
KIND_DESCRIPTIONS = {
    "int": "a whole number",
    "float": "a number",
    "word": "a word",
    "value": "a number or a word",
}


@dataclass(frozen=True)
class FieldSpec:
    """One field of a keyword record.

    Attributes
    ----------
    name : str
        User-facing name, used in messages as "expected the {name} ({kind description})".
    short : str
        Short name for the usage line (``BEAM e p r q s [ox oy oz]``).
    kind : str
        One of :data:`FIELD_KINDS`.
    positive : bool
        The value must be >= 1 (node and element numbers).
    """

    name: str
    short: str
    kind: str = "float"
    positive: bool = False


@dataclass(frozen=True)
class KeywordSpec:
    """The field layout of one keyword.

    A record is ``KEYWORD required... [group1...] [group2...] ... [variadic...]``: the required
    fields, then zero or more of the optional groups in order (a group is all-or-nothing), then,
    only if every optional group is present, any number of variadic fields.

    Attributes
    ----------
    name : str
        The keyword in upper case.
    summary : str
        One line: what the keyword does.
    required : tuple of FieldSpec
    optional : tuple of tuple of FieldSpec
    variadic : FieldSpec or None
    supported : bool
        False: recognised, parsed leniently, refused by the model builder.
    node_slots : int
        For unsupported element keywords: how many fields after the element number are node
        numbers (lets the builder recognise those nodes and elements without reporting them
        as undefined).
    """

    name: str
    summary: str
    required: tuple = ()
    optional: tuple = ()
    variadic: FieldSpec | None = None
    supported: bool = True
    node_slots: int = 0

    @property
    def counts(self) -> tuple[int, ...]:
        """The allowed field counts without a variadic tail, ascending."""
        n = len(self.required)
        out = [n]
        for group in self.optional:
            n += len(group)
            out.append(n)
        return tuple(out)

    @property
    def usage(self) -> str:
        """A usage line such as ``BEAM e p r q s [ox oy oz]``."""
        parts = [self.name] + [f.short for f in self.required]
        parts += ["[" + " ".join(f.short for f in group) + "]" for group in self.optional]
        if self.variadic is not None:
            parts.append(f"[{self.variadic.short}...]")
        return " ".join(parts)


def _f(name, short, kind="float", positive=False) -> FieldSpec:
    return FieldSpec(name=name, short=short, kind=kind, positive=positive)


ELEMENT = _f("element number", "e", "int", positive=True)
NODE = _f("node number", "n", "int", positive=True)
_ANY = _f("value", "value", "value")


def _lenient(name: str, summary: str, node_slots: int = 0) -> KeywordSpec:
    return KeywordSpec(name=name, summary=summary, variadic=_ANY, supported=False,
                       node_slots=node_slots)


def _each_optional(*fields: FieldSpec) -> tuple:
    return tuple((f,) for f in fields)


_LOAD_FIELDS = (NODE, _f("x component (N or N m)", "f1"), _f("y component (N or N m)", "f2"),
                _f("z component (N or N m)", "f3"))

_SUPPORTED = (
    KeywordSpec(
        "X", "initial position of a position node",
        required=(NODE, _f("x coordinate (m)", "x"), _f("y coordinate (m)", "y"),
                  _f("z coordinate (m)", "z"))),
    KeywordSpec(
        "BEAM", "spatial beam element between two position nodes",
        required=(ELEMENT, _f("position node p", "p", "int", True),
                  _f("orientation node at p", "r", "int", True),
                  _f("position node q", "q", "int", True),
                  _f("orientation node at q", "s", "int", True)),
        optional=((_f("x component of the initial local y-axis", "ox"),
                   _f("y component of the initial local y-axis", "oy"),
                   _f("z component of the initial local y-axis", "oz")),)),
    KeywordSpec(
        "FIX", "hold nodal coordinates at their initial value",
        required=(NODE,), variadic=_f("coordinate number", "c", "int")),
    KeywordSpec(
        "DYNE", "deformation modes that are flexible (carry stiffness)",
        required=(ELEMENT,), variadic=_f("deformation mode number", "k", "int")),
    KeywordSpec(
        "RLSE", "deformation modes that are released (free)",
        required=(ELEMENT,), variadic=_f("deformation mode number", "k", "int")),
    KeywordSpec("END", "closes a module"),
    KeywordSpec("HALT", "separates modules (after END)"),
    # ESTIFF/EM: values optional at the parse level because a HINGE takes 1 value or none;
    # the model builder requires at least EA GJ EIy EIz (ESTIFF) / rhoA (EM) for a BEAM.
    KeywordSpec(
        "ESTIFF", "element stiffness",
        required=(ELEMENT,),
        optional=_each_optional(
            _f("axial stiffness EA (N)", "EA"), _f("torsional stiffness GJ (N m^2)", "GJ"),
            _f("bending stiffness EIy (N m^2)", "EIy"), _f("bending stiffness EIz (N m^2)", "EIz"),
            _f("shear flexibility cy (m^2)", "cy"), _f("shear flexibility cz (m^2)", "cz"),
            _f("seventh stiffness value (ignored for BEAM)", "extra"))),
    KeywordSpec(
        "EM", "element mass per unit length",
        required=(ELEMENT,),
        optional=_each_optional(
            _f("mass per unit length rhoA (kg/m)", "rhoA"),
            _f("polar inertia per unit length rho(Iy+Iz) (kg m)", "rhoIp"),
            _f("inertia per unit length rhoIy (kg m)", "rhoIy"),
            _f("inertia per unit length rhoIz (kg m)", "rhoIz"),
            _f("product of inertia per unit length rhoIyz (kg m)", "rhoIyz"),
            _f("sixth mass value (ignored for BEAM)", "extra"))),
    KeywordSpec("XF", "dead nodal load present from the start", required=_LOAD_FIELDS),
    KeywordSpec("DELXF", "dead nodal load increment applied over the load steps",
                required=_LOAD_FIELDS),
    KeywordSpec(
        "ITERSTEP", "load stepping and Newton iteration settings",
        required=(_f("maximum number of iterations", "max_iter", "int"),
                  _f("number of load steps", "n_steps", "int")),
        optional=_each_optional(
            _f("convergence tolerance", "tol"), _f("fourth ITERSTEP value", "f4"),
            _f("fifth ITERSTEP value", "f5"),
            _f("number of initial-load steps", "n_init", "int"))),
    KeywordSpec("MODE", "analysis to run (spacarpy extension)",
                required=(_f("analysis name or SPACAR mode number", "analysis", "value"),)),
    KeywordSpec("DEFORMATIONS", "beam deformation definitions (spacarpy extension)",
                required=(_f("deformation variant (basic or modified)", "variant", "word"),)),
    KeywordSpec("VISUALIZATION", "starts the SPAVISUAL section (ignored)"),
)

_UNSUPPORTED = (
    _lenient("BEAMW", "beam with warping nodes", node_slots=6),
    _lenient("RBEAM", "rigid beam", node_slots=3),
    _lenient("TRUSS", "truss element", node_slots=2),
    _lenient("HINGE", "hinge between two orientation nodes", node_slots=2),
    _lenient("PLBEAM", "planar beam", node_slots=4),
    _lenient("PLTRUSS", "planar truss", node_slots=2),
    _lenient("PLHINGE", "planar hinge", node_slots=2),
    _lenient("INPUTX", "prescribed nodal coordinates"),
    _lenient("DYNX", "dynamic nodal coordinates"),
    _lenient("XM", "nodal mass or inertia"),
    _lenient("DELINPX", "increment of a prescribed coordinate"),
    _lenient("GRAVITY", "gravity acceleration"),
    _lenient("TIMESTEP", "time integration end time and steps"),
    _lenient("ERROR", "time integration error tolerances"),
    _lenient("ESIG", "element stress resultant input"),
    _lenient("OUTLEVEL", "SPACAR output level"),
    _lenient("USERSIG", "user load function"),
    _lenient("USERINP", "user motion function"),
    _lenient("INPUTF", "linearized-system input"),
    _lenient("OUTX", "linearized-system position output"),
    _lenient("OUTXP", "linearized-system velocity output"),
)

#: Every keyword spacarpy recognises before the VISUALIZATION section, by upper-case name.
KEYWORDS: dict[str, KeywordSpec] = {k.name: k for k in _SUPPORTED + _UNSUPPORTED}

#: Keywords that are recognised but refused by the model builder.
UNSUPPORTED = tuple(k.name for k in _UNSUPPORTED)

#: Unsupported keywords that define elements (their first field is an element number).
UNSUPPORTED_ELEMENTS = tuple(k.name for k in _UNSUPPORTED if k.node_slots)

#: Keywords of SPAVISUAL's VISUALIZATION section (only valid after VISUALIZATION).
VISUALIZATION_KEYWORDS = ("INITIAL", "COLOR", "BEAMPROPS", "CROSSTYPE", "CROSSDIM", "GRAPHICS",
                          "FACECOLOR", "OPACITY", "DONOTDRAW", "MODESHAPE", "MAXIMUM")
