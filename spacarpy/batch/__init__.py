"""Batch regression and parameter sweeps: many deck runs, isolated in worker processes.

- :mod:`~spacarpy.batch.runner` finds decks and runs one deck in a worker process, with a
  timeout (:func:`run_task`), and runs a whole batch against baselines (:func:`run_batch`);
- :mod:`~spacarpy.batch.workers` keeps the long-lived worker processes (one per job) that
  import spacarpy once (:mod:`~spacarpy.batch.serve` is their loop);
- :mod:`~spacarpy.batch.backends` executes the tasks: local processes, or a Dask cluster;
- :mod:`~spacarpy.batch.compare` compares a result file with its baseline;
- :mod:`~spacarpy.batch.report` writes the outcome as a table, JUnit XML or JSON;
- :mod:`~spacarpy.batch.sweep` runs a deck over a grid of SET parameter values and collects
  the results in one HDF5 file.

``spacarpy batch`` and ``spacarpy sweep`` (docs/batch.md) are the command-line front ends.
"""
from spacarpy.batch.compare import DatasetDiff, compare_files
from spacarpy.batch.runner import DeckOutcome, Task, TaskResult, find_decks, run_batch, run_task
from spacarpy.batch.sweep import SweepAxis, parse_sweep_axis, run_sweep

__all__ = ["DatasetDiff", "DeckOutcome", "SweepAxis", "Task", "TaskResult", "compare_files",
           "find_decks", "parse_sweep_axis", "run_batch", "run_sweep", "run_task"]
