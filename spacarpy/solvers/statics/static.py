"""Non-linear static analysis along the load path: load stepping, step cutting and
(with ``BIFURCATION switch``) branch switching.

Step 0 is the equilibrium under the initial load XF, reached in ``n_init`` internal
sub-steps of its factor ``a``; steps 1..n_steps add the DELXF increments (factor ``s``) in
equal parts. Every sub-step starts from the :class:`~spacarpy.solvers.statics.newton.Predictor` and
is solved by :func:`~spacarpy.solvers.statics.newton.newton` on the equations of
:class:`~spacarpy.solvers.statics.equilibrium.StaticProblem` under a
:class:`~spacarpy.solvers.statics.loads.LoadState`. A failing step (no convergence within
``max_iter``, divergence, a non-finite value, a singular Newton matrix) is cut in half and
retried, down to ``1/2**max_cuts`` of the requested increment, then a
:class:`~spacarpy.errors.ConvergenceError` names the step and the residual history. After
each stored step the stability of the path is checked where asked
(:class:`~spacarpy.solvers.path.stability.PathStability`). Before the first load the model's
kinematics are checked (:mod:`spacarpy.solvers.statics.kinematic_check`). The formulation is in
docs/solver.md.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from spacarpy.errors import ConvergenceError, ModelError
from spacarpy.model import Model
from spacarpy.settings import AnalysisSettings
from spacarpy.solvers.path.arclength import ArcLengthPath
from spacarpy.solvers.path.stability import PathStability
from spacarpy.solvers.statics.contact import ContactMonitor
from spacarpy.solvers.statics.equilibrium import StaticProblem, Timings
from spacarpy.solvers.statics.errors import StepFailed
from spacarpy.solvers.statics.kinematic_check import check_initial, free_motions
from spacarpy.solvers.statics.loads import Loads, LoadState
from spacarpy.solvers.statics.newton import Predictor, newton

log = logging.getLogger(__name__)


@dataclass
class StaticStep:
    """One converged (stored) load step."""

    load_factor: float
    x: np.ndarray             # (n_coord,) all nodal coordinates
    deformation: dict         # element keyword -> (n_elem, n_def) deformations
    stress: dict              # keyword -> (n_elem, n_def) stress resultants (rigid: multipliers)
    reaction: np.ndarray      # (n_reac,)
    iterations: int
    residual: float
    mu: np.ndarray | None = None   # (n_constraint,) constraint multipliers
    arc_length: float | None = None   # ARCLENGTH: the scaled arc length from step 0
    critical: object = None           # ARCLENGTH: a CriticalPoint refined at this step
    warning: str | None = None        # load stepping: the step jumped (snap-through)
    converged_by: str = "tolerance"   # or "floor": within the measured round-off floor
    stability: int = -1               # ARCLENGTH: certified status (path/point_status.py)


@dataclass
class StaticOptions:
    """Solver settings; defaults come from the deck's ITERSTEP line."""

    max_iter: int = 10
    tol: float = 5e-7
    n_steps: int = 1
    n_init: int = 1
    max_cuts: int = 12
    deformations: str = "modified"
    bifurcation: str = "off"        # stability check of the path: off, warn, switch
    arclength: object = None        # settings.ArcLength: arc-length continuation

    @classmethod
    def from_settings(cls, settings: AnalysisSettings, **kw) -> StaticOptions:
        """The options of a deck's settings (ITERSTEP, DEFORMATIONS, BIFURCATION); ``kw``
        replaces fields."""
        it = settings.static.iterstep
        fields = dict(max_iter=it.max_iter, tol=it.tol, n_steps=it.n_steps, n_init=it.n_init,
                      deformations=settings.deformations, bifurcation=settings.bifurcation,
                      arclength=settings.static.arclength)
        fields.update(kw)
        return cls(**fields)


@dataclass
class StaticResult:
    """All stored steps of a static run plus bookkeeping."""

    steps: list = field(default_factory=list)
    problem: StaticProblem | None = None


