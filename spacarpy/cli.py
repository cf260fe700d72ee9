"""Command line: ``spacarpy run | check | bench | validate | show | extract | plot | export |
batch | sweep``.

Exit codes (see :mod:`spacarpy.errors`): 0 success, 1 solver failure, 2 input error (deck or
command line), 3 model not analysable (mechanism, over-constraint), 4 (``run``) an EXPECT line
of the deck failed, 130 interrupted (Ctrl-C), 143 terminated (SIGTERM); ``batch``/``sweep``:
1 when a deck changed or failed.
Progress goes to stderr, silenced by ``-q``; errors are printed without a traceback.

The module is longer than 600 lines because it holds the argument parser of all ten
subcommands and one short handler each; the work itself is in the modules they call.
"""
from __future__ import annotations

import argparse
import functools
import logging
import os
import signal
import sys
import time
from pathlib import Path

from spacarpy import __version__
from spacarpy.errors import (
    EXIT_INPUT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_SOLVER,
    EXIT_TERMINATED,
    SpacarError,
    Terminated,
)

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


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}")
    return value


def _output_path(text: str) -> Path:
    """An output file name: not empty (``-o ""`` would mean the current directory)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("the output file name is empty")
    return Path(text)


def _parse_set(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    name, value = name.strip(), value.strip()
    if not sep or not name or not value:
        raise argparse.ArgumentTypeError(
            f"expected NAME=VALUE (for example R=100 or EI=1e7/12), got {text!r}")
    return name, value


def _set_option(p):
    p.add_argument("--set", dest="overrides", metavar="NAME=VALUE", type=_parse_set,
                   action="append", default=[],
                   help="override the deck's 'SET NAME ...' line (a number or an expression; "
                        "repeat for several parameters)")


#: spacarpy.bench.CASES and its DECK_CASES (spelled out: the parser does not import bench).
_BENCH_CASES = ("cantilever", "bend", "eigen", "transient", "arclength", "spinup", "pendulum",
                "sweep")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of every subcommand. ``command``: the subcommand about to be
    parsed, when known; the result-file subcommands then skip importing the plot and table
    vocabularies (only their names and help are needed), which keeps ``spacarpy run``'s
    start-up free of the plotting modules."""
    p = argparse.ArgumentParser(
        prog="spacarpy",
        description="Large-deflection analysis of flexible multibody systems and slender "
                    "structures with the DDM beam (SPACAR-style decks).")
    p.add_argument("--version", action="version", version=f"spacarpy {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

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
                          "every time step); a negative SPACAR "
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
                          "precision (spacarpy.solvers.conditioning)")
    _set_option(run)
    _verbosity(run)

    check = sub.add_parser("check", help="parse and validate a deck without solving it, and "
                                         "print a summary")
    check.add_argument("deck", type=Path, help="SPACAR-style deck (.dat)")
    _set_option(check)
    _verbosity(check)

    bench = sub.add_parser("bench", help="time the solvers on cantilevers and a bend of "
                                         "growing size (optionally beside Exudyn)")
    bench.add_argument("--cases", nargs="+", choices=_BENCH_CASES, default=list(_BENCH_CASES),
                       help="which cases (default: all eight; pendulum and sweep time whole "
                            "processes on shipped decks)")
    bench.add_argument("--sizes", type=int, nargs="+", default=None,
                       help="numbers of elements for every case (default: 10 100 1000 10000; "
                            "transient 10 100)")
    bench.add_argument("--case-sizes", action="append", default=[], metavar="CASE=N,N,...",
                       help="numbers of elements for one case (repeatable; overrides "
                            "--sizes for it), e.g. cantilever=1000,10000,100000")
    bench.add_argument("--steps", type=int, default=10, help="static load steps (default 10)")
    bench.add_argument("--transient-steps", type=int, default=1000,
                       help="time steps of the transient case (default 1000)")
    bench.add_argument("--spinup-t-end", type=float, default=30.0, metavar="SECONDS",
                       help="end time of the spinup case (default 30 s)")
    bench.add_argument("--repeat", type=int, default=3,
                       help="repetitions per size; min and median are shown (default 3)")
    bench.add_argument("--peer", choices=["exudyn"], default=None,
                       help="solve the same problems with a peer code in the same run "
                            "(pip install 'spacarpy[bench]')")
    bench.add_argument("--markdown", metavar="FILE", default=None,
                       help="also write the tables as Markdown (docs/performance.md)")
    _verbosity(bench)
    _results_commands(sub, vocabularies=command is None or command in _VOCABULARY_COMMANDS)
    _batch_commands(sub)
    return p


