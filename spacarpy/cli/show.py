"""``spacarpy show``: the summary of a result file."""
from __future__ import annotations

import sys
from pathlib import Path

from spacarpy.cli.common import _verbosity
from spacarpy.errors import EXIT_OK


def add_parser(sub) -> None:
    """The ``show`` subcommand's arguments."""
    show = sub.add_parser("show", help="summary of a result file: steps, convergence, "
                                       "extremes, frequencies, buckling multipliers")
    show.add_argument("file", type=Path, help="result file (.h5)")
    _verbosity(show)


def cmd_show(args) -> int:
    """``spacarpy show FILE``: the summary of :func:`spacarpy.results.summary.summary`."""
    from spacarpy.results import open_results
    from spacarpy.results.summary import summary

    sweep = _sweep_summary(args.file)
    if sweep is not None:
        sys.stdout.write(sweep)
        return EXIT_OK
    with open_results(args.file) as res:
        sys.stdout.write(summary(res))
    return EXIT_OK


def _sweep_summary(path) -> str | None:
    """The summary of a ``spacarpy sweep`` file (``filetype = "spacarpy-sweep"``): its deck,
    the swept parameters, the points that ran or failed, and the table ``sweep`` printed;
    None for any other file (read as a results file)."""
    import h5py
    import numpy as np

    from spacarpy.results.h5file import open_for_reading, python_value
    try:
        with open_for_reading(path) as f:
            if python_value(f.attrs.get("filetype")) != "spacarpy-sweep":
                return None
            from spacarpy.batch.sweep import SweepAxis, SweepResult, format_sweep_table
            names = [str(python_value(n)) for n in np.atleast_1d(f.attrs["parameters"])]
            axes = [SweepAxis(n, tuple(np.asarray(f[f"parameters/{n}"][()]).tolist()))
                    for n in names]
            data = {}

            def collect(name, obj):
                if hasattr(obj, "shape") and not name.startswith(("parameters/", "sweep/")) \
                        and name != "deck" and not h5py.h5ds.is_scale(obj.id):   # 3.0 axes
                    data["/" + name] = obj[()]
            f.visititems(collect)
            status = np.asarray(f["sweep/status"][()])
            errors = np.asarray([python_value(e) for e in f["sweep/error"][()].ravel()],
                                dtype=object).reshape(status.shape)
            deck = str(python_value(f.attrs.get("deck_path", "")))
    except KeyError as exc:
        from spacarpy.results.h5file import damaged
        raise damaged(path, f"a sweep file without {exc}") from None
    result = SweepResult(deck, axes, data, status, errors.astype(str))
    n_ok, n_not_run = int(np.sum(status == 0)), int(np.sum(status == -2))
    n_failed = status.size - n_ok - n_not_run      # -2: not run (an interrupted sweep)
    lines = [f"{path}",
             f"  sweep      of {deck}",
             "  parameters " + ", ".join(f"{a.name} ({len(a.values)} values, "
                                         f"{min(a.values):.6g} .. {max(a.values):.6g})"
                                         for a in axes),
             f"  points     {status.size}: {n_ok} ran, {n_failed} failed"
             + (f", {n_not_run} not run (interrupted)" if n_not_run else ""),
             "  collected  " + (", ".join(data) or "nothing"), ""]
    return "\n".join(lines) + "\n" + format_sweep_table(result)
