"""Parameter sweeps: run one deck for every combination of SET parameter values, collect one file.

``spacarpy sweep DECK --set R=50:150:21 --set F=1,2`` runs the deck for every point of the
grid (the Cartesian product of the axes), each run a :class:`spacarpy.batch.runner.Task` with
``--set`` overrides, in parallel (local processes or Dask). The client collects the **last
row** of chosen datasets of every result (the final load step, or the last linearized step)
into one HDF5 file whose leading axes are the parameters (see docs/batch.md for the layout),
written point by point as the runs finish (:mod:`spacarpy.batch.sweep_file`): an interrupted
sweep keeps its finished points. Every output is checked before any point runs.
"""
from __future__ import annotations

import contextlib
import csv as csv_module
import io
import itertools
import logging
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from spacarpy.batch.runner import BatchInputError, Task, run_task
from spacarpy.batch.sweep_file import NOT_RUN, SweepFile, estimated_size

__all__ = ["DEFAULT_COLLECT", "LARGE_SWEEP", "SweepAxis", "SweepInterrupted", "SweepResult",
           "format_sweep_table", "parse_sweep_axis", "run_sweep", "write_sweep"]

log = logging.getLogger(__name__)

#: A sweep of more points than this is announced with a warning and its estimated size.
LARGE_SWEEP = 10_000

#: Datasets collected when none are named: every linearized result, the final load factor.
DEFAULT_COLLECT = ("/static/load_factor", "/eigen/frequency", "/buckling/load_multiplier",
                   "/buckling/critical_load_multiplier", "/compliance/global",
                   "/compliance/local")


@dataclass(frozen=True)
class SweepAxis:
    """One swept SET parameter: its name and its values, in order."""

    name: str
    values: tuple


def parse_sweep_axis(text: str) -> SweepAxis:
    """``name=start:stop:count`` (count equally spaced values, both ends included) or
    ``name=v1,v2,...``.

    Raises
    ------
    ValueError
        With a message naming the expected forms.
    """
    name, sep, spec = text.partition("=")
    name, spec = name.strip(), spec.strip()
    usage = (f"expected NAME=START:STOP:COUNT (e.g. ratio=-0.9:-0.1:21) or NAME=V1,V2,..., "
             f"got {text!r}")
    if not sep or not name or not spec:
        raise ValueError(usage)
    try:
        if ":" in spec:
            parts = spec.split(":")
            if len(parts) != 3:
                raise ValueError
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
            if count < 1 or not (math.isfinite(start) and math.isfinite(stop)):
                raise ValueError
            values = tuple(float(v) for v in np.linspace(start, stop, count))
        else:
            values = tuple(float(v) for v in spec.split(","))
    except ValueError:
        raise ValueError(usage) from None
    return SweepAxis(name, values)


@dataclass
class SweepResult:
    """Everything a sweep collected.

    Attributes
    ----------
    deck : str
    axes : list of SweepAxis
    data : dict
        Dataset path -> array of shape ``grid + row shape`` (NaN where a run failed or lacked
        the dataset).
    status : ndarray of int, shape ``grid``
        Exit code of each run (0 ok, -1 timeout, -2 not run: the sweep was interrupted).
    errors : ndarray of str, shape ``grid``
        The error message of each failed run ("" when it succeeded).
    """

    deck: str
    axes: list
    data: dict = field(default_factory=dict)
    status: np.ndarray | None = None
    errors: np.ndarray | None = None

    @property
    def shape(self) -> tuple:
        return tuple(len(a.values) for a in self.axes)


class SweepInterrupted(KeyboardInterrupt):
    """A sweep stopped by Ctrl-C or SIGTERM: ``result`` holds the finished points (the
    others have status -2), ``kept`` the partial sweep file (or None), ``cause`` the
    interrupt, re-raised by the command once the table is written (exit 130 or 143)."""

    def __init__(self, result, kept, cause):
        super().__init__(str(cause))
        self.result, self.kept, self.cause = result, kept, cause