def solve_static(model: Model, settings: AnalysisSettings | None = None, *,
                 deformations: str | None = None, options: StaticOptions | None = None,
                 on_step=None, problem: StaticProblem | None = None) -> StaticResult:
    """Solve the static problem of ``model`` along its load path.

    ``settings`` (default: the defaults) give the load stepping (ITERSTEP), the deformation
    variant and the stability check; ``options`` replaces them all, ``deformations`` the
    variant only.

    Step 0 is the equilibrium under XF (reached in ``n_init`` internal sub-steps); steps
    1..n_steps add DELXF in equal increments. ``on_step(StaticStep)`` is called after each
    stored step (the results writer appends it to the file at once).

    Raises
    ------
    ConvergenceError
        With the step, the load factor reached and the residual history; the steps already
        passed to ``on_step`` stay valid.
    ModelError
        When the Newton matrix is singular (mechanism, over-constraint).
    """
    settings = settings if settings is not None else AnalysisSettings()
    opts = options or StaticOptions.from_settings(
        settings, deformations=deformations or settings.deformations)
    prob = problem or StaticProblem(model, deformations=opts.deformations)
    t_start = time.perf_counter()
    num = prob.num
    x = num.x0.copy()
    mu = np.zeros(prob.n_multiplier)            # constraint multipliers, then the slips'
    result = StaticResult(problem=prob)
    if prob.loads.any and prob.slips:
        # rolling wheels: the kinematic check sees the holonomic constraints only, so the
        # motions the slips hold (and those the loads hold, a balanced inverted pendulum
        # such as a bicycle at rest) look free to it; the loaded Newton matrix with the
        # slip rows decides (a singular one fails the step, naming it)
        exc = check_initial(prob, allow_mechanism=True)
        if exc is not None:
            log.info("holonomic free motions (%s): held by the slips and the loads, or the "
                     "first Newton matrix is singular", free_motions(exc))
    elif prob.loads.any:
        try:
            check_initial(prob)
        except ModelError as exc:
            raise _no_equilibrium(exc, settings) from None
    else:
        # no load at all: the initial configuration is the equilibrium, also for a
        # free-floating structure or a mechanism (neutral equilibrium, e.g. before an
        # eigenfrequency analysis): say so instead of refusing, unless something else
        # (a pre-stress ESIG) drives it. Redundant constraints are an error with or
        # without load.
        exc = check_initial(prob, allow_mechanism=True)
        if exc is not None:
            if _driven(prob, opts.tol):
                raise _no_equilibrium(exc, settings)
            log.warning("unloaded model with free motions (%s): no load drives them, so its "
                        "initial configuration is taken as the equilibrium (a neutral one)",
                        free_motions(exc))

    warned = []
    contact = ContactMonitor(num)

    def store(load_factor, x, mu, its, res, arc=None, critical=None, warning=None,
              by="tolerance", stability=-1):
        ev = prob.evaluate(x, mu, prob.loads.at(1.0, load_factor))
        if not warned:
            warned.extend(_strain_warnings(num, ev.states, len(result.steps)))
        deformation, stress = prob.element_results(ev)
        k = len(result.steps)
        lift = contact(stress, k, f"static step {k} (load factor {load_factor:.4g})")
        if lift is not None:
            warning = lift if warning is None else f"{warning}; {lift}"
        step = StaticStep(load_factor=load_factor, x=x.copy(), deformation=deformation,
                          stress=stress, reaction=prob.reactions(x, ev.f_int, ev.f_ext),
                          iterations=its, residual=res, mu=mu.copy(), arc_length=arc,
                          critical=critical, warning=warning, converged_by=by,
                          stability=stability)
        result.steps.append(step)
        if on_step is not None:
            on_step(step)

    predictor = Predictor(prob)

    def advance(x, mu, p_from, p_to, n_sub, stored_step):
        return _advance(prob, predictor, x, mu, p_from, p_to, n_sub, opts, stored_step)

    path = PathStability(prob, opts, predictor, advance)
    if path.on and prob.loads.parts:
        # its index counts the negative eigenvalues of the tangent's symmetric part: no
        # stability criterion where follower loads make the tangent unsymmetric
        log.warning("BIFURCATION %s is off: the follower loads (XFL/DELXFL) are not "
                    "conservative and the index of the tangent's symmetric part does not "
                    "decide stability; divergence and flutter show in MODE eigen",
                    opts.bifurcation)
        path.on = False
    # phase A: reach XF (a: 0 -> 1) at s = 0
    x, mu, its, res, by = advance(x, mu, (0.0, 0.0), (1.0, 0.0),
                                  opts.n_init if prob.loads.has_xf else 1, stored_step=0)
    x, mu = path.check(prob.normalize(x), mu, (1.0, 0.0), 0)
    if opts.arclength is not None:
        if prob.slips:
            raise ModelError("ARCLENGTH is not supported with rolling wheels (WHEEL slips "
                             "held) yet: use load steps (ITERSTEP, DELXF)")
        arc_path = ArcLengthPath(prob, opts, opts.arclength)
        store(0.0, x, mu, its, res, arc=0.0, by=by, stability=arc_path.start_status(x, mu))
        arc_path.follow(x, mu, store)
        prob.timings.total = time.perf_counter() - t_start
        return result
    store(0.0, x, mu, its, res, by=by)
    # phase B: DELXF in n_steps stored increments
    jumps = JumpCheck(prob)
    for k in range(1, opts.n_steps + 1):
        s0, s1 = (k - 1) / opts.n_steps, k / opts.n_steps
        x_old = x
        x, mu, its, res, by = advance(x, mu, (1.0, s0), (1.0, s1), 1, stored_step=k)
        x, mu = path.check(prob.normalize(x), mu, (1.0, s1), k)
        store(s1, x, mu, its, res, warning=jumps(x_old, x, k, s1), by=by)
    prob.timings.total = time.perf_counter() - t_start
    if contact.report() is not None:
        log.info(contact.report())
    return result


