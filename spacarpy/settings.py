"""Analysis settings: what to compute on a model, kept beside it (never inside it).

A deck holds two things: the structure (:class:`spacarpy.model.Model`) and the choices of
analysis (MODE, DEFORMATIONS, ROTARYINERTIA, BIFURCATION, ITERSTEP, MODES, TIMESTEP, RHOINF,
SUBSTEPS, ERROR, START, TIMEFUNCTION, VELOCITY). The second are frozen dataclasses here, one
per concern, after ERT's per-concern config objects: :class:`AnalysisSettings` with
:class:`StaticSettings`, :class:`LinearizedSettings` and :class:`TransientSettings`.
Command-line choices make a new settings object (:meth:`AnalysisSettings.override`); nothing
mutates one. This module also holds the one implementation of the MODE and DEFORMATIONS
vocabularies (:func:`resolve_analysis`, :func:`resolve_deformations`), used by the deck layer
and the CLI.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

from spacarpy.elements.beam_mass import ROTARY_CHOICES
from spacarpy.errors import SourceLoc

__all__ = ["ANALYSES", "ArcLength", "BIFURCATION_CHOICES", "DEFORMATION_VARIANTS",
           "ROTARY_CHOICES", "SPACAR_MODE_NUMBERS", "START_CHOICES", "UNSUPPORTED_SPACAR_MODES",
           "AnalysisSettings", "IterStep",
           "LinearizedSettings", "StaticSettings", "SystemSignal", "TransientSettings",
           "is_silent_mode", "resolve_analysis", "resolve_deformations", "spacar_mode_refusal",
           "valid_modes"]

DEFORMATION_VARIANTS = ("modified", "basic")
BIFURCATION_CHOICES = ("off", "warn", "switch")
START_CHOICES = ("deck", "static")

#: Analysis names and the SPACAR mode numbers that map onto them (docs/deck.md, "SPACAR
#: mode numbers").
ANALYSES = ("static", "eigen", "buckling", "transient", "check", "state_space",
            "static_linearized", "transient_linearized", "inverse_dynamics")
#: ``static_linearized`` (SPACAR 10) is the static path with the linearized equations
#: (/state_space), frequencies and buckling multipliers at every step; the name ``static``
#: stays the plain static path (the cheap default). ``transient_linearized`` (SPACAR 3) is the
#: transient with the linearized equations at every stored time step.
#: ``inverse_dynamics`` (SPACAR 2) computes the input forces of a fully prescribed motion.
SPACAR_MODE_NUMBERS = {10: "static_linearized", 0: "check", 1: "transient", 8: "buckling",
                       4: "eigen", 7: "eigen", 9: "state_space", 3: "transient_linearized",
                       2: "inverse_dynamics"}
#: SPACAR mode numbers spacarpy knows but does not run, with the reason given to the user
#: (none at present: every SPACAR mode runs).
UNSUPPORTED_SPACAR_MODES: dict = {}


def _mode_number(value) -> int | None:
    """The whole number of a MODE value (an int, a float or its text), or None."""
    if isinstance(value, str):
        try:
            value = float(value.strip())
        except ValueError:
            return None
    if isinstance(value, float):
        return int(value) if value.is_integer() else None
    return value if isinstance(value, int) else None


def spacar_mode_refusal(value) -> str | None:
    """The message refusing a known but unsupported SPACAR mode number (2, 3, also negative),
    or None for any other value."""
    number = _mode_number(value)
    return None if number is None else UNSUPPORTED_SPACAR_MODES.get(abs(number))


def is_silent_mode(value) -> bool:
    """A negative SPACAR mode number: SPACAR's silent run (no progress output)."""
    number = _mode_number(value)
    return number is not None and number < 0


def resolve_analysis(value) -> str | None:
    """Map a MODE value (name, SPACAR number, or its text) to an analysis name.

    Returns None if the value is not valid. Negative SPACAR numbers (silent runs) map like
    their positive counterparts.
    """
    if isinstance(value, str) and value.strip().lower() in ANALYSES:
        return value.strip().lower()
    number = _mode_number(value)
    return None if number is None else SPACAR_MODE_NUMBERS.get(abs(number))


def resolve_deformations(value) -> str | None:
    """Map a DEFORMATIONS value to ``"basic"``/``"modified"``, or None if not valid."""
    if isinstance(value, str) and value.strip().lower() in DEFORMATION_VARIANTS:
        return value.strip().lower()
    return None


def valid_modes() -> str:
    """The MODE values, for messages."""
    numbers = ", ".join(f"{k}={v}" for k, v in sorted(SPACAR_MODE_NUMBERS.items()))
    return f"{', '.join(ANALYSES)} or a SPACAR mode number ({numbers}; negative = silent)"