#: Subcommands whose arguments list the plot kinds or the extractable quantities.
_VOCABULARY_COMMANDS = frozenset({"extract", "plot"})


@functools.lru_cache(maxsize=2)
def _parser(vocabularies: bool) -> argparse.ArgumentParser:
    """:func:`build_parser`'s parser, built once per process (argparse parsers are reusable):
    building it makes about 110 help formatters, each asking for the terminal's size, 11 ms
    that a batch or sweep worker would pay again for every deck it runs."""
    return build_parser(None if vocabularies else "run")


def _command_name(argv: list[str] | None) -> str | None:
    """The subcommand named on the command line (the first word that is not an option), or
    None when there is none; only a hint for :func:`build_parser`."""
    words = sys.argv[1:] if argv is None else argv
    for word in words:
        if not word.startswith("-"):
            return word
    return None


class UsageError(SpacarError):
    """A command-line value that argparse cannot check by itself (exit 2)."""

    exit_code = EXIT_INPUT


def _bench_sizes(args):
    """--sizes and --case-sizes as run_bench's ``sizes`` (a list, a dict per case or None)."""
    for n in list(args.sizes or []) + [args.steps, args.repeat, args.transient_steps]:
        if n < 1:
            raise UsageError(f"spacarpy bench: sizes, --steps, --repeat and --transient-steps "
                             f"must be positive whole numbers, not {n}")
    if not args.case_sizes:
        return args.sizes
    from spacarpy.bench import CASES, DEFAULT_SIZES
    out = {c: (args.sizes or DEFAULT_SIZES[c]) for c in CASES}
    for item in args.case_sizes:
        case, _, values = item.partition("=")
        try:
            if case not in CASES:
                raise ValueError
            out[case] = [int(v) for v in values.split(",") if v.strip()]
            if not out[case] or min(out[case]) < 1:
                raise ValueError
        except ValueError:
            raise UsageError(f"spacarpy bench: --case-sizes {item!r}: expected CASE=N,N,... "
                             f"with CASE one of {', '.join(CASES)}") from None
    return out


def _nonnegative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return value