def _driven(prob, tol: float) -> bool:
    """Whether an unloaded model is out of equilibrium in its initial configuration at
    the start or the end of its load path (a pre-stress ESIG acting)."""
    num = prob.num
    mu = np.zeros(prob.n_multiplier)
    for s in (0.0, 1.0):
        ev = prob.evaluate(num.x0, mu, prob.loads.at(1.0, s))
        if prob.null_state(num.x0, ev.load):
            continue
        if prob.residual_norm(ev.r, ev.c, ev.f_int, ev.f_ext)[0] > tol:
            return True
    return False


def _no_equilibrium(exc, settings) -> ModelError:
    """A static run of a mechanism under its loads: it has no static equilibrium. The
    kinematic check's error (the free motions, their nodes and drivers) gets a line that
    says so and names the analysis the deck's lines suggest (exit 3)."""
    if not getattr(exc, "mechanism", True) or getattr(exc, "over_constrained", False):
        return exc
    hint = ("to follow its motion, run it as a transient (--mode 1, with TIMESTEP and "
            "masses)")
    if settings.transient.timestep is not None:
        hint = "the deck has TIMESTEP: run it with --mode 1 (transient)"
    err = ModelError(f"{exc}\n  a mechanism under its loads has no static equilibrium, and "
                     f"a static run cannot solve it: {hint}")
    err.mechanism, err.over_constrained = True, False
    return err


#: A load step whose scaled increment exceeds this many times the largest one before it
#: has jumped (to another branch of the path: a snap-through).
JUMP_RATIO = 5.0


class JumpCheck:
    """Load stepping warns when a step jumps between branches: its increment (the largest
    position change relative to the length scale, rotations as they are) is more than
    :data:`JUMP_RATIO` times the largest increment of the steps before it. Equal load steps
    on a smooth path change by comparable amounts; a snap-through moves many times
    further in one step."""

    def __init__(self, prob):
        self.prob, self.largest = prob, 0.0

    def __call__(self, x_old, x_new, step: int, load_factor: float) -> str | None:
        d = self.prob.increment_norm((x_new - x_old)[self.prob.free])
        before, self.largest = self.largest, max(self.largest, d)
        if not (before > 0 and d > JUMP_RATIO * before):
            return None
        msg = (f"step {step} (load factor {load_factor:.4g}) jumped: its increment is "
               f"{d / before:.3g} times the largest before it; the path passed a limit point "
               f"(snap-through) and the step landed on another branch. Use ARCLENGTH (or "
               f"displacement control, INPUTX/DELINPX) to follow the path through it")
        log.warning(msg)
        return msg


#: Axial strain beyond which a warning says the linear material law is being stretched.
MAX_AXIAL_STRAIN = 0.05


def _strain_warnings(num, states, step) -> list:
    """Warn once when an element's axial strain leaves the small-strain range."""
    out = []
    for g, st in zip(num.groups, states):
        if g.keyword not in ("BEAM", "TRUSS") or not g.n_elem:
            continue
        strain = np.abs(st.e[:, 0]) / g.ref.l0
        i = int(np.argmax(strain))
        if strain[i] > MAX_AXIAL_STRAIN:
            msg = (f"step {step}: {g.keyword} {int(g.ids[i])} has an axial strain of "
                   f"{100 * strain[i]:.3g}%, far beyond the small strains the linear "
                   f"stiffness (ESTIFF) describes; check the loads and the model")
            log.warning(msg)
            out.append(msg)
    return out


#: The smallest tolerance the scaled residual and increment can meet in double precision:
#: 100 machine epsilons (round-off of sums of many terms of the load's size). An ITERSTEP
#: tolerance below it can never be met, whatever the model.
ROUNDOFF_TOL = 100 * np.finfo(float).eps