@dataclass(frozen=True)
class IterStep:
    """SPACAR's ``ITERSTEP`` line as spacarpy reads it (documented in docs/deck.md).

    ``ITERSTEP max_iter n_steps tol [f4 f5 n_init]``

    max_iter : int
        Newton iterations allowed per load step before the step is cut (SPACAR's field 1).
    n_steps : int
        Number of equal load increments in which DELXF is applied; results are stored after
        the initial state (XF only, step 0) and after every increment (steps 1..n_steps).
    tol : float
        Relative convergence tolerance of the Newton iterations.
    n_init : int
        Number of sub-steps used internally to reach the initial load XF (field 6; not stored).
    extra : tuple
        Fields 4 and 5, kept but not used (their meaning in SPACAR is not public).
    """

    max_iter: int = 10
    n_steps: int = 1
    tol: float = 5e-7
    n_init: int = 1
    extra: tuple = ()
    loc: SourceLoc | None = None


@dataclass(frozen=True)
class ArcLength:
    """The deck's ``ARCLENGTH n_max ds0 [ds_min [ds_max]]`` (spacarpy extension): follow the
    equilibrium path by arc-length continuation instead of load stepping (docs/path.md, "Method").

    n_max : int
        At most this many points after the initial state (critical points included).
    ds0 : float
        The first arc length, in the scaled norm of :mod:`spacarpy.solvers.path.arclength`.
    ds_min, ds_max : float or None
        Bounds of the adaptive arc length (None: ``ds0 / 1000`` and ``10 ds0``).
    """

    n_max: int
    ds0: float
    ds_min: float | None = None
    ds_max: float | None = None
    loc: SourceLoc | None = field(default=None, compare=False)

    @property
    def bounds(self) -> tuple[float, float]:
        """(ds_min, ds_max) with the defaults filled in."""
        lo = self.ds_min if self.ds_min is not None else self.ds0 / 1000.0
        hi = self.ds_max if self.ds_max is not None else 10.0 * self.ds0
        return lo, hi


@dataclass(frozen=True)
class StaticSettings:
    """The static load path: ``iterstep`` (ITERSTEP) and ``arclength`` (ARCLENGTH, None:
    load stepping)."""

    iterstep: IterStep = field(default_factory=IterStep)
    arclength: ArcLength | None = None


@dataclass(frozen=True)
class SystemSignal:
    """One input or output of the linearized state-space system (SPACAR mode 9), a deck line
    ``INPUTF i n c``, ``INPUTS i e k``, ``OUTX i n c``, ``OUTXP i n c``, ``OUTE i e k`` or
    ``OUTEP i e k``.

    keyword : str
        ``INPUTF``, ``INPUTS``, ``OUTX``, ``OUTXP``, ``OUTE`` or ``OUTEP``.
    index : int
        ``i``: the signal's number among the inputs / outputs (1 = first).
    target : int
        The deck node (INPUTF, OUTX, OUTXP) or element (INPUTS, OUTE, OUTEP).
    number : int
        The node's coordinate (1..3 x y z; 1..4 lambda0..lambda3) or the element's mode.
    """

    keyword: str
    index: int
    target: int
    number: int
    loc: SourceLoc | None = field(default=None, compare=False)

    @property
    def name(self) -> str:
        """The deck line, ``OUTX 2 31 1``: the signal's name in result and MATLAB files."""
        return f"{self.keyword} {self.index} {self.target} {self.number}"


@dataclass(frozen=True)
class LinearizedSettings:
    """Eigenfrequencies and buckling: the deck's ``MODES count [each|last]`` (spacarpy
    extension). ``n_modes`` None means the program's default (10); ``modes_each_step``:
    linearize at every load step, not only the last. ``inputs`` and ``outputs``: the
    :class:`SystemSignal` lines of the state-space system (mode 9), each ordered by index."""

    n_modes: int | None = None
    modes_each_step: bool = False
    inputs: tuple = ()
    outputs: tuple = ()

    @property
    def count(self) -> int:
        """The number of modes to compute."""
        return self.n_modes or 10

    @property
    def input_names(self) -> list[str]:
        """The name of each input column, 1..the largest input number: the deck line, or
        ``(no input i)`` for a number without a line (a zero column)."""
        return signal_names(self.inputs, "input")

    @property
    def output_names(self) -> list[str]:
        """The name of each output row (``(no output i)`` for a gap: a zero row)."""
        return signal_names(self.outputs, "output")


def signal_names(signals, what: str) -> list[str]:
    """The names of the signals by number 1..max (``(no input 3)`` for a gap)."""
    by_index = {s.index: s.name for s in signals}
    return [by_index.get(i, f"(no {what} {i})") for i in range(1, max(by_index, default=0) + 1)]