def _last_rows(data: bytes, collect) -> dict:
    import h5py

    out = {}
    with h5py.File(io.BytesIO(data), "r") as f:
        for path in collect:
            if path in f and isinstance(f[path], h5py.Dataset) and f[path].shape \
                    and f[path].shape[0] > 0 and f[path].dtype.kind in "biufc":
                # complex rows (/state_space/pole) stay complex
                out[path] = np.asarray(f[path][-1], dtype=complex if f[path].dtype.kind
                                       == "c" else float)
    return out


def run_sweep(deck, axes, *, fixed=(), collect=None, jobs: int = 1,
              timeout: float | None = 600.0, run_args=(), dask: str | None = None,
              progress=None, output=None, outputs=()) -> SweepResult:
    """Run ``deck`` at every grid point of ``axes`` and collect the last rows of datasets.

    Parameters
    ----------
    deck : path-like
    axes : sequence of SweepAxis
        The swept parameters (each must be SET in the deck).
    fixed : sequence of (str, str)
        Further ``--set`` overrides, the same for every run.
    collect : sequence of str, optional
        HDF5 dataset paths to collect (default :data:`DEFAULT_COLLECT`, those present).
    jobs, timeout, run_args, dask
        As for :func:`spacarpy.batch.runner.run_batch`.
    progress : callable, optional
        ``progress(done, total, task_result)``.
    output : path-like, optional
        The sweep file, written point by point (:class:`~spacarpy.batch.sweep_file.
        SweepFile`) and moved into place when every point has run.
    outputs : sequence of (str, path-like)
        Further files the caller writes afterwards (``("--csv", path)``), checked with
        ``output`` before any point runs.

    Returns
    -------
    SweepResult

    Raises
    ------
    BatchInputError, spacarpy.outputs.OutputError, spacarpy.batch.backends.DaskError
        Before any point runs.
    SweepInterrupted
        On Ctrl-C or SIGTERM: the finished points, and the partial sweep file kept.
    """
    from spacarpy.batch.backends import check_dask_address, execute

    deck = Path(deck)
    if not deck.is_file():
        raise BatchInputError(f"sweep: no deck '{deck}'")
    axes = list(axes)
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise BatchInputError(f"sweep: a parameter is swept twice ({', '.join(names)})")
    if dask is not None:
        check_dask_address(dask)
    shape = tuple(len(a.values) for a in axes)
    n_points = math.prod(shape)
    collect = tuple(collect) if collect else DEFAULT_COLLECT
    if dask is None:
        # the local workers import spacarpy while the deck is checked here
        from spacarpy.batch.workers import close_workers, prestart
        prestart(min(max(1, jobs or 1), n_points))
    try:
        inputs = _check_parameters(deck, [(a.name, f"{a.values[0]:.17g}") for a in axes]
                                   + list(fixed))
        _check_outputs(output, outputs, inputs)
        _announce(n_points, shape, collect)
        results = execute(run_task, _tasks(deck, axes, fixed, run_args, timeout), jobs=jobs,
                          dask=dask)
        sink = SweepFile(output, deck, axes) if output is not None else None
    except BaseException:
        if dask is None:
            close_workers()
        raise
    rows: dict = {}
    status = np.full(shape, NOT_RUN, dtype=np.int32)
    errors = np.full(shape, "", dtype=object)
    done = 0
    try:
        for res in results:
            idx = tuple(int(i) for i in res.key.split(",")) if res.key else ()
            status[idx] = -1 if res.returncode is None else res.returncode
            if res.status != "ok":
                errors[idx] = res.message
            if res.data is not None:
                rows[idx] = _last_rows(res.data, collect)
            if sink is not None:
                sink.add(idx, int(status[idx]), errors[idx], rows.get(idx, {}))
            done += 1
            if progress is not None:
                progress(done, n_points, res)
    except KeyboardInterrupt as exc:
        close = getattr(results, "close", None)
        if close is not None:
            close()                     # cancel the rest, end the workers
        kept = None
        if sink is not None:
            what = "terminated (SIGTERM)" if type(exc).__name__ == "Terminated" \
                else "interrupted"
            kept = sink.abort(f"{what} after {done} of {n_points} points")
        raise SweepInterrupted(_result(deck, axes, collect, rows, status, errors), kept,
                               exc) from None
    except Exception:                   # the sweep file could not be written (a full disk)
        close = getattr(results, "close", None)
        if close is not None:
            close()
        if sink is not None:
            with contextlib.suppress(Exception):
                sink.abort(f"stopped after {done} of {n_points} points")
        raise
    if sink is not None:
        sink.finish()
    return _result(deck, axes, collect, rows, status, errors)


