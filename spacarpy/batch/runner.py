"""Run decks in child processes with a timeout, and a whole batch against baselines.

One deck run is one :class:`Task`. :func:`run_task` runs ``python -m spacarpy run`` in a
fresh child process and a temporary directory, so a crash, a hang (killed at the timeout) or
an exhausted memory cannot take the batch down; it returns the result file as bytes, so that
the client (possibly on another machine, with Dask) writes every file. :func:`run_batch` finds
the decks, runs them through a backend (:mod:`spacarpy.batch.backends`) and compares each
result with its baseline (:mod:`spacarpy.batch.compare`); a damaged baseline fails its deck
only, and an interrupted batch still hands back the decks that finished.
"""
from __future__ import annotations

import glob
import io
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from spacarpy.errors import EXIT_INPUT, DeckError, SpacarError

__all__ = ["BatchInputError", "BatchInterrupted", "DeckOutcome", "baseline_problem",
           "check_batch_outputs", "Task", "TaskResult", "find_decks", "run_batch",
           "run_task"]

#: Exit code of a run whose EXPECT lines failed (spacarpy.deck.expect.EXIT_EXPECTATION).
_EXIT_EXPECTATION = 4


class BatchInputError(SpacarError):
    """A batch argument names no deck, or a baseline directory is missing."""

    exit_code = EXIT_INPUT


@dataclass(frozen=True)
class Task:
    """One deck run.

    Attributes
    ----------
    key : str
        Identifies the run in the results (a relative deck path, or a sweep point).
    deck : str
        Absolute path of the deck.
    overrides : tuple of (str, str)
        ``--set NAME=VALUE`` pairs.
    args : tuple of str
        More ``spacarpy run`` options (``--modes-per-step``, ``--modes 3``, ...).
    timeout : float or None
        Seconds before the child process is killed.
    """

    key: str
    deck: str
    overrides: tuple = ()
    args: tuple = ()
    timeout: float | None = None


@dataclass
class TaskResult:
    """What a run gave back.

    Attributes
    ----------
    key : str
    status : str
        ``"ok"``; ``"xfail"`` (failed with the exit code its ``EXPECT run.exit_code`` line
        names); ``"expect"`` (finished, but an EXPECT line failed); ``"error"`` (non-zero
        exit); ``"timeout"`` (killed).
    returncode : int or None
    message : str
        The error message (last lines of stderr), or the failed expectations.
    seconds : float
    data : bytes or None
        The HDF5 result file, when the run finished.
    stdout : str
    """

    key: str
    status: str
    returncode: int | None
    message: str
    seconds: float
    data: bytes | None = None
    stdout: str = ""


def _expected_exit_code(deck: str, overrides) -> int | None:
    """The value of the deck's ``EXPECT run.exit_code`` line, if any (None if unreadable)."""
    from spacarpy.deck.expect import expectations
    from spacarpy.deck.parser import parse_deck
    from spacarpy.deck.textfile import read_deck_text

    try:
        statements = parse_deck(read_deck_text(deck), deck, overrides=dict(overrides) or None)
        for ex in expectations(statements):
            if ex.quantity == "run.exit_code":
                return int(round(ex.value))
    except (DeckError, ValueError):
        return None
    return None


@dataclass(frozen=True)
class _Answer:
    """A worker's answer, shaped like ``subprocess.CompletedProcess``."""

    rc: int
    stdout: str
    stderr: str

    @property
    def returncode(self) -> int:
        return self.rc


def _tail(text: str, n: int = 6) -> str:
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    return "\n".join(lines[-n:])


def run_task(task: Task) -> TaskResult:
    """Run one deck (``spacarpy run``) in a worker process and collect its result.

    The worker (:mod:`spacarpy.batch.workers`) is this thread's long-lived child process,
    which has imported spacarpy already; a run that hangs is killed at the timeout, and a
    crashed or killed worker is replaced for the next task.

    Parameters
    ----------
    task : Task

    Returns
    -------
    TaskResult
        Never raises for a failing deck: errors, timeouts and failed expectations are
        statuses.
    """
    from spacarpy.batch.workers import WorkerDied, worker

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="spacarpy-batch-") as tmp:
        out = Path(tmp) / "result.h5"
        argv = ["run", task.deck, "-o", str(out), "-q", *task.args]
        for name, value in task.overrides:
            argv += ["--set", f"{name}={value}"]
        w = worker()
        try:
            proc = _Answer(**w.call(argv, tmp, task.timeout))
        except WorkerDied as exc:
            if w.timed_out:
                return TaskResult(task.key, "timeout", None,
                                  f"timed out after {task.timeout:g} s (killed)",
                                  time.perf_counter() - t0)
            return TaskResult(task.key, "error", None, f"the run crashed: {exc}",
                              time.perf_counter() - t0)
        seconds = time.perf_counter() - t0
        data = out.read_bytes() if out.exists() else None
        rc = proc.returncode
        if rc == 0:
            return TaskResult(task.key, "ok", rc, "", seconds, data, proc.stdout)
        if rc == _EXIT_EXPECTATION:
            fails = [ln for ln in proc.stdout.splitlines() if ln.startswith("FAIL")]
            return TaskResult(task.key, "expect", rc, "\n".join(fails) or _tail(proc.stdout),
                              seconds, data, proc.stdout)
        expected = _expected_exit_code(task.deck, task.overrides)
        message = _tail(proc.stderr) or f"exit code {rc}"
        if expected is not None and rc == expected:
            return TaskResult(task.key, "xfail", rc, f"failed as its EXPECT run.exit_code "
                              f"{expected} line requires: {message.splitlines()[-1]}",
                              seconds, None, proc.stdout)
        return TaskResult(task.key, "error", rc, f"exit code {rc}: {message}", seconds, None,
                          proc.stdout)


