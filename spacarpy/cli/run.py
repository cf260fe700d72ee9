"""``spacarpy run``: its arguments (``--mode`` and the SPACAR mode numbers), the analysis
of one deck into a result file, the transient's progress bar and the EXPECT lines."""
from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

from spacarpy.cli.common import (
    _output_path,
    _positive_int,
    _require_elements,
    _set_option,
    _user_code_options,
    _verbosity,
)
from spacarpy.errors import EXIT_OK

log = logging.getLogger("spacarpy")


class _Mode(str):
    """An analysis name from ``--mode``; ``silent``: given as a negative SPACAR number."""

    silent = False


def _parse_mode(text: str) -> str:
    from spacarpy.settings import (
        ANALYSES,
        SPACAR_MODE_NUMBERS,
        is_silent_mode,
        resolve_analysis,
        spacar_mode_refusal,
    )
    refusal = spacar_mode_refusal(text)
    if refusal is not None:
        raise argparse.ArgumentTypeError(refusal)
    name = resolve_analysis(text)
    if name is not None:
        mode = _Mode(name)
        mode.silent = is_silent_mode(text)
        return mode
    raise argparse.ArgumentTypeError(
        f"unknown mode {text!r}: expected one of {', '.join(ANALYSES)} or a SPACAR mode "
        f"number ({', '.join(str(k) for k in sorted(SPACAR_MODE_NUMBERS))}; negative = "
        "silent)")


def add_parser(sub) -> None:
    """The ``run`` subcommand's arguments."""
    run = sub.add_parser("run", help="analyse a deck and write an HDF5 result file")
    run.add_argument("deck", type=Path, help="SPACAR-style deck (.dat)")
    run.add_argument("-o", "--output", type=_output_path, default=None,
                     help="result file (default: the deck's name with .h5)")
    run.add_argument("--mode", type=_parse_mode, default=None,
                     help="analysis: static, static_linearized (SPACAR 10: with the "
                          "linearized equations, frequencies and buckling at every step), "
                          "eigen (4, 7), buckling (8), transient (1), check (0: mechanism "
                          "and DOF report, no solve), state_space (9: the linearized state "
                          "space), transient_linearized (3: the linearized equations at "
                          "every time step), inverse_dynamics (2: the input forces of a "
                          "prescribed motion); a negative SPACAR "
                          "number runs silently (as -q); overrides the deck's MODE line")
    run.add_argument("--deformations", choices=("modified", "basic"), default=None,
                     help="deformation definitions: modified second-order (Eq. 48, default) "
                          "or basic (Eq. 7); overrides the deck's DEFORMATIONS line")
    run.add_argument("--rotary-inertia", choices=("lumped", "consistent"), default=None,
                     help="the beams' section rotary inertia: lumped at the end orientation "
                          "nodes (SPACAR's, default) or consistent (linearly interpolated "
                          "angular velocity); overrides the deck's ROTARYINERTIA line")
    run.add_argument("--modes", type=_positive_int, default=None, metavar="N",
                     help="number of eigenmodes / buckling modes per linearization (default: "
                          "the deck's MODES line, else 10)")
    run.add_argument("--compliance", type=_positive_int, nargs=2, default=None,
                     metavar=("POS", "ROT"),
                     help="store the 6x6 compliance of position node POS with orientation "
                          "node ROT at the linearized steps (global and body axes)")
    run.add_argument("--modes-per-step", action="store_true",
                     help="linearize at every load step: frequencies (if the model has mass) "
                          "and buckling multipliers (if it is loaded), as SPACAR's mode 10 does")
    run.add_argument("--ignore-memory-limit", action="store_true",
                     help="run even when the memory estimate exceeds the available memory")
    run.add_argument("--ignore-conditioning-limit", action="store_true",
                     help="run even when the beams are too finely meshed for double "
                          "precision (spacarpy.solvers.statics.conditioning)")
    _user_code_options(run)
    _set_option(run)
    _verbosity(run)


def cmd_run(args) -> int:
    from spacarpy.memory import IGNORE_LIMIT
    from spacarpy.outputs import OutputLock, check_output_path, discarding

    out = args.output if args.output is not None else args.deck.with_suffix(".h5")
    out = check_output_path(out, "-o" if args.output is not None else "result file",
                            inputs=[args.deck])
    # -o /dev/null: the run writes a private temporary file, removed at the end
    with discarding(out, ".h5") as target, OutputLock(target):
        # with --ignore-memory-limit the factorizations' memory check only warns (this run)
        token = IGNORE_LIMIT.set(bool(args.ignore_memory_limit))
        try:
            return _run_locked(args, target)   # a second run on one file stops at the lock
        finally:
            IGNORE_LIMIT.reset(token)


