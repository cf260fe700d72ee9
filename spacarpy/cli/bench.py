"""``spacarpy bench``: its arguments (the cases, the sizes per case) and the call of the
benchmark (:mod:`spacarpy.bench`)."""
from __future__ import annotations

from spacarpy.cli.common import UsageError, _positive_float, _verbosity
from spacarpy.errors import EXIT_OK, EXIT_SOLVER

#: spacarpy.bench.decks.CASES and its DECK_CASES (spelled out: the parser does not import bench).
_BENCH_CASES = ("cantilever", "bend", "eigen", "transient", "arclength", "spinup", "lattice",
                "pendulum", "sweep")


def add_parser(sub) -> None:
    """The ``bench`` subcommand's arguments."""
    bench = sub.add_parser("bench", help="time the solvers on cantilevers and a bend of "
                                         "growing size (optionally beside Exudyn)")
    bench.add_argument("--cases", nargs="+", choices=_BENCH_CASES, default=list(_BENCH_CASES),
                       help="which cases (default: all nine; pendulum and sweep time whole "
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
    bench.add_argument("--spinup-t-end", type=_positive_float, default=30.0, metavar="SECONDS",
                       help="end time of the spinup case (default 30 s)")
    bench.add_argument("--repeat", type=int, default=3,
                       help="repetitions per size; min and median are shown (default 3)")
    bench.add_argument("--peer", choices=["exudyn", "opensees"], default=None,
                       help="solve the same problems with a peer code in the same run: "
                            "exudyn (every case but arclength) or opensees (the lattice) "
                            "(pip install 'spacarpy[bench]')")
    bench.add_argument("--peer-limit", type=_positive_float, default=None, metavar="SECONDS",
                       help="stop Exudyn's own lattice solve after this many seconds and "
                            "show its time as a lower bound (default 900; the answer comes "
                            "from Exudyn's equations solved with PARDISO either way)")
    bench.add_argument("--markdown", metavar="FILE", default=None,
                       help="also write the tables as Markdown (docs/performance.md)")
    _verbosity(bench)


def _bench_sizes(args):
    """--sizes and --case-sizes as run_bench's ``sizes`` (a list, a dict per case or None)."""
    for n in list(args.sizes or []) + [args.steps, args.repeat, args.transient_steps]:
        if n < 1:
            raise UsageError(f"spacarpy bench: sizes, --steps, --repeat and --transient-steps "
                             f"must be positive whole numbers, not {n}")
    if not args.case_sizes:
        return args.sizes
    from spacarpy.bench.decks import CASES, DEFAULT_SIZES
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


def cmd_bench(args) -> int:
    """``spacarpy bench``: the tables of :func:`spacarpy.bench.runner.run_bench`."""
    from spacarpy.bench.runner import run_bench
    sizes = _bench_sizes(args)
    if args.markdown is not None:
        from spacarpy.outputs import check_output_path, is_null_device
        check_output_path(args.markdown, "--markdown")
        if is_null_device(args.markdown):      # discarded: the tables are not written
            args.markdown = None
    results = run_bench(cases=args.cases, sizes=sizes, n_steps=args.steps,
                        repeat=args.repeat, transient_steps=args.transient_steps,
                        peer=args.peer, markdown=args.markdown,
                        spinup_t_end=args.spinup_t_end, peer_limit=args.peer_limit)
    from spacarpy.bench.runner import failed_rows
    failed = failed_rows(results)
    if failed:
        import sys
        print(f"bench: {len(failed)} case(s) failed: "
              + "; ".join(f"{r.get('case')} {r.get('n') or ''}".strip() for r in failed),
              file=sys.stderr)
        return EXIT_SOLVER
    return EXIT_OK