def find_decks(paths) -> list[tuple[Path, str]]:
    """The decks named by files, directories (searched recursively for ``*.dat``) and globs.

    Returns
    -------
    list of (Path, str)
        Absolute deck path and its relative name (the baseline key): relative to the
        directory argument, else the file name. Sorted by relative name, without duplicates.

    Raises
    ------
    BatchInputError
        If an argument matches nothing.
    """
    found: dict[str, Path] = {}
    for arg in paths:
        arg = str(arg)
        p = Path(arg)
        if p.is_dir():
            hits = [(d, d.relative_to(p).as_posix()) for d in sorted(p.rglob("*.dat"))]
        elif p.is_file():
            hits = [(p, p.name)]
        else:
            hits = [(Path(g), Path(g).name) for g in sorted(glob.glob(arg, recursive=True))
                    if Path(g).is_file()]
        if not hits:
            raise BatchInputError(f"batch: '{arg}' names no deck (a .dat file, a directory "
                                  "holding .dat files, or a glob)")
        for deck, rel in hits:
            found.setdefault(rel, deck.resolve())
    return sorted(((d, r) for r, d in found.items()), key=lambda x: x[1])


@dataclass
class DeckOutcome:
    """The verdict on one deck of a batch.

    Attributes
    ----------
    name : str
        Relative deck path (the baseline key).
    status : str
        ``"pass"``, ``"changed"``, ``"failed"``, ``"new"`` (no baseline) or ``"not run"``
        (the batch was interrupted first).
    message : str
    seconds : float
    diffs : list of DatasetDiff
        For ``"changed"``.
    """

    name: str
    status: str
    message: str = ""
    seconds: float = 0.0
    diffs: list = field(default_factory=list)


def _verdict(res: TaskResult, baseline: Path | None, rtol, atol) -> DeckOutcome:
    from spacarpy.batch.compare import compare_files, load_tolerances

    if res.status == "xfail":
        return DeckOutcome(res.key, "pass", res.message, res.seconds)
    if res.status != "ok":
        what = {"expect": "expectation failed", "timeout": "timeout"}.get(res.status, "error")
        return DeckOutcome(res.key, "failed", f"{what}: {res.message}", res.seconds)
    if baseline is None or not baseline.exists():
        return DeckOutcome(res.key, "new", "no baseline", res.seconds)
    tol_file = baseline.with_suffix(".tol.json")
    try:
        tolerances = load_tolerances(tol_file) if tol_file.exists() else None
    except ValueError as exc:
        return DeckOutcome(res.key, "failed", f"baseline tolerances: {exc}", res.seconds)
    problem = baseline_problem(baseline)
    if problem is None:
        from spacarpy.results.h5file import ResultsFormatError, reading
        try:
            with reading(baseline):
                diffs = compare_files(io.BytesIO(res.data), baseline, rtol=rtol, atol=atol,
                                      tolerances=tolerances)
        except ResultsFormatError as exc:
            problem = _reason_of(exc, baseline)
    if problem is not None:
        return DeckOutcome(res.key, "failed", f"damaged baseline: {problem} ({baseline})",
                           res.seconds)
    if diffs:
        worst = max(diffs, key=lambda d: d.rel_diff)
        msg = (f"{len(diffs)} dataset{'s' * (len(diffs) > 1)} changed "
               f"({', '.join(d.path for d in diffs)}); worst {worst.message}")
        return DeckOutcome(res.key, "changed", msg, res.seconds, diffs)
    return DeckOutcome(res.key, "pass", "", res.seconds)


def _reason_of(exc, path) -> str:
    text = str(exc)
    for prefix in (f"{os.fspath(path)}: ", "damaged results file: "):
        text = text.removeprefix(prefix)
    return text.replace("\n", " ")


def baseline_problem(path) -> str | None:
    """Why the baseline file ``path`` cannot be compared with (None when it can): read
    through the integrity layer every command uses (:mod:`spacarpy.results.h5file`): a
    truncated, non-HDF5 (a Git LFS pointer ...), foreign or schema-violating file."""
    from spacarpy.results.h5file import ResultsFormatError, open_for_reading
    from spacarpy.results.validate import check_readable

    try:
        with open_for_reading(path) as f:
            check_readable(f, os.fspath(path))
    except ResultsFormatError as exc:
        return _reason_of(exc, path)
    return None