def _run_locked(args, out) -> int:
    from spacarpy.deck.expect import load_with_expectations
    from spacarpy.outputs import check_output_path
    from spacarpy.run import RunOptions, run_model

    t0 = time.perf_counter()
    inputs = []
    from spacarpy.deck.semantics.build import BEFORE_BUILD
    from spacarpy.memory import check_memory
    # the memory estimate from the deck's element count, before the elements are made
    token = BEFORE_BUILD.set(lambda n: check_memory(n, ignore=args.ignore_memory_limit))
    try:
        job, expects = load_with_expectations(args.deck,
                                              overrides=dict(args.overrides) or None,
                                              input_files=inputs)
    finally:
        BEFORE_BUILD.reset(token)
    model = job.model
    from spacarpy.user_routines import refuse_unless_allowed
    refuse_unless_allowed(model, args.allow_user_code)     # before any work
    check_output_path(out, "-o", inputs=inputs, warn=False)   # not an INCLUDEd file
    _require_elements(model, args.deck)
    check_memory(model.n_elem, ignore=args.ignore_memory_limit)
    from spacarpy.solvers.statics.conditioning import check_conditioning
    check_conditioning(model, ignore=args.ignore_conditioning_limit)
    # the command line makes new settings; the deck's stay as they were read
    settings = job.settings.override(analysis=args.mode, deformations=args.deformations,
                                     n_modes=args.modes,
                                     modes_each_step=True if args.modes_per_step else None,
                                     rotary_inertia=args.rotary_inertia)
    if settings.analysis in ("transient", "transient_linearized", "inverse_dynamics"):
        _warn_output_size(model, settings, out)
    if settings.analysis == "check" and args.output is not None:
        log.warning("-o %s is ignored: the check analysis writes no result file",
                    args.output)
    n_elem = model.n_elem
    log.info("%s: %d position nodes, %d orientation nodes, %d elements; %s analysis, %s "
             "deformations", args.deck, model.position_ids.size, model.orientation_ids.size,
             n_elem, settings.analysis, settings.deformations)
    progress = (_ProgressBar(sys.stderr) if settings.analysis in ("transient", "inverse_dynamics")
                and not args.quiet
                and sys.stderr.isatty() else None)
    handlers = logging.getLogger().handlers if progress is not None else []
    for handler in handlers:         # a log line first clears the bar's line
        handler.addFilter(progress.clear_line)
    summary = run_model(model, settings, out, RunOptions(
        compliance_node=args.compliance, progress=progress,
        ignore_conditioning=args.ignore_conditioning_limit,
        allow_user_code=args.allow_user_code, user_modules=tuple(args.user_module)))
    if progress is not None:
        progress.close()
    for handler in handlers:
        handler.removeFilter(progress.clear_line)
    if settings.analysis == "check":
        print(summary.report)
        return EXIT_OK
    if settings.analysis in ("transient", "transient_linearized"):
        _warn_energy_error(out)
        what = ("transient analysis" if settings.analysis == "transient" else
                "transient_linearized analysis (linearized at every stored time step)")
        log.info("finished " + what + ": %d stored time steps, %d integration steps "
                 "(%d rejected by the error control), %d Newton iterations in %.2f s",
                 summary.n_time, summary.integration_steps, summary.rejected_steps,
                 summary.newton_iterations, time.perf_counter() - t0)
    elif settings.analysis == "inverse_dynamics":
        log.info("finished inverse dynamics: %d stored time steps, %d Newton iterations in "
                 "%.2f s", summary.n_time, summary.newton_iterations, time.perf_counter() - t0)
    else:
        log.info("finished %s analysis: %d steps in %.2f s", settings.analysis, summary.n_steps,
                 time.perf_counter() - t0)
    if expects:
        changed = bool(args.overrides) or args.mode is not None or \
            args.deformations is not None or args.rotary_inertia is not None
        return _check_expectations(expects, out, fatal=not changed)
    return EXIT_OK


#: A transient whose result file is estimated above this size is announced (bytes).
OUTPUT_SIZE_WARNING = 5 * 2**30
#: A transient's energy balance T + U + D - W drifting by more than this fraction of its
#: largest energy is reported with the cure (shipped decks: below 0.3 %).
ENERGY_DRIFT_WARNING = 0.05


def _step_bytes(model) -> int:
    """About the bytes one stored time step takes in the result file: positions, velocities
    and accelerations, Euler parameters and their rates, deformations and stress resultants
    of every element kind, in float64, with a little per-step overhead."""
    n_def = sum(es.def_class.shape[1] * es.n_elem for es in model.elements.values())
    values = 9 * model.position_ids.size + 12 * model.orientation_ids.size + 3 * n_def
    return 8 * values + 200