def roundoff_hint(tol: float, history) -> str:
    """A sentence for a failure message when ``tol`` is below :data:`ROUNDOFF_TOL`, else "".

    The suggested tolerance is the power of ten at or above both the floor and the smallest
    residual the last attempt reached (where the iterations stalled), at most the default
    tolerance (an attempt that diverged early says nothing about the floor).
    """
    if not tol < ROUNDOFF_TOL:
        return ""
    finite = [h for h in history if np.isfinite(h) and h > 0]
    reached = min(finite, default=ROUNDOFF_TOL)
    suggest = min(10.0 ** np.ceil(np.log10(max(reached, ROUNDOFF_TOL))), StaticOptions.tol)
    return (f". The ITERSTEP tolerance {tol:.3g} is below the round-off floor of the scaled "
            f"residual (100 x machine epsilon = {ROUNDOFF_TOL:.1e}; the smallest residual "
            f"reached was {reached:.2e}): use a tolerance of {suggest:.0e} or larger (the "
            f"default is {StaticOptions.tol:.0e})")


#: The lowest eigenvalue of the reduced tangent, relative to that of the material
#: stiffness alone, below which a state where step cutting failed is taken to be at a
#: limit point when no second state tells the trend (the failure came on the first
#: sub-step of a load step).
LIMIT_EIGENVALUE = 1e-3


def _softest(prob, x, mu, params) -> tuple[float, float] | None:
    """Lowest eigenvalues of the reduced tangent and of the reduced material stiffness at
    a state, or None where the tangent has a negative eigenvalue (an unstable state, not
    one on the way to a limit point) or no free coordinate. Dense up to
    ``eigen.DENSE_LIMIT`` coordinates; above it :func:`_softest_sparse` (the same numbers)."""
    import scipy.linalg as sla

    from spacarpy.solvers.linear.eigen import DENSE_LIMIT, null_space_basis
    from spacarpy.solvers.linear.linearize import linearize
    n_x = prob.pattern.n_x
    lin = linearize(prob, x, mu, prob.loads.at(*params))
    if n_x > DENSE_LIMIT:
        return _softest_sparse(lin, n_x)
    T = null_space_basis(lin.C, n_x)
    if T.shape[1] == 0:
        return None
    out = []
    for k in (lin.K, lin.K_mat):
        k = T.T @ (k @ T)
        out.append(float(sla.eigvalsh(0.5 * (k + k.T))[0]))
    return out[0], out[1]


#: Eigenvalues nearest zero that :func:`_softest_sparse` computes (the lowest of them is the
#: lowest of all where none is negative).
SPARSE_NEAREST = 3


