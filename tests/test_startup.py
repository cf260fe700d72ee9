"""Start-up of issue 20: ``spacarpy run`` imports only what the analysis needs, the compiled
grammars are cached between processes, and batch/sweep runs reuse worker processes.

The import guard asserts on ``sys.modules`` of a real ``spacarpy run`` in a fresh process, not
on time, so it holds on any machine and under any load.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DECK = ROOT / "decks" / "table1_cantilever_8el_modified.dat"

#: Modules a static ``spacarpy run`` must not import (plotting, Dask, the batch machinery, the
#: peers, scipy submodules a static solve does not use).
NOT_FOR_RUN = ("matplotlib", "dask", "distributed", "exudyn", "openseespy", "meshio",
               "scipy.signal",
               "scipy.io", "scipy.optimize", "scipy.integrate", "scipy.interpolate",
               "spacarpy.batch", "spacarpy.bench",
               "spacarpy.results.plot", "spacarpy.results.plot_base",
               "spacarpy.results.plot_shapes", "spacarpy.results.plot_geometry",
               "spacarpy.results.export",
               "spacarpy.results.tables", "spacarpy.results.summary",
               # the readers and the validator: a run writes its file, its EXPECT lines
               # read it with h5py
               "spacarpy.results.reader", "spacarpy.results.eager",
               "spacarpy.results.views", "spacarpy.results.validate",
               # the linearized analyses of run.py's branches a static run does not take
               "spacarpy.solvers.linear.buckling", "spacarpy.solvers.linear.compliance",
               "spacarpy.solvers.linear.state_space", "spacarpy.solvers.dynamics.trajectory",
               "spacarpy.solvers.dynamics.transient",
               # ldconfig's search for the C library (spacarpy.memory loads libc.so.6)
               "ctypes.util")

_RUN_AND_LIST = """
import json, sys
from spacarpy.cli import main
rc = main(sys.argv[1:])
print(json.dumps({"rc": rc, "modules": sorted(sys.modules)}))
"""


def _run_in_fresh_process(args, env=None) -> dict:
    proc = subprocess.run([sys.executable, "-c", _RUN_AND_LIST, *args], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _cache_env(tmp_path) -> dict:
    return dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "cache"),
                PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))


def test_spacarpy_run_imports_no_plotting_batch_peers_or_unused_scipy(tmp_path):
    got = _run_in_fresh_process(["run", str(DECK), "-q", "-o", str(tmp_path / "t.h5")],
                                env=_cache_env(tmp_path))
    assert got["rc"] == 0
    loaded = set(got["modules"])
    bad = sorted(m for m in loaded for banned in NOT_FOR_RUN
                 if m == banned or m.startswith(banned + "."))
    assert not bad, f"spacarpy run imported {bad}"
    # the guard is not vacuous: the run did load what a static solve needs
    assert {"spacarpy.run", "spacarpy.solvers.statics.static", "h5py",
            "spacarpy.deck.parser"} <= loaded


def test_plot_and_extract_still_list_their_choices(capsys):
    from spacarpy.cli.main import build_parser, main
    assert main(["plot", "--help"]) == 0
    assert "load-displacement" in capsys.readouterr().out
    assert main(["extract", "--help"]) == 0
    assert "strain_energy" in capsys.readouterr().out
    # a run's parser lists the result subcommands without importing their vocabularies
    assert "extract" in build_parser("run").format_help()


def test_compiled_grammars_are_cached_and_parse_as_a_fresh_compile(tmp_path, monkeypatch):
    from lark import Lark

    from spacarpy import grammars

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    grammar = ROOT / "spacarpy" / "expr.lark"
    options = {"propagate_positions": True, "maybe_placeholders": False}
    first = grammars.lalr_parser(grammar, **options)        # compiled, then saved
    files = list((tmp_path / "spacarpy").glob("expr-*.lark"))
    assert len(files) == 1
    cached = grammars.lalr_parser(grammar, **options)       # loaded from the file
    fresh = Lark(grammar.read_text(), parser="lalr", **options)
    text = "2*sin(pi/4) - x + (1e-3)"
    assert cached.parse(text) == fresh.parse(text) == first.parse(text)
    tree = cached.parse("1 + 2*x")
    assert tree.meta.column == 1 and tree.meta.end_column == 8    # positions kept
    # other options: another file; a damaged file is ignored and replaced
    grammars.lalr_parser(grammar, propagate_positions=False, maybe_placeholders=False)
    assert len(list((tmp_path / "spacarpy").glob("expr-*.lark"))) == 2
    files[0].write_bytes(b"not a parser")
    again = grammars.lalr_parser(grammar, **options)
    assert again.parse(text) == fresh.parse(text)
    assert files[0].read_bytes() != b"not a parser"


def test_unwritable_cache_still_gives_the_parser(tmp_path, monkeypatch):
    from spacarpy import grammars

    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker))      # a file, not a folder
    parser = grammars.lalr_parser(ROOT / "spacarpy" / "deck" / "grammar.lark", lexer="basic")
    assert [t.type for t in parser.lex("BEAM 1 2")][0] == "WORD"


@pytest.mark.slow
def test_batch_tasks_reuse_one_worker_per_thread_and_replace_a_killed_one(tmp_path):
    from spacarpy.batch.runner import Task, run_task
    from spacarpy.batch.workers import close_workers, worker

    try:
        a = run_task(Task("a", str(DECK)))
        pid = worker().proc.pid
        b = run_task(Task("b", str(DECK)))
        assert a.status == b.status == "ok" and worker().proc.pid == pid
        assert a.data[:8] == b"\x89HDF\r\n\x1a\n"
        worker().proc.kill()
        worker().proc.wait()
        c = run_task(Task("c", str(DECK)))
        assert c.status == "ok" and worker().proc.pid != pid
        bad = run_task(Task("d", str(tmp_path / "missing.dat")))
        assert bad.status == "error" and bad.returncode == 2
        # the local backend ends the worker processes of its threads with the pool
        from spacarpy.batch import workers
        from spacarpy.batch.backends import execute
        close_workers()
        done = list(execute(run_task, [Task("e", str(DECK)), Task("f", str(DECK))], jobs=2))
        assert [r.status for r in done] == ["ok", "ok"] and not workers._ALL
    finally:
        close_workers()


def test_the_results_package_gives_every_public_name_on_first_use():
    """``spacarpy.results`` imports its modules lazily (so a run does not import the
    readers); every name of ``__all__`` still resolves, to the object of its module."""
    import spacarpy.results as results
    from spacarpy.results import reader, writer

    for name in results.__all__:
        assert getattr(results, name) is not None, name
        assert name in dir(results)
    assert results.open_results is reader.open_results
    assert results.ResultsWriter is writer.ResultsWriter
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        results.nothing  # noqa: B018


def test_spacarpy_run_does_not_load_numpys_unused_submodules_or_lark(tmp_path):
    """``spacarpy run`` (the console entry point) leaves numpy.testing, f2py, ma, ... unloaded
    (spacarpy.lazy_imports) and reads a deck of ranges without Lark; -X importtime lists
    every module the process really executed."""
    from spacarpy.bench.cases import cantilever_deck
    deck = tmp_path / "compact.dat"
    deck.write_text(cantilever_deck(4, n_steps=2, compact=True))     # ESTIFF 1:4 ...
    proc = subprocess.run([sys.executable, "-X", "importtime", "-m", "spacarpy", "run",
                           str(deck), "-q", "-o", str(tmp_path / "c.h5")], capture_output=True,
                          text=True, cwd=tmp_path, timeout=300, env=_cache_env(tmp_path))
    assert proc.returncode == 0, proc.stderr[-2000:]
    executed = {line.rsplit("|", 1)[-1].strip() for line in proc.stderr.splitlines()
                if line.startswith("import time:")}
    assert {"spacarpy.run", "scipy.sparse", "numpy.random"} <= executed   # not vacuous
    from spacarpy.lazy_imports import DEFERRED
    unused = [f"numpy.{name}" for name in DEFERRED] + ["lark"]
    loaded = sorted(m for m in executed if ".".join(m.split(".")[:2]) in unused
                    or m.split(".")[0] == "lark")
    assert not loaded, f"spacarpy run executed {loaded}"
    assert (tmp_path / "c.h5").read_bytes()[:8] == b"\x89HDF\r\n\x1a\n"


_LAZY_NUMPY = """
import sys
from spacarpy.lazy_imports import defer_numpy_submodules
done = defer_numpy_submodules()
import scipy.sparse.linalg
assert "numpy.f2py.crackfortran" not in sys.modules and "numpy.ma.core" not in sys.modules
import numpy as np
import numpy.ma
from numpy.polynomial import Polynomial
from numpy.testing import assert_allclose
assert_allclose(Polynomial([1, 2, 3])(2.0), 17.0)
assert float(np.ma.masked_array([1.0, 5.0], mask=[0, 1]).sum()) == 1.0
assert np.testing.assert_allclose is assert_allclose and np.char.upper("ab") == "AB"
print(" ".join(done))
"""


def test_deferred_numpy_submodules_load_on_first_use_and_work():
    proc = subprocess.run([sys.executable, "-c", _LAZY_NUMPY], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert {"numpy.testing", "numpy.f2py", "numpy.ma"} <= set(proc.stdout.split())


def test_deferring_numpy_submodules_changes_nothing_once_scipy_is_imported():
    import scipy.sparse  # noqa: F401

    from spacarpy.lazy_imports import defer_numpy_submodules
    assert defer_numpy_submodules() == []