def _warn_output_size(model, settings, out) -> None:
    """Before a long transient: its result file's estimated size, when it is large or more
    than the free space where it is written (report N11: TIMESTEP 2.2 100000000)."""
    import shutil
    timestep = settings.transient.timestep
    if timestep is None:
        return
    size = (int(timestep[1]) + 1) * _step_bytes(model)
    try:
        free = shutil.disk_usage(out.parent if str(out.parent) else ".").free
    except OSError:
        free = None
    if size > OUTPUT_SIZE_WARNING or (free is not None and size > free):
        room = f", {free / 2**30:.3g} GB free there" if free is not None else ""
        log.warning("TIMESTEP %g %d stores %d time steps: the result file will be about "
                    "%.3g GB (%d bytes per step%s); fewer steps (TIMESTEP's second number) "
                    "make it smaller", timestep[0], timestep[1], timestep[1] + 1,
                    size / 2**30, _step_bytes(model), room)


def _warn_energy_error(out) -> None:
    """After a transient: a warning when its energy balance T + U + D - W (constant for an
    exact integration) drifted by more than :data:`ENERGY_DRIFT_WARNING` of its largest
    energy (report N11: TIMESTEP 2.2 2 on the pendulum, 1.69 J of 9.8 J)."""
    import numpy as np

    from spacarpy.results import open_results
    with open_results(out) as res:
        tr = res.transient
        if tr is None or tr.n_step < 2:
            return
        bal = tr.energy_balance
        scale = max(float(np.max(np.abs(e))) for e in
                    (tr.kinetic_energy, tr.elastic_energy, tr.external_work))
        drift = float(np.max(np.abs(bal - bal[0])))
    if scale > 0 and drift > ENERGY_DRIFT_WARNING * scale:
        log.warning("the energy balance T + U + D - W drifted by %.3g J, %.0f %% of the "
                    "largest energy (%.3g J): the time integration is inaccurate; use more "
                    "time steps (TIMESTEP) or a tighter error tolerance (ERROR)", drift,
                    100 * drift / scale, scale)


class _ProgressBar:
    """A one-line progress display of a transient run on a terminal: time reached, a bar and
    the estimated remaining time (redrawn at most 5 times a second)."""

    def __init__(self, stream, width: int = 30):
        self.stream, self.width = stream, width
        self.t0 = time.perf_counter()
        self.last = 0.0
        self.shown = False

    def __call__(self, t: float, t_end: float) -> None:
        now = time.perf_counter()
        if now - self.last < 0.2 and t < t_end:
            return
        self.last = now
        frac = min(max(t / t_end, 0.0), 1.0) if t_end > 0 else 1.0
        elapsed = now - self.t0
        eta = elapsed * (1 - frac) / frac if frac > 0 else float("nan")
        bar = "#" * int(round(frac * self.width))
        self.stream.write(f"\r  t = {t:.4g} / {t_end:.4g} s [{bar:<{self.width}}] "
                          f"{100 * frac:5.1f}%  remaining {eta:6.1f} s ")
        self.stream.flush()
        self.shown = True

    def clear_line(self, record=None) -> bool:
        """Blank the bar's line so that a log line starts at its beginning (a logging
        filter: lets every record through); the next update draws the bar again."""
        if self.shown:
            self.stream.write("\r" + " " * (self.width + 60) + "\r")
            self.stream.flush()
            self.shown = False
            self.last = 0.0
        return True

    def close(self) -> None:
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()


def _check_expectations(expects, out, fatal: bool = True) -> int:
    """The deck's EXPECT lines against the result file: a PASS/FAIL table on stdout; exit 4
    (:data:`spacarpy.deck.expect.EXIT_EXPECTATION`) when any fails, unless not ``fatal``
    (the command line changed the deck: --set, --mode, --deformations, --rotary-inertia),
    then a warning."""
    from spacarpy.deck.expect import EXIT_EXPECTATION, check_expectations, format_results

    expects = [e for e in expects if e.quantity != "run.exit_code"]      # for batch only
    if not expects:
        return EXIT_OK
    results = check_expectations(expects, out)
    sys.stdout.write(format_results(results))
    if all(r.passed for r in results):
        return EXIT_OK
    if not fatal:
        log.warning("expectations failed, but --set/--mode/--deformations/--rotary-inertia "
                    "changed the deck, "
                    "and the EXPECT lines belong to the deck as written: not an error")
        return EXIT_OK
    return EXIT_EXPECTATION
