"""``spacarpy plot``: a figure or an animation of a result file."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from spacarpy.cli.common import (
    _dof,
    _output_path,
    _positive_float,
    _positive_int,
    _selection,
    _verbosity,
)
from spacarpy.errors import EXIT_OK


def add_parser(sub, vocabularies: bool = True) -> None:
    """The ``plot`` subcommand's arguments. ``vocabularies``: False when another
    subcommand is being parsed; plot is then listed with its help but without its
    (imported) list of plot kinds."""
    if vocabularies:
        from spacarpy.results.plot import PLOTS
    else:
        PLOTS = {}

    plot = sub.add_parser("plot", help="draw a figure (PNG, PDF or SVG; needs matplotlib)",
                          formatter_class=argparse.RawDescriptionHelpFormatter,
                          epilog="plots:\n" + "\n".join(f"  {k:<18} {v}"
                                                       for k, v in PLOTS.items()))
    plot.add_argument("file", type=Path, help="result file (.h5); root-locus: a sweep file")
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
                           "scale); mode: amplitude of the mode shape (default: its largest "
                           "displacement 15%% of the model size or its largest rotation "
                           "0.5 rad, whichever is smaller)")
    plot.add_argument("--x", dest="x_axis", choices=("auto", "prescribed", "load-factor"),
                      default="auto",
                      help="frequency, buckling, load-displacement: the load axis: the "
                           "quantity the run prescribes (a DELINPE angle in mrad, a DELXF "
                           "force in N), or the load factor (default auto: the prescribed "
                           "quantity where there is one)")
    plot.add_argument("--fps", type=_positive_float, default=20.0,
                      help="animate: frames per second (default 20)")
    plot.add_argument("--frames", type=_positive_int, default=200,
                      help="animate: at most this many frames, spread over the steps "
                           "(default 200)")
    plot.add_argument("--view", type=float, nargs=2, default=None, metavar=("ELEV", "AZIM"),
                      help="shape, mode: camera elevation and azimuth in degrees for a 3-D "
                           "model (default 30 -60; a planar model is drawn in 2-D)")
    plot.add_argument("-o", "--output", type=_output_path, default=None,
                      help="image file; the suffix picks the format: .png, .pdf, .svg; "
                           "animate: .gif, .mp4 (default: <file>_<kind>.png, .gif)")
    _verbosity(plot)


def cmd_plot(args) -> int:
    """``spacarpy plot FILE [KIND]``: an image file."""
    from spacarpy.outputs import atomic_output, discarding, refuse_special_output
    from spacarpy.results import open_results
    from spacarpy.results.plot import animate, make_figure, save
    from spacarpy.results.plot_base import ANIMATION_SUFFIXES, IMAGE_SUFFIXES, check_output

    animation = args.kind == "animate"
    out = args.output or args.file.with_name(
        f"{args.file.stem}_{args.kind}{'.gif' if animation else '.png'}")
    out = check_output(out, ANIMATION_SUFFIXES if animation else IMAGE_SUFFIXES,
                       f"plot {args.kind}")          # before any work
    refuse_special_output(out, "-o")
    if args.kind == "root-locus":            # a sweep file, not a run's result file
        from spacarpy.results.plot_sweep import root_locus_figure
        fig = root_locus_figure(args.file)
        with discarding(out) as target, atomic_output(target) as staged:
            save(fig, staged)
        print(out)
        return EXIT_OK
    step = "all" if args.all_steps else args.step
    with open_results(args.file) as res, discarding(out) as target, \
            atomic_output(target) as staged:      # whole or not at all (a full disk)
        if animation:
            bar = None if args.quiet else _FrameProgress(sys.stderr)
            try:
                animate(res, staged, fps=args.fps, max_frames=args.frames, scale=args.scale,
                        view=args.view, progress=bar)
            finally:
                if bar is not None:
                    bar.close()
        else:
            fig = make_figure(res, args.kind, node=args.node, element=args.element,
                              step=step, mode=args.mode, quantity=args.quantity,
                              scale=args.scale, view=args.view, time=args.time,
                              x=args.x_axis, dof=args.dof)
            save(fig, staged)
    print(out)
    return EXIT_OK


class _FrameProgress:
    """Progress of ``plot animate`` on stderr: on a terminal one line redrawn (frames done, a
    bar, the time left, at most 5 times a second); otherwise a line at every 10 %."""

    def __init__(self, stream, width: int = 30):
        self.stream, self.width = stream, width
        self.tty = bool(getattr(stream, "isatty", lambda: False)())
        self.t0 = time.perf_counter()
        self.last, self.shown, self.tenth = 0.0, False, -1

    def __call__(self, done: int, total: int) -> None:
        now = time.perf_counter()
        frac = done / total if total else 1.0
        elapsed = now - self.t0
        eta = elapsed * (1 - frac) / frac if frac > 0 else float("nan")
        bar = "#" * int(round(frac * self.width))
        text = (f"animate: frame {done}/{total} [{bar:<{self.width}}] {100 * frac:5.1f}%  "
                f"remaining {eta:5.1f} s")
        if self.tty:
            if now - self.last < 0.2 and done < total:
                return
            self.last = now
            self.stream.write("\r" + text + " ")
            self.shown = True
        else:
            tenth = int(10 * frac)
            if tenth == self.tenth:
                return
            self.tenth = tenth
            self.stream.write(f"animate: frame {done}/{total} ({100 * frac:.0f}%), "
                              f"{elapsed:.1f} s\n")
        self.stream.flush()

    def close(self) -> None:
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()