def _softest_sparse(lin, n_x: int) -> tuple[float, float] | None:
    """:func:`_softest` at any size: the eigenvalues nearest zero of the pencil
    ``[[K, C^T], [C, 0]] - lam [[I, 0], [0, 0]]`` (those of ``T^T K T`` for an orthonormal
    null-space basis T of C, as the dense reduction), in shift-invert about zero with one
    sparse LU of the bordered matrix (ARPACK). A state with a negative eigenvalue among
    them, or an odd number of negative ones in all (the sign of the bordered determinant,
    ``(-1)^m`` times that of the reduced tangent, m the constraints), is not judged."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from spacarpy.solvers.path.arclength import determinant_sign
    C = sp.csr_matrix(lin.C)
    m = C.shape[0]
    if n_x - m < 1:
        return None
    mask = np.concatenate([np.ones(n_x), np.zeros(m)])
    out = []
    for which, K in enumerate((lin.K, lin.K_mat)):
        K = sp.csr_matrix(K)
        A = sp.bmat([[0.5 * (K + K.T), C.T], [C, None]], format="csc")
        try:
            lu = spla.splu(A, permc_spec="COLAMD")
        except RuntimeError:                         # exactly singular: at the point itself
            out.append(0.0)
            continue
        if which == 0 and determinant_sign(lu) * (-1) ** m < 0:
            return None
        op = spla.LinearOperator(A.shape, matvec=lambda v, lu=lu: lu.solve(mask * v),
                                 dtype=float)
        k = min(SPARSE_NEAREST, n_x - m - 1)
        if k < 1:
            return None
        nu = spla.eigs(op, k=k, which="LM", v0=mask.copy(), return_eigenvectors=False)
        with np.errstate(divide="ignore"):
            lam = 1.0 / nu.real
        if which == 0 and np.any(lam < 0):
            return None
        out.append(float(lam.min()))
    return out[0], out[1]


def limit_point(prob, prev, last, p_from, p_to, t_prev, t, dt) -> str | None:
    """The message of a load-control failure at a limit point, or None.

    Step cutting failed at the load parameter ``t + dt`` of the way from ``p_from`` to
    ``p_to``, after the state ``last`` converged at ``t`` and ``prev`` at ``t_prev`` before
    it (the step's start where ``t_prev == t``). Near a limit point the lowest eigenvalue of
    the reduced tangent goes to zero like the square root of the distance to it, so its
    square is linear in the load: extrapolated from the two states it vanishes before twice
    the failed increment, and where it vanishes is the load factor the message gives (with
    one state: it is below :data:`LIMIT_EIGENVALUE` times the material stiffness's, and the
    message gives the last converged load factor). A state with a negative eigenvalue (an
    unstable branch, a passed bifurcation) is not a limit point of this path. Any size
    (:func:`_softest`)."""
    moving = 1 if p_to[1] != p_from[1] else 0          # phase B moves DELXF, A moves XF
    q = [p_from[moving] + f * (p_to[moving] - p_from[moving]) for f in (t_prev, t, t + dt)]
    soft_c = _softest(prob, *last, p_from + t * (p_to - p_from))
    if soft_c is None or not soft_c[0] >= 0:
        return None
    lam_c, q_zero = soft_c[0], q[1]
    if t > t_prev:
        soft_s = _softest(prob, *prev, p_from + t_prev * (p_to - p_from))
        if soft_s is None or not soft_s[0] > lam_c:
            return None
        lam_s = soft_s[0]
        q_zero = q[1] + lam_c ** 2 * (q[1] - q[0]) / (lam_s ** 2 - lam_c ** 2)
        log.debug("limit point test: lowest eigenvalue %.3g at %.8g, %.3g at %.8g: zero "
                  "at %.8g; failed at %.8g", lam_s, q[0], lam_c, q[1], q_zero, q[2])
        if not q_zero <= q[2] + (q[2] - q[1]):
            return None
    elif not lam_c < LIMIT_EIGENVALUE * soft_c[1]:
        return None
    name = "DELXF" if moving else "XF"
    return (f"limit point at load factor {q_zero:.6g} ({name} factor, where the tangent's "
            f"lowest eigenvalue goes to zero; the last converged state is at {q[1]:.6g}): "
            f"the load cannot be raised further on this path; add ARCLENGTH to follow it")


def _advance(prob, predictor, x, mu, p_from, p_to, n_sub, opts, stored_step):
    """Move the load parameters (a, s) from p_from to p_to, cutting steps on failure."""
    p_from, p_to = np.asarray(p_from, float), np.asarray(p_to, float)
    t, t_end = 0.0, 1.0
    dt_nominal = 1.0 / max(n_sub, 1)
    dt = dt_nominal
    min_dt = dt_nominal / 2 ** opts.max_cuts
    total_its, last_res, last_by = 0, 0.0, "tolerance"
    prev, t_prev = (x, mu), 0.0                 # the converged state before the last
    while t < t_end - 1e-14:
        dt = min(dt, t_end - t)
        p = p_from + (t + dt) * (p_to - p_from)
        try:
            load = prob.loads.at(*p)
            x_start, states = predictor.with_states(x, mu, load)
            x_new, mu_new, its, res, hist = newton(prob, x_start, mu, load, opts, states)
        except StepFailed as fail:
            if dt / 2 < min_dt:
                lf = p_from[1] + t * (p_to[1] - p_from[1])
                limit = limit_point(prob, prev, (x, mu), p_from, p_to, t_prev, t, dt)
                if limit is not None:
                    raise ConvergenceError(f"static step {stored_step}: {limit}") from None
                hist = ", ".join(f"{h:.3e}" for h in fail.history)
                raise ConvergenceError(
                    f"static step {stored_step} did not converge ({fail.reason}) after "
                    f"{opts.max_cuts} step cuts; last converged load: XF factor "
                    f"{p_from[0] + t * (p_to[0] - p_from[0]):.6g}, DELXF factor {lf:.6g}; "
                    f"residual history of the last attempt: [{hist}]"
                    f"{roundoff_hint(opts.tol, fail.history)}") from None
            log.info("step %d: %s at increment %.3g, cutting the step", stored_step,
                     fail.reason, dt)
            dt /= 2
            continue
        prev, t_prev = (x, mu), t
        x, mu = x_new, mu_new
        if prob.has_commit:
            prob.commit(x, mu, load)
        total_its += its
        last_res, last_by = res, hist.converged_by
        t += dt
        dt = min(dt * 2, dt_nominal)            # grow back after a successful cut step
    return x, mu, total_its, last_res, last_by


__all__ = ["solve_static", "StaticProblem", "StaticStep", "StaticOptions", "StaticResult",
           "Loads", "LoadState", "Timings"]