def _tasks(deck: Path, axes, fixed, run_args, timeout) -> list:
    shape = tuple(len(a.values) for a in axes)
    tasks = []
    for idx in itertools.product(*(range(n) for n in shape)):
        over = tuple(fixed) + tuple((a.name, f"{a.values[i]:.17g}") for a, i in zip(axes, idx))
        tasks.append(Task(",".join(map(str, idx)), str(deck.resolve()), over, tuple(run_args),
                          timeout))
    return tasks


def _result(deck, axes, collect, rows, status, errors) -> SweepResult:
    shape = tuple(len(a.values) for a in axes)
    result = SweepResult(str(deck), axes, status=status, errors=errors)
    for path in collect:
        tails = [r[path].shape for r in rows.values() if path in r]
        if not tails:
            continue
        kind = next(r[path].dtype for r in rows.values() if path in r)
        arr = np.full(shape + tails[0], np.nan, dtype=kind)
        for idx, r in rows.items():
            if path in r and r[path].shape == tails[0]:
                arr[idx] = r[path]
        result.data[path] = arr
    return result


def _check_outputs(output, outputs, inputs) -> None:
    """The sweep file (and its partial file) and the caller's other files: writable, not a
    directory or device, not the deck or one of its INCLUDE files (symlinks resolved)."""
    from spacarpy.outputs import check_output_path
    from spacarpy.results.h5file import partial_path_for

    if output is not None:
        check_output_path(output, "-o", inputs=inputs)
        check_output_path(partial_path_for(output), "-o (its partial file)", inputs=inputs,
                          warn=False)
    for what, path in outputs:
        if path is not None:
            check_output_path(path, what, inputs=inputs)


def _announce(n_points: int, shape: tuple, collect) -> None:
    """Say how many points the sweep has; warn when that is very many, with the size."""
    grid = " x ".join(map(str, shape))
    if n_points > LARGE_SWEEP:
        size = estimated_size(n_points, max(len(collect), 1))
        log.warning("sweep: %d points (%s): a very large sweep; the sweep file will take "
                    "at least %.1f MB (more for vector datasets such as frequencies), and "
                    "Ctrl-C keeps the finished points", n_points, grid, size / 1e6)
    else:
        log.info("sweep: %d point%s (%s)", n_points, "s" * (n_points != 1), grid)


def _check_parameters(deck: Path, overrides) -> list[str]:
    """Refuse, before any point runs, a ``--set`` name the deck does not SET; return the
    deck's input files (the deck and its INCLUDEs), which no output may overwrite.

    The deck is parsed once with the first grid point's overrides; only the parser's
    "no 'SET name' line" errors stop the sweep (they name the parameter and the deck's SET
    names). Any other deck error is left to the runs, which report it per point.
    """
    from spacarpy.deck.parser import parse_deck
    from spacarpy.deck.textfile import read_deck_text
    from spacarpy.errors import DeckError

    try:
        statements = parse_deck(read_deck_text(deck), str(deck), overrides=dict(overrides))
    except DeckError as exc:
        unknown = [msg for _, msg, *_ in exc.items if msg.startswith("--set ")]
        if unknown:
            raise BatchInputError("sweep: " + "; ".join(unknown)) from None
        return [str(deck)]
    return [str(deck)] + list(dict.fromkeys(st.file for st in statements
                                            if st.file is not None and st.file != str(deck)))