class BatchInterrupted(KeyboardInterrupt):
    """A batch stopped by Ctrl-C or SIGTERM: ``outcomes`` holds every deck, those that did
    not finish as ``"not run"``; ``cause`` is the interrupt (re-raised once the table and
    reports are written, for exit code 130 or 143)."""

    def __init__(self, outcomes, cause):
        super().__init__(str(cause))
        self.outcomes, self.cause = outcomes, cause


def check_batch_outputs(baseline=None, update_baseline: bool = False,
                        output_dir=None) -> None:
    """Refuse, before any deck runs, an output directory that cannot be written
    (:func:`spacarpy.outputs.check_output_dir`): ``--output-dir`` and, with
    ``--update-baseline``, ``--baseline``."""
    from spacarpy.outputs import check_output_dir

    if output_dir is not None:
        check_output_dir(output_dir, "--output-dir")
    if baseline is not None and update_baseline:
        check_output_dir(baseline, "--baseline")


def _keep(data: bytes, root: Path, key: str, what: str) -> None:
    """Write a result under ``root`` (its subdirectories made as needed), atomically."""
    from spacarpy.outputs import OutputError, write_atomically

    dst = root / Path(key).with_suffix(".h5")
    try:
        dst.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{what}: cannot create {dst.parent}: "
                          f"{exc.strerror or exc}") from None
    write_atomically(dst, data)


def run_batch(paths, *, baseline: str | os.PathLike | None = None, jobs: int = 1,
              rtol: float = 1e-6, atol: float = 1e-9, timeout: float | None = 600.0,
              update_baseline: bool = False, output_dir=None, run_args=(),
              dask: str | None = None, progress=None) -> list[DeckOutcome]:
    """Run every deck found in ``paths`` and compare the results with the baselines.

    Parameters
    ----------
    paths : sequence of path-like or str
        Deck files, directories (recursive) and globs.
    baseline : path-like, optional
        Directory of baseline result files: ``<baseline>/<relative deck path>.h5``.
    jobs : int
        Decks run at the same time.
    rtol, atol : float
        Comparison tolerances (see :func:`spacarpy.batch.compare.compare_files`).
    timeout : float or None
        Seconds per deck before its process is killed.
    update_baseline : bool
        Write each finished run's result as its new baseline (the verdict is still
        computed against the old one).
    output_dir : path-like, optional
        Also keep every result file there, under its relative path.
    run_args : sequence of str
        More ``spacarpy run`` options for every deck.
    dask : str, optional
        Run on Dask (see :func:`spacarpy.batch.backends.execute`).
    progress : callable, optional
        ``progress(done, total, outcome)`` after each deck.

    Returns
    -------
    list of DeckOutcome
        Sorted by deck name.

    Raises
    ------
    BatchInputError, spacarpy.outputs.OutputError
        Before any deck runs: no deck, no baseline directory, an output directory that
        cannot be written.
    BatchInterrupted
        On Ctrl-C or SIGTERM, with the outcomes of the decks that finished.
    """
    from spacarpy.batch.backends import execute
    from spacarpy.outputs import OutputError

    decks = find_decks(paths)
    base = Path(baseline) if baseline is not None else None
    if base is not None and not base.is_dir() and not update_baseline:
        raise BatchInputError(f"batch: the baseline directory '{base}' does not exist (use "
                              "--update-baseline to create it)")
    check_batch_outputs(base, update_baseline, output_dir)
    tasks = [Task(rel, str(deck), args=tuple(run_args), timeout=timeout) for deck, rel in decks]
    outcomes = []
    results = execute(run_task, tasks, jobs=jobs, dask=dask)
    try:
        for res in results:
            target = base / Path(res.key).with_suffix(".h5") if base is not None else None
            outcome = _verdict(res, target, rtol, atol)
            if res.data is not None:
                try:
                    if output_dir is not None:
                        _keep(res.data, Path(output_dir), res.key, "--output-dir")
                    if update_baseline and target is not None and res.status == "ok":
                        _keep(res.data, base, res.key, "--baseline")
                        outcome.message = (outcome.message + "; " if outcome.message
                                           else "") + "baseline written"
                except OutputError as exc:       # e.g. the disk filled up: this deck only
                    outcome.status = "failed"
                    outcome.message = (outcome.message + "; " if outcome.message
                                       else "") + str(exc)
            outcomes.append(outcome)
            if progress is not None:
                progress(len(outcomes), len(tasks), outcome)
    except KeyboardInterrupt as exc:
        close = getattr(results, "close", None)
        if close is not None:
            close()                     # cancel the rest, end the workers
        done = {o.name for o in outcomes}
        outcomes += [DeckOutcome(t.key, "not run", "interrupted before it finished")
                     for t in tasks if t.key not in done]
        raise BatchInterrupted(sorted(outcomes, key=lambda o: o.name), exc) from None
    return sorted(outcomes, key=lambda o: o.name)
