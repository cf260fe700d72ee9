"""``spacarpy export``: XDMF or VTK files for ParaView, the state space for MATLAB."""
from __future__ import annotations

import sys
from pathlib import Path

from spacarpy.cli.common import _output_path, _positive_int, _verbosity
from spacarpy.errors import EXIT_INPUT, EXIT_OK

#: Kept equal to :data:`spacarpy.results.export.MAX_FRAMES` (a test checks), not imported:
#: the parser is built without importing the results layer.
MAX_FRAMES = 500


def add_parser(sub) -> None:
    """The ``export`` subcommand's arguments."""
    exp = sub.add_parser("export", help="files for ParaView: XDMF (.xdmf with one .xdmf.h5 "
                                        "data file) or VTK .vtu/.pvd (needs meshio)")
    exp.add_argument("file", type=Path, help="result file (.h5)")
    exp.add_argument("--xdmf", action="store_true",
                     help="write <file>.xdmf and its data <file>.xdmf.h5 (the default)")
    exp.add_argument("--vtk", action="store_true",
                     help="write <file>.pvd and one .vtu per exported step")
    exp.add_argument("--every", type=_positive_int, default=None, metavar="N",
                     help="export every N-th step and the last (default: all, or every k-th "
                          f"so that a long run has at most {MAX_FRAMES} intervals)")
    exp.add_argument("-o", "--output", type=_output_path, default=None,
                     help="name of the .xdmf or .pvd file (with only one of --xdmf, --vtk)")
    exp.add_argument("--state-space", type=_output_path, default=None, metavar="FILE.mat",
                     help="write the linearized state space A, B, C, D (SPACAR mode 9) with "
                          "its names as a MATLAB file, for ss(A, B, C, D)")
    exp.add_argument("--step", type=int, default=None,
                     help="--state-space: the static step (0 = initial state; default and -1: "
                          "the last linearized one); --xdmf, --vtk: export only this step "
                          "(an XDMF of one grid, which meshio.read reads)")
    _verbosity(exp)


def cmd_export(args) -> int:
    """``spacarpy export FILE --xdmf | --vtk | --state-space FILE.mat``: files for ParaView,
    and the state space for MATLAB."""
    from contextlib import nullcontext

    from spacarpy.errors import is_disk_full
    from spacarpy.outputs import (
        atomic_output,
        discarding,
        disk_full_error,
        refuse_special_output,
        staged_outputs,
    )
    from spacarpy.results.export import (
        check_export_output,
        write_state_space_mat,
        write_vtk,
        write_xdmf,
    )

    if args.state_space is not None:
        check_export_output(args.state_space, ".mat")
        refuse_special_output(args.state_space, "--state-space")
        with discarding(args.state_space) as target, atomic_output(target) as staged:
            write_state_space_mat(args.file, staged, step=args.step)
        print(args.state_space)
        if not (args.xdmf or args.vtk):
            return EXIT_OK
    want_xdmf = args.xdmf or not args.vtk
    steps = None if args.state_space is not None else args.step
    if args.output is not None and want_xdmf and args.vtk:
        print("export: -o names one file; give only one of --xdmf and --vtk", file=sys.stderr)
        return EXIT_INPUT
    if args.output is not None:          # before any work
        check_export_output(args.output, ".pvd" if args.vtk else ".xdmf")
        refuse_special_output(args.output, "-o")
    with discarding(args.output) if args.output is not None else nullcontext() as target:
        if want_xdmf:
            try:
                print(write_xdmf(args.file, target, every=args.every, step=steps))
            except (OSError, RuntimeError) as exc:
                if not is_disk_full(exc):
                    raise
                raise disk_full_error(target or Path(args.file).with_suffix(".xdmf"),
                                      exc) from None
        if args.vtk:
            vtk = target if target is not None else Path(args.file).with_suffix(".pvd")
            check_export_output(vtk, ".pvd")
            with staged_outputs(vtk) as staged:   # the .pvd and its .vtu: all or none
                write_vtk(args.file, staged, every=args.every, step=steps)
            print(vtk)
    return EXIT_OK