def write_sweep(result: SweepResult, out) -> Path:
    """Write a whole sweep to one HDF5 file (the layout of :mod:`spacarpy.batch.sweep_file`,
    which :func:`run_sweep` writes point by point as the runs finish)."""
    sink = SweepFile(out, result.deck, result.axes)
    try:
        for idx in itertools.product(*(range(n) for n in result.shape)):
            if result.status[idx] == NOT_RUN:
                continue
            rows = {path: arr[idx] for path, arr in result.data.items()}
            sink.add(idx, int(result.status[idx]), str(result.errors[idx] or ""), rows)
    except BaseException:
        sink.abort("not all points written")
        raise
    return sink.finish()


def _columns(result: SweepResult, n_values: int = 3):
    """(header, array over grid) pairs for the table: scalars, and the first values of
    vector datasets."""
    cols = []
    for path, arr in result.data.items():
        tail = arr.shape[len(result.shape):]
        short = path.rsplit("/", 1)[-1]
        if not tail:
            cols.append((short, arr))
        elif len(tail) == 1:
            for k in range(min(n_values, tail[0])):
                cols.append((f"{short}[{k + 1}]", arr[..., k]))
    return cols


def format_sweep_table(result: SweepResult, n_values: int = 3, csv: bool = False) -> str:
    """One row per grid point: the parameter values, then each collected scalar and the first
    ``n_values`` values of each collected vector (e.g. frequency[1..3]); ``csv`` for CSV.
    The points an interrupted sweep did not run are counted below the table (and are rows
    with status ``not run`` in the CSV)."""
    cols = _columns(result, n_values)
    head = [a.name for a in result.axes] + [c for c, _ in cols] + ["status"]
    rows = []
    for idx in itertools.product(*(range(n) for n in result.shape)):
        row = [f"{a.values[i]:.10g}" for a, i in zip(result.axes, idx)]
        row += [f"{arr[idx]:.10g}" for _, arr in cols]
        row.append("ok" if result.status[idx] == 0 else
                   "timeout" if result.status[idx] == -1 else
                   "not run" if result.status[idx] == NOT_RUN else f"exit {result.status[idx]}")
        rows.append(row)
    reasons = [failure_reason(str(result.errors[idx])) if result.status[idx] not in
               (0, NOT_RUN) and result.errors is not None else ""
               for idx in itertools.product(*(range(n) for n in result.shape))]
    if csv:
        buf = io.StringIO()
        writer = csv_module.writer(buf, lineterminator="\n")
        writer.writerow(head + ["error"])
        writer.writerows(r + [why] for r, why in zip(rows, reasons))
        return buf.getvalue()
    n_not_run = sum(r[-1] == "not run" for r in rows)
    if n_not_run:                       # an interrupted sweep: its finished points only
        rows = [r for r in rows if r[-1] != "not run"]
    widths = [max([len(h)] + [len(r[k]) for r in rows]) for k, h in enumerate(head)]
    fmt = "  ".join(f"{{:>{w}}}" for w in widths)
    text = "\n".join(fmt.format(*r) for r in [head] + rows) + "\n"
    if n_not_run:
        text += (f"{n_not_run} of {len(reasons)} points not run (the sweep was "
                 "interrupted)\n")
    failed = [(r, why) for r, why in zip(rows, reasons) if why]
    if failed:
        text += "failed runs:\n" + "".join(
            "  " + ", ".join(f"{a.name}={v}" for a, v in zip(result.axes, r)) +
            f": {r[-1]}: {why}\n" for r, why in failed)
    return text


def failure_reason(message: str) -> str:
    """The reason of a failed run in one line: the first ``error:`` line of its message (the
    message is the tail of the run's stderr, after ``exit code N:``), else its last line."""
    message = re.sub(r"^exit code -?\d+: ", "", message.strip())
    lines = [ln.strip() for ln in message.splitlines() if ln.strip()]
    for ln in lines:
        if "error:" in ln or ln.startswith("error"):
            return ln
    return lines[-1] if lines else "no message"