@dataclass(frozen=True)
class TransientSettings:
    """The time integration (see docs/transient.md).

    timestep : (t_end, n_steps) or None
        TIMESTEP (None: not given; MODE transient then refuses to run).
    rho_inf : float
        RHOINF, the spectral radius at infinite frequency of the generalized-alpha method.
    substeps : int
        SUBSTEPS, integration steps per stored step.
    error_tol : (abs, rel) or None
        ERROR: adaptive time steps.
    start : str
        START: ``"deck"`` (at rest in the deck's configuration) or ``"static"``.
    time_function : (kind, params)
        TIMEFUNCTION (:mod:`spacarpy.time_functions`), the deck's function: of every load
        increment and prescribed motion that names none.
    named_time_functions : tuple of (name, (kind, params))
        The named ``TIMEFUNCTION name kind params`` lines (names in lower case), of the
        loads and motions that LOADTF gives them.
    initial_velocities : dict of node -> (3,)
        VELOCITY lines.
    """

    timestep: tuple | None = None
    rho_inf: float = 0.9
    substeps: int = 1
    error_tol: tuple | None = None
    start: str = "deck"
    time_function: tuple = ("constant", ())
    named_time_functions: tuple = ()
    initial_velocities: dict = field(default_factory=dict)


@dataclass(frozen=True)
class AnalysisSettings:
    """What to compute on a model: the analysis, the deformation variant, the stability check
    of the static path, and the settings of each kind of solution.

    analysis : str
        One of :data:`ANALYSES`.
    deformations : str
        ``"modified"`` (Eq. 48, default) or ``"basic"`` (Eq. 7).
    bifurcation : str
        ``"off"``, ``"warn"`` (say when the path turns unstable) or ``"switch"`` (also switch
        to a stable branch), see :mod:`spacarpy.solvers.path.stability`.
    rotary_inertia : str
        ``"lumped"`` (SPACAR's, default) or ``"consistent"``: how the beams' section rotary
        inertia enters the mass (:mod:`spacarpy.elements.beam_mass`); used by every analysis
        with mass (eigen, transient).
    """

    analysis: str = "static"
    deformations: str = "modified"
    bifurcation: str = "off"
    rotary_inertia: str = "lumped"
    static: StaticSettings = field(default_factory=StaticSettings)
    linearized: LinearizedSettings = field(default_factory=LinearizedSettings)
    transient: TransientSettings = field(default_factory=TransientSettings)

    def __post_init__(self):
        if self.analysis not in ANALYSES:
            raise ValueError(f"unknown analysis {self.analysis!r}; expected one of {ANALYSES}")
        if self.deformations not in DEFORMATION_VARIANTS:
            raise ValueError(f"unknown deformation variant {self.deformations!r}")
        if self.bifurcation not in BIFURCATION_CHOICES:
            raise ValueError(f"unknown bifurcation setting {self.bifurcation!r}")
        if self.rotary_inertia not in ROTARY_CHOICES:
            raise ValueError(f"unknown rotary inertia {self.rotary_inertia!r}; expected one of "
                             f"{ROTARY_CHOICES}")

    @property
    def iterstep(self) -> IterStep:
        """Short for ``static.iterstep``."""
        return self.static.iterstep

    def override(self, *, analysis: str | None = None, deformations: str | None = None,
                 n_modes: int | None = None, modes_each_step: bool | None = None,
                 iterstep: IterStep | None = None,
                 rotary_inertia: str | None = None) -> AnalysisSettings:
        """A copy with the given choices replaced (None: keep); ``analysis`` and
        ``deformations`` are names as :func:`resolve_analysis` / :func:`resolve_deformations`
        accept them.

        Raises
        ------
        ValueError
            For an unknown analysis or deformation variant.
        """
        new = self
        if analysis is not None:
            name = resolve_analysis(analysis)
            if name is None:
                raise ValueError(f"unknown analysis '{analysis}'; expected {valid_modes()}")
            new = replace(new, analysis=name)
        if deformations is not None:
            name = resolve_deformations(deformations)
            if name is None:
                raise ValueError(f"unknown deformation variant '{deformations}'; expected "
                                 f"{' or '.join(DEFORMATION_VARIANTS)}")
            new = replace(new, deformations=name)
        if n_modes is not None or modes_each_step is not None:
            lin = new.linearized
            new = replace(new, linearized=replace(
                lin, n_modes=lin.n_modes if n_modes is None else n_modes,
                modes_each_step=(lin.modes_each_step if modes_each_step is None
                                 else modes_each_step)))
        if iterstep is not None:
            new = replace(new, static=replace(new.static, iterstep=iterstep))
        if rotary_inertia is not None:
            new = replace(new, rotary_inertia=str(rotary_inertia).strip().lower())
        return new
