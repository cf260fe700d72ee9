"""The table of deck keywords: which fields each record takes, in which order, with which names.

This module is data only. :mod:`spacarpy.deck.parser` checks every record of a deck against
:data:`KEYWORDS` (field count and field types, with the user-facing field names used in error
messages) and :data:`VISUALIZATION_KEYWORDS`; :mod:`spacarpy.deck.semantics` gives the records
their meaning. Every SPACAR keyword has its real field layout here, also the ones spacarpy cannot
analyse yet (``supported=False``): those are parsed and checked like the others, so that
field-count errors are meaningful and the typed values are kept, and the model builder refuses
them with "SPACAR keyword KEYWORD is not supported yet" (:func:`unsupported_message`). Real
SPACAR keywords whose layouts are not publicly known (TUBE, SCREW, ENHC) take any
fields and are refused the same way, never as "unknown keyword". The layouts come from
../shared/spacar/README.md and the decks of SPACAR's front ends; docs/deck.md documents them.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from spacarpy.elements.registry import KINDS

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

#: Keyword groups, in the order docs/deck.md presents them.
SECTIONS = ("structure", "kinematics", "element", "data", "output", "extension", "visualization")


@dataclass(frozen=True)
class FieldSpec:
    """One field of a keyword record.

    ``short`` is also the field's name for named access
    (:meth:`spacarpy.deck.statement.Statement.value`). The choices and ranges are checked by
    the deck semantics, each with its own message.

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
    choices : tuple of str or None
        The words a "word" field accepts (compared in lower case).
    min : float or None
        The lower end of a number field's range, inclusive (None: unbounded).
    max : float or None
        The upper end of a number field's range, inclusive (None: unbounded).
    """

    name: str
    short: str
    kind: str = "float"
    positive: bool = False
    choices: tuple | None = None
    min: float | None = None
    max: float | None = None

    def accepts(self, value) -> bool:
        """Whether ``value`` is among the choices and in the range."""
        if self.choices is not None:
            return str(value).lower() in self.choices
        return ((self.min is None or value >= self.min)
                and (self.max is None or value <= self.max))

    @property
    def range_text(self) -> str:
        """The range as ``[0, 1]``, ``>= 0``."""
        if self.min is not None and self.max is not None:
            return f"[{self.min:g}, {self.max:g}]"
        return f">= {self.min:g}" if self.min is not None else f"<= {self.max:g}"


@dataclass(frozen=True)
class KeywordSpec:
    """The field layout of one keyword.

    A record is ``KEYWORD required... [group1...] [group2...] ... [variadic...]``: the required
    fields, then zero or more of the optional groups in order (a group is all-or-nothing), then,
    only if every optional group is present, any number of variadic fields. Variadic whole-number
    fields accept ranges (``1:6``), which stand for all the numbers of the range.

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
        False: recognised and checked, but refused by the model builder ("not supported yet").
    section : str
        One of :data:`SECTIONS`.
    extension : bool
        A spacarpy extension (not read by SPACAR).
    node_roles : str
        For element keywords: the role of each node field after the element number, one
        letter per field: ``p`` position node, ``r`` orientation node, ``w`` warping node.
    range_first : bool
        The first field (an element number) may be a range such as ``1:48``; the record then
        stands for one record per number.
    data_form : KeywordSpec or None
        A different layout used after the first END (``INPUTX n c`` declares a prescribed
        coordinate in the kinematics module, ``INPUTX n c value`` gives its value later).
    """

    name: str
    summary: str
    required: tuple = ()
    optional: tuple = ()
    variadic: FieldSpec | None = None
    supported: bool = True
    section: str = "kinematics"
    extension: bool = False
    node_roles: str = ""
    range_first: bool = False
    data_form: KeywordSpec | None = None

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
        usage = " ".join(parts)
        if self.data_form is not None:
            usage += f"  (after the first END: {self.data_form.usage})"
        return usage

    @property
    def fields(self) -> tuple:
        """The fixed fields in order: required, then the optional groups."""
        return tuple(self.required) + tuple(f for group in self.optional for f in group)

    def field(self, name: str) -> tuple[int, FieldSpec]:
        """The index and spec of the field called ``name`` (its ``short``); a variadic field
        gives the index of its first value.

        Raises
        ------
        KeyError
        """
        for i, f in enumerate(self.fields):
            if f.short == name:
                return i, f
        if self.variadic is not None and self.variadic.short == name:
            return len(self.fields), self.variadic
        raise KeyError(f"{self.name} has no field {name!r}")

    @property
    def is_element(self) -> bool:
        """Whether the keyword defines an element (its first field is an element number)."""
        return bool(self.node_roles)


def _f(name, short, kind="float", positive=False, **checks) -> FieldSpec:
    return FieldSpec(name=name, short=short, kind=kind, positive=positive, **checks)


def _each_optional(*fields: FieldSpec) -> tuple:
    return tuple((f,) for f in fields)


ELEMENT = _f("element number", "e", "int", positive=True)
NODE = _f("node number", "n", "int", positive=True)
_POS_P = _f("position node p", "p", "int", True)
_POS_Q = _f("position node q", "q", "int", True)
_ROT_P = _f("orientation node at p", "r", "int", True)
_ROT_Q = _f("orientation node at q", "s", "int", True)
_COORD = _f("coordinate number", "c", "int")
_MODE = _f("deformation mode number", "k", "int")
_ORIENTATION = (_f("x component of the initial local y-axis", "ox"),
                _f("y component of the initial local y-axis", "oy"),
                _f("z component of the initial local y-axis", "oz"))
# three components; a planar model gives fx fy (position node) or the moment m (orientation
# node): the builder checks the count
_LOAD_FIELDS = (NODE, _f("x component (N or N m)", "f1"))
# XFL/DELXFL: the loaded node, the orientation node whose current axes the components are in
_FOLLOWER_FIELDS = (NODE, _f("orientation node of the load's axes", "r", "int", positive=True),
                    _f("component along the first axis (N or N m)", "f1"))
# QEL/DELQEL e q1 q2 q3 [q1 q2 q3 at q]: a follower line load (N/m) in a beam's current
# axes (a planar deck: e qx qy [qx qy at q]); the builder checks the count
_FOLLOWER_LINE_FIELDS = (ELEMENT, _f("component along the element at p (N/m)", "q1"))
_FOLLOWER_LINE_OPTIONAL = _each_optional(
    _f("component along its local y-axis at p (N/m)", "q2"),
    _f("component along its local z-axis at p (N/m)", "q3"),
    _f("component along the element at q (N/m)", "q4"),
    _f("component along its local y-axis at q (N/m)", "q5"),
    _f("component along its local z-axis at q (N/m)", "q6"))
_FOLLOWER_OPTIONAL = _each_optional(_f("component along the second axis (N or N m)", "f2"),
                                    _f("component along the third axis (N or N m)", "f3"))
_LOAD_OPTIONAL = _each_optional(_f("y component (N or N m)", "f2"),
                                _f("z component (N or N m)", "f3"))
# QE/DELQE e q1 q2 q3 [q1 q2 q3 at the end q]: force per length at the element's end p
# (and at its end q: a linear variation); a planar deck gives qx qy [qx qy]
_LINE_LOAD_FIELDS = (ELEMENT, _f("x component of the line load at p (N/m)", "q1"))
_LINE_LOAD_OPTIONAL = _each_optional(
    _f("y component of the line load at p (N/m)", "q2"),
    _f("z component of the line load at p (N/m)", "q3"),
    _f("x component of the line load at q (N/m)", "q4"),
    _f("y component of the line load at q (N/m)", "q5"),
    _f("z component of the line load at q (N/m)", "q6"))
_COUNT = _f("number of elements", "count", "int", positive=True)
_IO_FIELDS = (_f("input/output index", "i", "int", True), NODE, _COORD)
_IO_ELEMENT_FIELDS = (_f("output index", "i", "int", True), ELEMENT, _MODE)


def _unsupported(name, summary, section, **kw) -> KeywordSpec:
    return KeywordSpec(name=name, summary=summary, supported=False, section=section, **kw)


#: Real SPACAR keywords spacarpy does not implement and whose field layout is not publicly
#: documented: (name, summary, section). Their lines take any fields and are refused with
#: :func:`unsupported_message`; the first field of an element keyword is taken as the element
#: number and its other whole numbers as nodes (so that DYNE/FIX lines about them do not add
#: "not defined" errors to the refusal).
_SPACAR_ONLY = (
    ("TUBE", "SPACAR tube element (element type 16)", "element"),
    ("SCREW", "SPACAR screw element (element type 17)", "element"),
    ("ENHC", "SPACAR ENHC line (layout not publicly documented)", "kinematics"),
)

def unsupported_message(keyword: str) -> str:
    """The one message of a real SPACAR keyword that spacarpy does not implement:
    ``SPACAR keyword X is not supported yet``."""
    return f"SPACAR keyword {keyword} is not supported yet"


#: Matches :func:`unsupported_message`; group 1 is the keyword.
UNSUPPORTED_PATTERN = re.compile(r"SPACAR keyword (\S+) is not supported yet")


def _spacar_only(name, summary, section) -> KeywordSpec:
    return _unsupported(name, summary, section,
                        variadic=_f("field of a SPACAR line spacarpy does not read", "v",
                                    "value"))


#: The node role letter of each slot type (position, orientation, warping node).
_ROLE_OF_SLOT = {"pos": "p", "rot": "r", "warp": "w"}


def element_keyword(kind) -> KeywordSpec:
    """The deck keyword of an element kind, from what the kind declares (its node fields and
    the optional trailing vector): ``KEYWORD e nodes... [v1 v2 v3]`` (``v1 v2 v3`` required
    where the kind says so, the WHEEL's axle)."""
    nodes = tuple(_f(name, short, "int", True) for name, short in kind.node_fields)
    vector = tuple(_f(name, short) for name, short in kind.vector_fields)
    if kind.vector_required:
        return KeywordSpec(kind.keyword, kind.summary, section="element",
                           required=(ELEMENT, *nodes, *vector),
                           node_roles="".join(_ROLE_OF_SLOT[s] for s in kind.slots))
    return KeywordSpec(kind.keyword, kind.summary, section="element",
                       required=(ELEMENT, *nodes), optional=(vector,) if vector else (),
                       node_roles="".join(_ROLE_OF_SLOT[s] for s in kind.slots))


_KEYWORD_LIST = (
    # ------------------------------------------------------------------ structure
    KeywordSpec("END", "closes a module; END END closes the deck", section="structure"),
    KeywordSpec("HALT", "starts the next module (directly after an END)", section="structure"),
    KeywordSpec("VISUALIZATION", "starts the SPAVISUAL section after the final END",
                section="structure"),
    # ------------------------------------------------------------------ kinematics
    # z may be left out in a planar model (PLBEAM/PLTRUSS/PLHINGE); the builder checks it
    KeywordSpec("X", "initial position of a position node",
                required=(NODE, _f("x coordinate (m)", "x"), _f("y coordinate (m)", "y")),
                optional=((_f("z coordinate (m)", "z"),),)),
    KeywordSpec("FIX", "hold nodal coordinates at their initial value",
                required=(NODE,), variadic=_COORD),
    KeywordSpec("DYNE", "deformation modes that are flexible (carry stiffness)",
                required=(ELEMENT,), variadic=_MODE, range_first=True),
    KeywordSpec("RLSE", "deformation modes that are released (free)",
                required=(ELEMENT,), variadic=_MODE, range_first=True),
    KeywordSpec("INPUTX", "prescribed (input) nodal coordinates", section="kinematics",
                 required=(NODE,), variadic=_COORD,
                 data_form=KeywordSpec("INPUTX", "initial value (and rate) of a prescribed "
                                       "coordinate",
                                       required=(NODE, _COORD,
                                                 _f("initial value of the coordinate",
                                                    "value")),
                                       optional=_each_optional(
                                           _f("initial velocity of the coordinate", "velocity"),
                                           _f("acceleration of the coordinate",
                                              "acceleration")))),
    KeywordSpec("INPUTE", "prescribed (input) element deformations", section="kinematics",
                required=(ELEMENT,), variadic=_MODE,
                data_form=KeywordSpec("INPUTE", "initial value (and rate) of a prescribed "
                                      "deformation",
                                      required=(ELEMENT, _MODE,
                                                _f("initial value of the deformation",
                                                   "value")),
                                      optional=_each_optional(
                                          _f("initial rate of the deformation", "velocity"),
                                          _f("second time derivative of the deformation",
                                             "acceleration")))),
    KeywordSpec("KINE", "kinematic deformation modes (rates fixed by the rolling constraints)",
                required=(ELEMENT,), variadic=_MODE, range_first=True),
    KeywordSpec("KINX", "kinematic nodal coordinates (rates fixed by the rolling constraints)",
                required=(NODE,), variadic=_COORD),
    KeywordSpec("DYNX", "nodal coordinates that are degrees of freedom (dynamic)",
                required=(NODE,), variadic=_COORD),
    # ------------------------------------------------------------------ elements
    *(element_keyword(kind) for kind in KINDS.values()),
    # SPACAR element and kinematics keywords whose field layouts are not publicly documented
    # (../shared/spacar/README.md: element type codes; issue 18): any fields, always refused
    *(_spacar_only(name, summary, section) for name, summary, section in _SPACAR_ONLY),
    # ------------------------------------------------------------------ statics/dynamics data
    # ESTIFF/EM: values optional at the parse level because a HINGE takes 1 value or none;
    # the model builder requires at least EA GJ EIy EIz (ESTIFF) / rhoA (EM) for a BEAM.
    KeywordSpec(
        "ESTIFF", "element stiffness", section="data", range_first=True,
        required=(ELEMENT,),
        optional=_each_optional(
            _f("axial stiffness EA (N)", "EA"), _f("torsional stiffness GJ (N m^2)", "GJ"),
            _f("bending stiffness EIy (N m^2)", "EIy"), _f("bending stiffness EIz (N m^2)", "EIz"),
            _f("shear flexibility cy (m^2)", "cy"), _f("shear flexibility cz (m^2)", "cz"),
            _f("seventh stiffness value (warping, BEAMW)", "extra"))),
    KeywordSpec(
        "EM", "element mass per unit length", section="data", range_first=True,
        required=(ELEMENT,),
        optional=_each_optional(
            _f("mass per unit length rhoA (kg/m)", "rhoA"),
            _f("polar inertia per unit length rho(Iy+Iz) (kg m)", "rhoIp"),
            _f("inertia per unit length rhoIy (kg m)", "rhoIy"),
            _f("inertia per unit length rhoIz (kg m)", "rhoIz"),
            _f("product of inertia per unit length rhoIyz (kg m)", "rhoIyz"),
            _f("sixth mass value (warping, BEAMW)", "extra"))),
    KeywordSpec("EDAMP", "viscous damping of the deformation modes of an element",
                section="data", range_first=True, required=(ELEMENT,),
                variadic=_f("damping coefficient of a mode (N s/m, N m s)", "d")),
    KeywordSpec("XF", "dead nodal load present from the start", section="data",
                required=_LOAD_FIELDS, optional=_LOAD_OPTIONAL),
    KeywordSpec("DELXF", "dead nodal load increment applied over the load steps",
                section="data", required=_LOAD_FIELDS, optional=_LOAD_OPTIONAL),
    # a line load on a beam: three components (a planar deck: two) of q at p, then
    # optionally those at q (a linear variation); the builder checks the count
    KeywordSpec("QE", "dead line load on a beam (force per length, global axes) from the "
                "start", section="data", extension=True, range_first=True,
                required=_LINE_LOAD_FIELDS, optional=_LINE_LOAD_OPTIONAL),
    KeywordSpec("DELQE", "dead line load increment on a beam applied over the load steps",
                section="data", extension=True, range_first=True,
                required=_LINE_LOAD_FIELDS, optional=_LINE_LOAD_OPTIONAL),
    KeywordSpec("XFL", "follower nodal load in the current axes of an orientation node, "
                "present from the start", section="data", extension=True,
                required=_FOLLOWER_FIELDS, optional=_FOLLOWER_OPTIONAL),
    KeywordSpec("DELXFL", "follower nodal load increment (current axes of an orientation "
                "node) applied over the load steps", section="data", extension=True,
                required=_FOLLOWER_FIELDS, optional=_FOLLOWER_OPTIONAL),
    KeywordSpec("QEL", "follower line load on a beam (current element axes), present "
                "from the start", section="data", extension=True, range_first=True,
                required=_FOLLOWER_LINE_FIELDS, optional=_FOLLOWER_LINE_OPTIONAL),
    KeywordSpec("DELQEL", "follower line load increment on a beam (current element "
                "axes) applied over the load steps", section="data", extension=True,
                range_first=True, required=_FOLLOWER_LINE_FIELDS,
                optional=_FOLLOWER_LINE_OPTIONAL),
    KeywordSpec(
        "ITERSTEP", "load stepping and Newton iteration settings", section="data",
        required=(_f("maximum number of iterations", "max_iter", "int"),
                  _f("number of load steps", "n_steps", "int")),
        optional=_each_optional(
            _f("convergence tolerance", "tol"), _f("fourth ITERSTEP value", "f4"),
            _f("fifth ITERSTEP value", "f5"),
            _f("number of initial-load steps", "n_init", "int"))),
    KeywordSpec(
        "ARCLENGTH", "arc-length continuation of the static path instead of load steps",
        section="data", extension=True,
        required=(_f("maximum number of path points", "n_max", "int", True),
                  _f("first arc length", "ds0", positive=True)),
        optional=_each_optional(_f("smallest arc length", "ds_min", positive=True),
                                _f("largest arc length", "ds_max", positive=True))),
    KeywordSpec(
        "XM", "nodal mass (position node) or inertia tensor (orientation node)", section="data",
        required=(NODE, _f("mass m (kg) or inertia Ixx (kg m^2)", "m")),
        optional=((_f("inertia Ixy (kg m^2)", "Ixy"), _f("inertia Ixz (kg m^2)", "Ixz"),
                   _f("inertia Iyy (kg m^2)", "Iyy"), _f("inertia Iyz (kg m^2)", "Iyz"),
                   _f("inertia Izz (kg m^2)", "Izz")),)),
    KeywordSpec("DELINPX", "increment of a prescribed coordinate over the load steps",
                section="data",
                required=(NODE, _COORD, _f("increment of the coordinate", "delta"))),
    KeywordSpec("DELINPE", "increment of a prescribed deformation over the load steps",
                section="data",
                required=(ELEMENT, _MODE, _f("increment of the deformation", "delta"))),
    KeywordSpec("GRAVITY", "gravitational acceleration", section="data",
                required=(_f("x component of gravity (m/s^2)", "gx"),
                          _f("y component of gravity (m/s^2)", "gy"),
                          _f("z component of gravity (m/s^2)", "gz"))),
    KeywordSpec("TIMESTEP", "end time and number of time steps", section="data",
                required=(_f("end time (s)", "t_end"),
                          _f("number of time steps", "n_steps", "int"))),
    KeywordSpec("ERROR", "error tolerances of the time integration (adaptive step size)",
                section="data",
                required=(_f("absolute error tolerance", "abs"),
                          _f("relative error tolerance", "rel"))),
    KeywordSpec("ESIG", "initial stress resultants (pre-stress) of an element",
                section="data", range_first=True,
                required=(ELEMENT, _f("initial stress resultant of mode 1", "sigma")),
                variadic=_f("initial stress resultant of the next mode", "sigma")),
    KeywordSpec("STARTDE", "initial rate of a deformation mode in a transient analysis",
                section="data",
                required=(ELEMENT, _MODE, _f("initial rate of the deformation", "rate"))),
    # a Python function ``name`` of ``name.py`` beside the deck (docs/user-routines.md); it
    # runs only with ``--allow-user-code``
    KeywordSpec("USERSIG", "user routine giving nodal loads (Python, --allow-user-code)",
                section="data",
                required=(_f("name of the user load routine", "name", "word"),)),
    KeywordSpec("USERINP", "user routine giving prescribed motion (Python, "
                "--allow-user-code)", section="data",
                required=(_f("name of the user motion routine", "name", "word"),)),
    # ------------------------------------------------------------------ output / linearization
    KeywordSpec("OUTLEVEL", "SPACAR output level (accepted; no effect in spacarpy)",
                section="output", required=(_f("output level", "level", "int"),),
                optional=((_f("second output level", "level2", "int"),),)),
    KeywordSpec("INPUTF", "input of the linearized system: a force on a coordinate",
                section="output", required=_IO_FIELDS),
    KeywordSpec("INPUTS", "input of the linearized system: a stress resultant on a "
                "deformation mode", section="output",
                required=(_f("input index", "i", "int", True), ELEMENT, _MODE)),
    KeywordSpec("OUTX", "output of the linearized system: a position coordinate",
                section="output", required=_IO_FIELDS),
    KeywordSpec("OUTXP", "output of the linearized system: a velocity coordinate",
                section="output", required=_IO_FIELDS),
    KeywordSpec("OUTE", "output of the linearized system: an element deformation",
                section="output", required=_IO_ELEMENT_FIELDS),
    KeywordSpec("OUTEP", "output of the linearized system: an element deformation rate",
                section="output", required=_IO_ELEMENT_FIELDS),
    # ------------------------------------------------------------------ spacarpy extensions
    KeywordSpec("INPUTR", "prescribe the rotation of an orientation node about an axis",
                section="extension", extension=True,
                required=(NODE, _f("x component of the rotation axis", "ax"),
                          _f("y component of the rotation axis", "ay"),
                          _f("z component of the rotation axis", "az"))),
    KeywordSpec("DELINPR", "increment of a prescribed rotation angle over the load steps",
                section="extension", extension=True,
                required=(NODE, _f("rotation angle increment (rad)", "angle"))),
    KeywordSpec("MODE", "analysis to run", section="extension", extension=True,
                required=(_f("analysis name or SPACAR mode number", "analysis", "value"),)),
    KeywordSpec("DEFORMATIONS", "beam deformation definitions", section="extension",
                extension=True,
                required=(_f("deformation variant (basic or modified)", "variant", "word",
                             choices=("modified", "basic")),)),
    KeywordSpec("ROTARYINERTIA", "how the beams' section rotary inertia enters the mass",
                section="extension", extension=True,
                required=(_f("lumped (SPACAR's, at the end orientation nodes) or consistent",
                             "choice", "word", choices=("lumped", "consistent")),)),
    KeywordSpec("VELOCITY", "initial velocity of a node in a transient analysis",
                section="extension", extension=True,
                required=(NODE, _f("x component (m/s, or rad/s for an orientation node)", "vx"),
                          _f("y component", "vy"), _f("z component", "vz"))),
    KeywordSpec("DAMPING", "Rayleigh damping alpha M + beta K0 of a transient analysis",
                section="extension", extension=True,
                required=(_f("mass-proportional coefficient alpha (1/s)", "alpha", min=0.0),
                          _f("stiffness-proportional coefficient beta (s)", "beta", min=0.0))),
    KeywordSpec("SUBSTEPS", "time integration steps per stored time step",
                section="extension", extension=True,
                required=(_f("number of integration steps per stored step", "k", "int", True),)),
    KeywordSpec("RHOINF", "numerical dissipation of the time integration (0 to 1)",
                section="extension", extension=True,
                required=(_f("spectral radius at infinite frequency", "rho_inf", min=0.0,
                             max=1.0),)),
    KeywordSpec("START", "initial state of a transient analysis (deck or static)",
                section="extension", extension=True,
                required=(_f("'deck' (at rest in the deck's configuration) or 'static'",
                             "start", "word", choices=("deck", "static")),)),
    KeywordSpec("TIMEFUNCTION", "time function phi(t) of DELXF and the prescribed motions "
                "(or, named, of those LOADTF gives it)",
                section="extension", extension=True,
                required=(_f("constant, zero, linear, ramp, smoothstep, spinup, sine, table or "
                             "expr (or a name, then the kind)", "kind", "word"),),
                variadic=_f("parameter of the time function (expr: \"expression in t\")", "p",
                            "value")),
    KeywordSpec("LOADTF", "the named time function a load increment or a prescribed motion "
                "follows", section="extension", extension=True,
                required=(_f("name of a TIMEFUNCTION", "name", "word"),
                          _f("DELXF, DELXFL, DELQE, DELINPX, DELINPE or DELINPR", "what",
                             "word"),
                          _f("node or element number", "target", "int", True)),
                optional=((_f("coordinate or deformation mode number", "number", "int",
                              True),),)),
    KeywordSpec("MODES", "number of eigen/buckling modes and where to linearize",
                section="extension", extension=True,
                required=(_f("number of modes per linearization", "count", "int", True),),
                optional=((_f("'each' (every load step) or 'last' (the final step)", "where",
                              "word", choices=("each", "last")),),)),
    KeywordSpec("BIFURCATION", "stability check of the static path (off, warn, switch)",
                section="extension", extension=True,
                required=(_f("off, warn or switch", "setting", "word",
                             choices=("off", "warn", "switch")),)),
    KeywordSpec("SET", "define a parameter for {expressions}", section="extension",
                extension=True,
                required=(_f("parameter name", "name", "word"),
                          _f("parameter value (a number or an {expression})", "value"))),
    KeywordSpec("EXPECT", "an expected result value, checked after the run (not part of the "
                "model)", section="extension", extension=True,
                required=(_f("result quantity (e.g. static.position)", "quantity", "word"),
                          _f("selector or expected value", "sel", "value")),
                variadic=_f("selector, expected value or tolerance", "...", "value")),
    KeywordSpec("INCLUDE", "read another deck file here", section="extension", extension=True,
                required=(_f("file name (in double quotes)", '"file"', "word"),)),
    KeywordSpec("BEAMS", "a straight beam subdivided into equal BEAM elements",
                section="extension", extension=True, node_roles="prpr",
                required=(_f("first element number", "e", "int", True), _POS_P, _ROT_P, _POS_Q,
                          _ROT_Q, _COUNT),
                optional=(_ORIENTATION,)),
    KeywordSpec("BEAMARC", "a circular arc of equal BEAM (or curved BEAMC) elements",
                section="extension",
                extension=True, node_roles="prpr",
                required=(_f("first element number", "e", "int", True), _POS_P, _ROT_P, _POS_Q,
                          _ROT_Q, _COUNT, _f("x coordinate of the arc centre (m)", "cx"),
                          _f("y coordinate of the arc centre (m)", "cy"),
                          _f("z coordinate of the arc centre (m)", "cz")),
                optional=(_ORIENTATION,
                          (_f("element shape: chords (straight BEAMs, the default) or curved "
                              "(BEAMC arcs)", "shape", "word", choices=("chords", "curved")),))),
)

#: Every keyword spacarpy recognises before the VISUALIZATION section, by upper-case name.
KEYWORDS: dict[str, KeywordSpec] = {k.name: k for k in _KEYWORD_LIST}

#: Keywords that are recognised but refused by the model builder.
UNSUPPORTED = tuple(k.name for k in _KEYWORD_LIST if not k.supported)

#: Unsupported keywords that define elements (their first field is an element number).
UNSUPPORTED_ELEMENTS = tuple(k.name for k in _KEYWORD_LIST if not k.supported and k.is_element)

#: Unsupported element keywords whose layout is unknown (:data:`_SPACAR_ONLY`).
UNKNOWN_LAYOUT_ELEMENTS = tuple(name for name, _, section in _SPACAR_ONLY
                                if section == "element")

#: Keywords that generate BEAM elements (spacarpy extensions).
GENERATORS = ("BEAMS", "BEAMARC")

_ELEMENT_LIST = _f("element number", "e", "int", positive=True)
_RGB = (_f("red component", "r"), _f("green component", "g"), _f("blue component", "b"))

#: Keywords of SPAVISUAL's VISUALIZATION section (after the final END), by upper-case name.
#: spacarpy keeps the cross-section data (BEAMPROPS, CROSSTYPE, CROSSDIM) and checks the rest.
VISUALIZATION_KEYWORDS: dict[str, KeywordSpec] = {k.name: k for k in (
    KeywordSpec("INITIAL", "the following COLOR is that of the initial configuration",
                section="visualization"),
    KeywordSpec("COLOR", "line colour (RGB)", section="visualization", required=_RGB),
    KeywordSpec("BEAMPROPS", "elements the following CROSSTYPE/CROSSDIM apply to",
                section="visualization", required=(_ELEMENT_LIST,), variadic=_ELEMENT_LIST),
    KeywordSpec("CROSSTYPE", "cross-section shape: RECT or CIRC", section="visualization",
                required=(_f("cross-section type (RECT or CIRC)", "type", "word"),)),
    KeywordSpec("CROSSDIM", "cross-section dimensions: RECT w t, CIRC d (m)",
                section="visualization",
                required=(_f("first cross-section dimension (m)", "w"),),
                optional=((_f("second cross-section dimension (m)", "t"),),)),
    KeywordSpec("GRAPHICS", "elements the following FACECOLOR/OPACITY apply to",
                section="visualization", required=(_ELEMENT_LIST,), variadic=_ELEMENT_LIST),
    KeywordSpec("FACECOLOR", "face colour (RGB)", section="visualization", required=_RGB),
    KeywordSpec("OPACITY", "opacity, 0 to 1", section="visualization",
                required=(_f("opacity", "alpha"),)),
    KeywordSpec("DONOTDRAW", "elements not to draw", section="visualization",
                required=(_ELEMENT_LIST,), variadic=_ELEMENT_LIST),
    KeywordSpec("MODESHAPE", "draw mode shapes", section="visualization"),
    KeywordSpec("MAXIMUM", "maximum number of mode shapes drawn", section="visualization",
                required=(_f("maximum number", "n", "value"),)),
)}