def _sweep_set(text: str):
    """``NAME=START:STOP:COUNT`` or ``NAME=V1,V2,...`` (an axis), or ``NAME=VALUE`` (fixed)."""
    from spacarpy.batch.sweep import parse_sweep_axis
    name, _, value = text.partition("=")
    if ":" in value or "," in value:
        try:
            return parse_sweep_axis(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return _parse_set(text)


def _execution_options(p) -> None:
    p.add_argument("-j", "--jobs", type=_positive_int, default=None, metavar="N",
                   help="runs at the same time (default: the number of CPUs); with --dask "
                        "local, the number of workers")
    p.add_argument("--timeout", type=_nonnegative_float, default=600.0, metavar="S",
                   help="seconds per run before its process is killed (default 600)")
    p.add_argument("--dask", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster: a scheduler address (tcp://host:8786) or "
                        "'local' for a LocalCluster on this machine (needs dask[distributed])")
    p.add_argument("--run-args", default="", metavar="'OPTIONS'",
                   help="more 'spacarpy run' options for every run, in one quoted string "
                        "(e.g. '--modes-per-step --modes 4')")


def _batch_commands(sub) -> None:
    """Subcommands that run many decks (batch, sweep): docs/batch.md."""
    bat = sub.add_parser("batch", help="run many decks in parallel and compare the results "
                                       "with baselines (regression test)")
    bat.add_argument("paths", nargs="+", metavar="PATH",
                     help="deck files, directories (searched recursively for .dat) or globs")
    bat.add_argument("--baseline", type=Path, default=None, metavar="DIR",
                     help="baseline result files: DIR/<relative deck path>.h5")
    bat.add_argument("--update-baseline", action="store_true",
                     help="write every finished result as its baseline in --baseline DIR")
    bat.add_argument("--rtol", type=_nonnegative_float, default=1e-6,
                     help="relative tolerance of the comparison (default 1e-6)")
    bat.add_argument("--atol", type=_nonnegative_float, default=1e-9,
                     help="absolute tolerance of the comparison (default 1e-9)")
    bat.add_argument("--report", type=Path, action="append", default=[], metavar="FILE",
                     help="also write a report: .xml JUnit, .json JSON, other: the table "
                          "(repeatable)")
    bat.add_argument("--output-dir", type=Path, default=None, metavar="DIR",
                     help="keep the result files there (default: not kept)")
    _execution_options(bat)
    _verbosity(bat)

    swp = sub.add_parser("sweep", help="run a deck for every combination of SET parameter "
                                       "values and collect one HDF5 file and a table")
    swp.add_argument("deck", type=Path, help="SPACAR-style deck (.dat) with SET parameters")
    swp.add_argument("--set", dest="sweep_sets", metavar="NAME=START:STOP:COUNT",
                     type=_sweep_set, action="append", default=[], required=True,
                     help="a swept parameter (COUNT equally spaced values, or V1,V2,...), or "
                          "NAME=VALUE for a fixed override; repeat for a grid")
    swp.add_argument("-o", "--output", type=Path, default=None,
                     help="sweep file (default: <deck>_sweep.h5)")
    swp.add_argument("--collect", action="append", default=[], metavar="PATH",
                     help="dataset to collect, e.g. /eigen/frequency (repeatable; default: "
                          "load factor, frequencies, buckling multipliers, compliances)")
    swp.add_argument("--csv", type=Path, default=None, metavar="FILE",
                     help="also write the table as CSV")
    swp.add_argument("--columns", type=_positive_int, default=3, metavar="N",
                     help="values of each vector shown in the table (default 3)")
    _execution_options(swp)
    _verbosity(swp)


def _results_commands(sub, vocabularies: bool = True) -> None:
    """Subcommands that read a result file (validate, show, extract, plot, export).
    ``vocabularies``: False when another subcommand is being parsed; extract and plot are
    then listed with their help but without their (imported) lists of choices."""
    if vocabularies:
        from spacarpy.results.plot import PLOTS
        from spacarpy.results.tables import QUANTITIES
    else:
        PLOTS = QUANTITIES = {}

    val = sub.add_parser("validate", help="check a result file against the schema "
                                          "(docs/results.md)")
    val.add_argument("file", type=Path, help="result file (.h5)")
    val.add_argument("--require-complete", action="store_true",
                     help="also fail for a run that did not finish (a partial file)")
    _verbosity(val)

    show = sub.add_parser("show", help="summary of a result file: steps, convergence, "
                                       "extremes, frequencies, buckling multipliers")
    show.add_argument("file", type=Path, help="result file (.h5)")
    _verbosity(show)

    ext = sub.add_parser("extract", help="one quantity as a table (text, CSV or JSON) for "
                                         "scripts and spreadsheets",
                         formatter_class=argparse.RawDescriptionHelpFormatter,
                         epilog="quantities:\n" + "\n".join(
                             f"  {k:<21} {v}" for k, v in QUANTITIES.items()))
    ext.add_argument("file", type=Path, help="result file (.h5)")
    ext.add_argument("what", choices=list(QUANTITIES), metavar="WHAT",
                     help="quantity to extract (listed below)")
    _selection(ext)
    _dof(ext)
    fmt = ext.add_mutually_exclusive_group()
    fmt.add_argument("--csv", dest="format", action="store_const", const="csv",
                     help="comma-separated values with a header line")
    fmt.add_argument("--json", dest="format", action="store_const", const="json",
                     help="a JSON object with columns, units and data")
    ext.add_argument("-o", "--output", type=_output_path, default=None,
                     help="write to this file instead of standard output")
    _verbosity(ext)

    plot = sub.add_parser("plot", help="draw a figure (PNG, PDF or SVG; needs matplotlib)",
                          formatter_class=argparse.RawDescriptionHelpFormatter,
                          epilog="plots:\n" + "\n".join(f"  {k:<18} {v}"
                                                       for k, v in PLOTS.items()))
    plot.add_argument("file", type=Path, help="result file (.h5)")
    plot.add_argument("kind", choices=list(PLOTS), metavar="KIND", nargs="?", default="shape",
                      help="what to draw (default: shape; listed below)")
    _selection(plot)
    _dof(plot)
    plot.add_argument("--all-steps", action="store_true",
                      help="shape: draw every step, not only --step (default: the last)")
    plot.add_argument("--quantity", default="displacement",
                      help="history: the quantity (default: displacement)")
    plot.add_argument("--time", type=float, nargs="+", default=None, metavar="T",
                      help="shape: draw the stored time steps of /transient nearest to these "
                           "times (s)")
    plot.add_argument("--scale", type=float, default=None,
                      help="shape, animate: displacement magnification (default: automatic "
                           "when the displacements are small, stated in the legend; 1 = true "
                           "scale); mode: amplitude of the mode shape (default: 15%% of the "
                           "model size)")
    plot.add_argument("--x", dest="x_axis", choices=("auto", "prescribed", "load-factor"),
                      default="auto",
                      help="frequency, buckling, load-displacement: the load axis: the "
                           "quantity the run prescribes (a DELINPE angle in mrad, a DELXF "
                           "force in N), or the load factor (default auto: the prescribed "
                           "quantity where there is one)")
    plot.add_argument("--fps", type=float, default=20.0,
                      help="animate: frames per second (default 20)")
    plot.add_argument("--frames", type=_positive_int, default=200,
                      help="animate: at most this many frames, spread over the steps "
                           "(default 200)")
    plot.add_argument("--view", type=float, nargs=2, default=None, metavar=("ELEV", "AZIM"),
                      help="shape, mode: camera elevation and azimuth in degrees (default "
                           "30 -60)")
    plot.add_argument("-o", "--output", type=_output_path, default=None,
                      help="image file; the suffix picks the format: .png, .pdf, .svg; "
                           "animate: .gif, .mp4 (default: <file>_<kind>.png, .gif)")
    _verbosity(plot)

    exp = sub.add_parser("export", help="files for ParaView: an XDMF sidecar (reads the "
                                        "HDF5 directly) or VTK .vtu/.pvd (needs meshio)")
    exp.add_argument("file", type=Path, help="result file (.h5)")
    exp.add_argument("--xdmf", action="store_true", help="write <file>.xdmf (the default)")
    exp.add_argument("--vtk", action="store_true",
                     help="write <file>.pvd and one .vtu per step")
    exp.add_argument("-o", "--output", type=_output_path, default=None,
                     help="name of the .xdmf or .pvd file (with only one of --xdmf, --vtk)")
    exp.add_argument("--state-space", type=_output_path, default=None, metavar="FILE.mat",
                     help="write the linearized state space A, B, C, D (SPACAR mode 9) with "
                          "its names as a MATLAB file, for ss(A, B, C, D)")
    exp.add_argument("--step", type=int, default=None,
                     help="--state-space: the static step (0 = initial state; default and -1: "
                          "the last linearized one)")
    _verbosity(exp)


def _selection(p) -> None:
    p.add_argument("--node", type=int, default=None, help="deck node number")
    p.add_argument("--element", type=int, default=None, help="deck element number")
    p.add_argument("--step", type=int, default=None,
                   help="static step (0 = initial state; -1 = the last)")
    p.add_argument("--mode", type=_positive_int, default=None,
                   help="mode number (1 = the first)")


def _dof(p) -> None:
    p.add_argument("--dof", choices=("x", "y", "z"), default=None,
                   help="path: the displacement component of --node (default: the one that "
                        "moves most)")


def _verbosity(p):
    p.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    p.add_argument("-v", "--verbose", action="store_true", help="solver details")


def _single_blas_thread() -> None:
    """One BLAS thread unless the user says otherwise (OPENBLAS_NUM_THREADS etc. override).

    spacarpy's dense work is many small matrices (6x6 element blocks, small reductions) and
    sparse factorizations, where a multithreaded BLAS spends more time synchronising than
    computing; batch runs and sweeps use one process per core anyway. Set here rather than
    on ``import spacarpy``, since a library must not change its host's environment; it takes
    effect only because nothing imported so far by this module has imported numpy.
    """
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")


def _on_sigterm(signum, frame):
    signal.signal(signal.SIGTERM, signal.SIG_DFL)     # a second SIGTERM ends it at once
    raise Terminated("terminated by SIGTERM")


def _terminate_like_interrupt():
    """SIGTERM (job schedulers, ``kill``) ends a command the way Ctrl-C does: the result file
    is closed with ``error`` set and without its SWMR mark, then exit 143. Only in the main
    thread (``signal`` allows no other), and not where SIGTERM is ignored (``nohup``-like).
    Returns the previous handler (restored when :func:`main` returns), or None."""
    import threading
    if threading.current_thread() is not threading.main_thread():
        return None
    previous = signal.getsignal(signal.SIGTERM)
    if previous is signal.SIG_IGN:
        return None
    signal.signal(signal.SIGTERM, _on_sigterm)
    return previous


def console() -> None:
    """The ``spacarpy`` command (console script and ``python -m spacarpy``): :func:`main`,
    then :func:`exit_process` with its exit code.

    For the commands that analyse in this process and in its main thread only (``run``,
    ``check``), numpy's submodules that no analysis uses are made lazy first
    (:mod:`spacarpy.lazy_imports`), after the BLAS thread count is set: that import of numpy
    is the process's first. (Not for ``batch`` and ``sweep``, whose Dask backend has threads:
    Python 3.11's lazy modules are not safe to load from two threads at once.)"""
    if _command_name(None) in _LAZY_NUMPY_COMMANDS:
        from spacarpy.lazy_imports import defer_numpy_submodules
        _single_blas_thread()
        defer_numpy_submodules()
    exit_process(main())


#: The commands for which :func:`console` makes numpy's unused submodules lazy.
_LAZY_NUMPY_COMMANDS = ("run", "check")


def exit_process(code: int) -> None:
    """End the process with exit code ``code``, without the interpreter's teardown.

    After numpy, scipy and h5py are imported, Python's finalization (tearing down every
    module and collecting every object once more) takes 60-100 ms of CPU on the 2-core
    machine: more than the whole solve of a small model, and 15 % of the 8-element Table 1
    deck's run. Nothing spacarpy writes needs it: every result file and export is closed
    before :func:`main` returns. The exit handlers (the batch workers, logging, h5py) still
    run and the standard streams are flushed; then ``os._exit``. Only for a process that
    ends here: :func:`main` itself (tests, the batch workers' loop) returns normally."""
    import atexit
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):   # a closed pipe (``spacarpy ... | head``)
            pass
    os._exit(int(code or 0))


def main(argv: list[str] | None = None) -> int:
    _single_blas_thread()
    command = _command_name(argv)
    parser = _parser(command is None or command in _VOCABULARY_COMMANDS)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:           # argparse: 2 for usage errors, 0 for --help
        return int(exc.code or 0)
    from spacarpy.memory import keep_freed_memory
    keep_freed_memory()                 # large models: reuse freed memory (spacarpy.memory)
    previous = _terminate_like_interrupt()
    try:
        return _main(args)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


#: Libraries whose debug/info lines (h5py's "Creating converter from 5 to 3") -v hides.
_QUIET_LIBRARIES = ("h5py", "matplotlib", "PIL")


def _main(args) -> int:
    if getattr(getattr(args, "mode", None), "silent", False):
        args.quiet = True               # a negative SPACAR mode number: SPACAR's silent run
    level = logging.WARNING if args.quiet else (logging.DEBUG if args.verbose else logging.INFO)
    logging.basicConfig(level=level, format="%(message)s", stream=sys.stderr, force=True)
    for name in _QUIET_LIBRARIES:    # -v shows spacarpy's debug lines, not the libraries'
        logging.getLogger(name).setLevel(logging.WARNING)
    try:
        if args.command == "run":
            return cmd_run(args)
        if args.command == "check":
            return cmd_check(args)
        if args.command == "bench":
            from spacarpy.bench import run_bench
            sizes = _bench_sizes(args)
            if args.markdown is not None:
                from spacarpy.outputs import check_output_path
                check_output_path(args.markdown, "--markdown")
            run_bench(cases=args.cases, sizes=sizes, n_steps=args.steps,
                      repeat=args.repeat, transient_steps=args.transient_steps,
                      peer=args.peer, markdown=args.markdown,
                      spinup_t_end=args.spinup_t_end)
            return EXIT_OK
        if args.command in _RESULT_COMMANDS:
            from spacarpy.results.h5file import reading
            with reading(args.file):        # a damaged file: a message and exit 2
                return _RESULT_COMMANDS[args.command](args)
        if args.command in ("batch", "sweep"):
            return cmd_batch(args) if args.command == "batch" else cmd_sweep(args)
    except SpacarError as exc:
        print(_printable(_capped(exc)), file=sys.stderr)
        return exc.exit_code
    except MemoryError:
        # past the estimate of spacarpy.memory (a factorization's fill, another process's
        # memory): a message, never a traceback; a result file keeps its completed steps
        print("error: out of memory: the analysis needed more memory than the system could "
              "give (see docs/performance.md, 'Memory estimate before a run')",
              file=sys.stderr)
        return EXIT_SOLVER
    except Terminated:
        print("terminated (SIGTERM)", file=sys.stderr)
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_INPUT


#: Deck errors printed at most; the rest are counted.
MAX_PRINTED_ERRORS = 50


def _capped(exc: SpacarError) -> str:
    """The message of ``exc``; of a DeckError with many items only the first
    :data:`MAX_PRINTED_ERRORS`, then ``... and N more errors``."""
    from spacarpy.errors import DeckError
    items = getattr(exc, "items", None)
    if not isinstance(exc, DeckError) or len(items) <= MAX_PRINTED_ERRORS:
        return str(exc)
    head = str(DeckError(items[:MAX_PRINTED_ERRORS])).rsplit("\n", 1)[0]   # no "50 errors"
    return (f"{head}\n... and {len(items) - MAX_PRINTED_ERRORS} more errors "
            f"({len(items)} errors)")


def _printable(text: str) -> str:
    """``text`` with control characters (other than newline and tab) escaped as ``\\xNN``,
    so that a message quoting a binary or damaged input never drives the terminal."""
    return "".join(c if c.isprintable() or c in "\n\t" else
                   (f"\\x{ord(c):02x}" if ord(c) < 256 else f"\\u{ord(c):04x}")
                   for c in text)


def cmd_check(args) -> int:
    """``spacarpy check DECK``: the summary on stdout; exit 0 if the deck is valid and
    supported, 2 otherwise (syntax errors, semantic errors, features not supported yet)."""
    from spacarpy.deck import check_deck
    from spacarpy.errors import DeckError
    from spacarpy.memory import memory_line

    summary = check_deck(args.deck, overrides=dict(args.overrides) or None)
    if summary.model is not None:
        try:
            _require_elements(summary.model, args.deck)
        except DeckError as exc:
            summary.errors.extend(exc.items)
    text = summary.format()
    if summary.model is not None and summary.model.n_elem:
        lines = text.split("\n")      # the estimate above the final "OK" line
        lines.insert(len(lines) - 1,
                     f"  {'memory estimate':<20}{memory_line(summary.model.n_elem)}")
        text = "\n".join(lines)
    print(text)
    return EXIT_OK if summary.ok else EXIT_INPUT


def _require_elements(model, deck) -> None:
    """An empty deck (an empty file, ``END END``, /dev/null) is an input error, not a model
    with 0 degrees of freedom."""
    from spacarpy.errors import DeckError
    if model.n_elem == 0:
        what = "no elements" if model.position_ids.size else "no nodes and no elements"
        raise DeckError((None, f"{deck}: the deck defines {what}; nothing to analyse"))


def cmd_run(args) -> int:
    from spacarpy.outputs import OutputLock, check_output_path

    out = args.output if args.output is not None else args.deck.with_suffix(".h5")
    out = check_output_path(out, "-o" if args.output is not None else "result file",
                            inputs=[args.deck])
    with OutputLock(out):       # a second run on the same file stops here, before any work
        return _run_locked(args, out)


def _run_locked(args, out) -> int:
    from spacarpy.deck.expect import load_with_expectations
    from spacarpy.outputs import check_output_path
    from spacarpy.run import RunOptions, run_model

    t0 = time.perf_counter()
    inputs = []
    job, expects = load_with_expectations(args.deck, overrides=dict(args.overrides) or None,
                                          input_files=inputs)
    check_output_path(out, "-o", inputs=inputs, warn=False)   # not an INCLUDEd file
    model = job.model
    _require_elements(model, args.deck)
    from spacarpy.memory import check_memory
    check_memory(model.n_elem, ignore=args.ignore_memory_limit)
    from spacarpy.solvers.conditioning import check_conditioning
    check_conditioning(model, ignore=args.ignore_conditioning_limit)
    # the command line makes new settings; the deck's stay as they were read
    settings = job.settings.override(analysis=args.mode, deformations=args.deformations,
                                     n_modes=args.modes,
                                     modes_each_step=True if args.modes_per_step else None,
                                     rotary_inertia=args.rotary_inertia)
    n_elem = model.n_elem
    log.info("%s: %d position nodes, %d orientation nodes, %d elements; %s analysis, %s "
             "deformations", args.deck, model.position_ids.size, model.orientation_ids.size,
             n_elem, settings.analysis, settings.deformations)
    progress = (_ProgressBar(sys.stderr) if settings.analysis == "transient" and not args.quiet
                and sys.stderr.isatty() else None)
    handlers = logging.getLogger().handlers if progress is not None else []
    for handler in handlers:         # a log line first clears the bar's line
        handler.addFilter(progress.clear_line)
    summary = run_model(model, settings, out, RunOptions(
        compliance_node=args.compliance, progress=progress,
        ignore_conditioning=args.ignore_conditioning_limit))
    if progress is not None:
        progress.close()
    for handler in handlers:
        handler.removeFilter(progress.clear_line)
    if settings.analysis == "check":
        print(summary.report)
        return EXIT_OK
    if settings.analysis == "transient":
        log.info("finished transient analysis: %d stored time steps, %d integration steps "
                 "(%d rejected by the error control), %d Newton iterations in %.2f s",
                 summary.n_time, summary.integration_steps, summary.rejected_steps,
                 summary.newton_iterations, time.perf_counter() - t0)
    else:
        log.info("finished %s analysis: %d steps in %.2f s", settings.analysis, summary.n_steps,
                 time.perf_counter() - t0)
    if expects:
        changed = bool(args.overrides) or args.mode is not None or \
            args.deformations is not None or args.rotary_inertia is not None
        return _check_expectations(expects, out, fatal=not changed)
    return EXIT_OK


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


def cmd_validate(args) -> int:
    """``spacarpy validate FILE``: 0 if the file follows the schema (a consistent partial file
    does, unless ``--require-complete``), 2 with one line per problem otherwise."""
    from spacarpy.results import validate_file

    problems = validate_file(args.file, require_complete=args.require_complete)
    if problems:
        print(f"{args.file}: INVALID ({len(problems)} problem{'s' * (len(problems) > 1)})")
        for p in problems:
            print(f"  {p}")
        return EXIT_INPUT
    from spacarpy.results import open_results
    res = open_results(args.file)
    version = ".".join(map(str, res.schema_version))
    state = "completed run" if res.completed else (
        "incomplete run: " + (res.error or "the writer did not finish (killed, or still "
                                           "running)"))
    print(f"{args.file}: valid spacarpy results file, schema {version}, {state}")
    return EXIT_OK


def cmd_show(args) -> int:
    """``spacarpy show FILE``: the summary of :func:`spacarpy.results.tables.summary`."""
    from spacarpy.results import open_results
    from spacarpy.results.tables import summary

    with open_results(args.file) as res:
        sys.stdout.write(summary(res))
    return EXIT_OK


def cmd_extract(args) -> int:
    """``spacarpy extract FILE WHAT``: a table as text, CSV or JSON."""
    from spacarpy.outputs import check_output_path
    from spacarpy.results import open_results
    from spacarpy.results.tables import extract

    if args.output is not None:
        check_output_path(args.output, "-o", inputs=[args.file])
    with open_results(args.file) as res:
        table = extract(res, args.what, node=args.node, element=args.element, step=args.step,
                        mode=args.mode, dof=args.dof)
    text = {"csv": table.to_csv, "json": table.to_json}.get(args.format, table.to_text)()
    if args.output is not None:
        args.output.write_text(text, encoding="utf-8")
        log.info("%s written", args.output)
    else:
        sys.stdout.write(text)
    return EXIT_OK


def cmd_plot(args) -> int:
    """``spacarpy plot FILE [KIND]``: an image file."""
    from spacarpy.results import open_results
    from spacarpy.results.plot import animate, make_figure, save
    from spacarpy.results.plot_base import ANIMATION_SUFFIXES, IMAGE_SUFFIXES, check_output

    animation = args.kind == "animate"
    out = args.output or args.file.with_name(
        f"{args.file.stem}_{args.kind}{'.gif' if animation else '.png'}")
    out = check_output(out, ANIMATION_SUFFIXES if animation else IMAGE_SUFFIXES,
                       f"plot {args.kind}")          # before any work
    step = "all" if args.all_steps else args.step
    with open_results(args.file) as res:
        if animation:
            animate(res, out, fps=args.fps, max_frames=args.frames, scale=args.scale,
                    view=args.view)
        else:
            fig = make_figure(res, args.kind, node=args.node, element=args.element,
                              step=step, mode=args.mode, quantity=args.quantity,
                              scale=args.scale, view=args.view, time=args.time,
                              x=args.x_axis, dof=args.dof)
            save(fig, out)
    print(out)
    return EXIT_OK


def cmd_export(args) -> int:
    """``spacarpy export FILE --xdmf | --vtk | --state-space FILE.mat``: files for ParaView,
    and the state space for MATLAB."""
    from spacarpy.results.export import (
        check_export_output,
        write_state_space_mat,
        write_vtk,
        write_xdmf,
    )

    if args.state_space is not None:
        check_export_output(args.state_space, ".mat")
        print(write_state_space_mat(args.file, args.state_space, step=args.step))
        if not (args.xdmf or args.vtk):
            return EXIT_OK
    want_xdmf = args.xdmf or not args.vtk
    if args.output is not None and want_xdmf and args.vtk:
        print("export: -o names one file; give only one of --xdmf and --vtk", file=sys.stderr)
        return EXIT_INPUT
    if args.output is not None:          # before any work
        check_export_output(args.output, ".pvd" if args.vtk else ".xdmf")
    if want_xdmf:
        print(write_xdmf(args.file, args.output))
    if args.vtk:
        print(write_vtk(args.file, args.output))
    return EXIT_OK


class _Progress:
    """A live ``[done/total]`` line on stderr when it is a terminal (and not -q)."""

    def __init__(self, quiet: bool):
        self.live = not quiet and sys.stderr.isatty()
        self.failed = 0

    def __call__(self, done, total, item):
        status = getattr(item, "status", "")
        self.failed += status in ("failed", "changed", "error", "timeout", "expect")
        if self.live:
            name = getattr(item, "name", None) or getattr(item, "key", "")
            sys.stderr.write(f"\r\x1b[K[{done}/{total}] {self.failed} not passing; last: "
                             f"{name} {status}")
            if done == total:
                sys.stderr.write("\n")
            sys.stderr.flush()


def _jobs(args) -> int:
    import os
    return args.jobs or os.cpu_count() or 1


def cmd_batch(args) -> int:
    """``spacarpy batch PATH...``: the table on stdout, reports; exit 1 when a deck changed or
    failed, 0 otherwise (new decks without a baseline do not fail the batch)."""
    import shlex

    from spacarpy.batch.report import format_table, write_report
    from spacarpy.batch.runner import run_batch

    if args.update_baseline and args.baseline is None:
        print("batch: --update-baseline needs --baseline DIR", file=sys.stderr)
        return EXIT_INPUT
    outcomes = run_batch(args.paths, baseline=args.baseline, jobs=_jobs(args), rtol=args.rtol,
                         atol=args.atol, timeout=args.timeout or None,
                         update_baseline=args.update_baseline, output_dir=args.output_dir,
                         run_args=shlex.split(args.run_args), dask=args.dask,
                         progress=_Progress(args.quiet))
    sys.stdout.write(format_table(outcomes))
    for path in args.report:
        log.info("%s written", write_report(outcomes, path))
    bad = any(o.status in ("changed", "failed") for o in outcomes)
    return 1 if bad else EXIT_OK


def cmd_sweep(args) -> int:
    """``spacarpy sweep DECK --set NAME=START:STOP:COUNT ...``: one HDF5 file and a table on
    stdout; exit 1 when any run failed."""
    import shlex

    from spacarpy.batch.sweep import SweepAxis, format_sweep_table, run_sweep, write_sweep

    axes = [s for s in args.sweep_sets if isinstance(s, SweepAxis)]
    fixed = [s for s in args.sweep_sets if not isinstance(s, SweepAxis)]
    if not axes:
        print("sweep: give at least one swept parameter, --set NAME=START:STOP:COUNT",
              file=sys.stderr)
        return EXIT_INPUT
    result = run_sweep(args.deck, axes, fixed=fixed, collect=args.collect or None,
                       jobs=_jobs(args), timeout=args.timeout or None,
                       run_args=shlex.split(args.run_args), dask=args.dask,
                       progress=_Progress(args.quiet))
    out = args.output or args.deck.with_name(args.deck.stem + "_sweep.h5")
    write_sweep(result, out)
    sys.stdout.write(format_sweep_table(result, args.columns))
    if args.csv is not None:
        args.csv.write_text(format_sweep_table(result, args.columns, csv=True),
                            encoding="utf-8")
    n_bad = int((result.status != 0).sum())
    log.info("%s written: %d runs, %d failed", out, result.status.size, n_bad)
    return 1 if n_bad else EXIT_OK


_RESULT_COMMANDS = {"validate": cmd_validate, "show": cmd_show, "extract": cmd_extract,
                    "plot": cmd_plot, "export": cmd_export}


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
