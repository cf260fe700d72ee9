"""Safe outputs of ``spacarpy run`` (issue 17): the output lock, SIGTERM, output paths
checked before the work, and refused empty or binary decks."""
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import pytest

from spacarpy.cli import main
from spacarpy.outputs import OutputError, OutputLock

DECKS = Path(__file__).resolve().parents[1] / "decks"
ROOT = Path(__file__).resolve().parents[1]
DECK = "table1_cantilever_8el_modified.dat"


def copy_deck(tmp_path, name=DECK):
    dst = tmp_path / name
    shutil.copy(DECKS / name, dst)
    return dst


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


# -- D4: a lock on the output file ---------------------------------------------------------

def test_output_lock_is_exclusive_and_removed(tmp_path):
    out = tmp_path / "r.h5"
    with OutputLock(out) as lock:
        assert lock.lock_path == tmp_path / "r.h5.lock"
        assert lock.lock_path.read_text().strip() == str(os.getpid())
        with pytest.raises(OutputError, match=f"process {os.getpid()}"):
            OutputLock(out).acquire()
    assert not (tmp_path / "r.h5.lock").exists()
    with OutputLock(out):                       # free again
        pass


def test_second_run_on_a_locked_output_stops_at_once(tmp_path, capsys):
    """Another process holds the lock (as a running ``spacarpy run`` does): the second run
    exits 2 before any work, names that process, and leaves the first run's file alone."""
    deck = copy_deck(tmp_path)
    out = tmp_path / "same.h5"
    out.write_bytes(b"first run's result")
    holder = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(f"""
            import sys, time
            from spacarpy.outputs import OutputLock
            with OutputLock({str(out)!r}):
                print("locked", flush=True)
                time.sleep(30)
            """)], stdout=subprocess.PIPE, text=True, env=_env())
    try:
        assert holder.stdout.readline().strip() == "locked"
        assert main(["run", str(deck), "-o", str(out), "-q"]) == 2
        err = capsys.readouterr().err
        assert f"process {holder.pid}" in err and "another spacarpy run" in err
        assert out.read_bytes() == b"first run's result"
        assert not (tmp_path / "same.partial.h5").exists()
    finally:
        holder.kill()
        holder.wait(timeout=10)
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0       # lock released
    with h5py.File(out, "r") as f:
        assert f.attrs["completed"]
    assert not (tmp_path / "same.h5.lock").exists()


# -- D8: SIGTERM handled like Ctrl-C ------------------------------------------------------

SLOW_DECK = """\
X 1 0 0 0
BEAMS 1 1 2 3 4 100 0 1 0
X 3 2 0 0
DYNE 1:100 1:6
FIX 1
FIX 2
END
HALT
ESTIFF 1:100 2.07e9 1.12e6 1.725e6 1.725e6
DELXF 3 0 1.29375e6 0
ITERSTEP 20 2000 1e-9
END
END
"""


@pytest.mark.slow
def test_sigterm_closes_the_partial_file_and_exits_143(tmp_path):
    import signal
    deck = tmp_path / "slow.dat"
    deck.write_text(SLOW_DECK)
    proc = subprocess.Popen([sys.executable, "-m", "spacarpy", "run", str(deck)],
                            stderr=subprocess.PIPE, text=True, env=_env())
    try:
        for line in proc.stderr:               # wait for committed steps
            if line.startswith("step") and "/2000" in line and " 3/" in line:
                break
        proc.send_signal(signal.SIGTERM)
        rest = proc.stderr.read()
        assert proc.wait(timeout=60) == 143
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert "terminated (SIGTERM)" in rest and "Traceback" not in rest
    partial = tmp_path / "slow.partial.h5"
    assert not (tmp_path / "slow.h5").exists() and not (tmp_path / "slow.h5.lock").exists()
    with h5py.File(partial, "r") as f:        # plain open: the SWMR mark is cleared
        assert not f.attrs["completed"]
        assert f.attrs["error"] == "terminated by SIGTERM"
        n = f["static/load_factor"].shape[0]
        assert 4 <= n < 2001
        assert f["static/position"].shape[0] >= n


# -- D5/D6: output paths checked before the work -------------------------------------------

@pytest.mark.parametrize("output, message", [
    ("{tmp}/nonexist/x.h5", "does not exist"),
    ("{tmp}/adir", "is a directory"),
    ("{tmp}/" + DECK, "is an input file"),
    ("{tmp}/model.inc", "is an input file"),
])
def test_run_refuses_bad_output_paths_before_the_solve(tmp_path, capsys, output, message):
    deck = copy_deck(tmp_path)
    (tmp_path / "adir").mkdir()
    text = deck.read_text()
    first_end = text.index("\nEND")
    (tmp_path / "model.inc").write_text(text[:first_end + 1])
    deck.write_text('INCLUDE "model.inc"' + text[first_end:])
    before = deck.read_bytes(), (tmp_path / "model.inc").read_bytes()
    assert main(["run", str(deck), "-q", "-o", output.format(tmp=tmp_path)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert (deck.read_bytes(), (tmp_path / "model.inc").read_bytes()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [DECK, "adir", "model.inc"])                # nothing written, no partial file


def test_run_refuses_an_empty_output_name(tmp_path, capsys):
    deck = copy_deck(tmp_path)
    assert main(["run", str(deck), "-q", "-o", ""]) == 2
    assert "the output file name is empty" in capsys.readouterr().err


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only directory")
def test_run_refuses_a_read_only_directory(tmp_path, capsys):
    deck = copy_deck(tmp_path)
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["run", str(deck), "-q", "-o", str(ro / "x.h5")]) == 2
    finally:
        ro.chmod(0o755)
    assert "is not writable" in capsys.readouterr().err


def test_an_unwritable_directory_is_refused_whoever_runs(tmp_path, monkeypatch):
    """The same check as above where the tests run as root (os.access says no)."""
    import spacarpy.outputs as outputs
    real = os.access
    monkeypatch.setattr(outputs.os, "access",
                        lambda p, mode: False if Path(p) == tmp_path else real(p, mode))
    with pytest.raises(OutputError, match=f"the directory {tmp_path} is not writable"):
        outputs.check_output_path(tmp_path / "x.h5", "-o")


def test_run_warns_before_replacing_a_write_protected_result(tmp_path, capsys):
    deck = copy_deck(tmp_path)
    out = tmp_path / "r.h5"
    assert main(["run", str(deck), "-q", "-o", str(out)]) == 0
    out.chmod(0o444)
    capsys.readouterr()
    assert main(["run", str(deck), "-q", "-o", str(out)]) == 0
    warnings = [ln for ln in capsys.readouterr().err.splitlines() if "write-protected" in ln]
    assert warnings == [f"{out} is write-protected; it will be replaced by the new results"]


def test_extract_and_bench_check_their_output_before_the_work(tmp_path, capsys):
    deck = copy_deck(tmp_path)
    assert main(["run", str(deck), "-q"]) == 0
    capsys.readouterr()
    assert main(["extract", str(deck.with_suffix(".h5")), "position", "-o",
                 str(tmp_path / "no" / "x.csv")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["bench", "--sizes", "10", "--markdown", str(tmp_path / "no" / "b.md")]) == 2
    captured = capsys.readouterr()
    assert "does not exist" in captured.err and "cantilever" not in captured.out


# -- D10/D12: empty and binary decks -----------------------------------------------------

@pytest.mark.parametrize("text", ["", "END\nEND\n", "\n\n% only a comment\n"])
def test_an_empty_deck_is_refused(tmp_path, capsys, text):
    deck = tmp_path / "e.dat"
    deck.write_text(text)
    assert main(["run", str(deck), "-q"]) == 2
    assert "the deck defines no nodes and no elements" in capsys.readouterr().err
    assert not deck.with_suffix(".h5").exists()
    assert not (tmp_path / "e.partial.h5").exists()
    assert main(["check", str(deck)]) == 2
    out = capsys.readouterr().out
    assert "no nodes and no elements" in out and "OK" not in out


def test_dev_null_is_refused(tmp_path, capsys):
    assert main(["run", "/dev/null", "-q", "-o", str(tmp_path / "n.h5")]) == 2
    assert "defines no nodes and no elements" in capsys.readouterr().err


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero")
def test_binary_input_is_refused_from_its_first_bytes(tmp_path, capsys):
    """/dev/zero is endless: it must be refused without reading it all."""
    assert main(["run", "/dev/zero", "-q", "-o", str(tmp_path / "z.h5")]) == 2
    assert "binary data" in capsys.readouterr().err
    deck = copy_deck(tmp_path)
    assert main(["run", str(deck), "-q"]) == 0
    capsys.readouterr()
    assert main(["run", str(deck.with_suffix(".h5")), "-q", "-o", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err
    assert "HDF5 file" in err and "\x89" not in err


def test_oversized_deck_is_refused(tmp_path, monkeypatch, capsys):
    import spacarpy.deck.textfile as textfile
    monkeypatch.setattr(textfile, "MAX_DECK_BYTES", 10_000)
    deck = tmp_path / "big.dat"
    deck.write_text("% padding\n" * 2000)
    assert main(["run", str(deck), "-q"]) == 2
    assert "larger than" in capsys.readouterr().err


def test_control_characters_in_messages_are_escaped(tmp_path, capsys):
    deck = tmp_path / "c.dat"
    deck.write_bytes(b"X 1 0 0 \x1b[31mRED\x07\nEND\nEND\n")
    assert main(["run", str(deck), "-q"]) == 2
    err = capsys.readouterr().err
    assert "\x1b" not in err and "\x07" not in err and "\\x1b[31mRED\\x07" in err


# -- D7: memory estimate before the solve ----------------------------------------------------

@pytest.mark.parametrize("n_elem, peaks_mb", [(10, [75]), (1000, [120]), (10**4, [541, 623]),
                                              (10**5, [3342])])
def test_memory_estimate_matches_the_benchmark_measurements(n_elem, peaks_mb):
    """docs/performance.md, "Memory estimate before a run": the peak resident memory of
    `spacarpy run` on the bench's static cantilever (two measurements at 10^4); the estimate
    is within a factor 1.5 of each (issue 36)."""
    from spacarpy.memory import estimate_run_bytes
    for peak in peaks_mb:
        assert 1 / 1.5 < estimate_run_bytes(n_elem) / (peak * 2**20) < 1.5


def test_run_stops_when_the_estimate_exceeds_the_available_memory(tmp_path, capsys,
                                                                   monkeypatch):
    import spacarpy.memory as memory
    monkeypatch.setattr(memory, "available_bytes", lambda: 100 * 2**20)
    deck = copy_deck(tmp_path)
    assert main(["run", str(deck), "-q"]) == 2
    err = capsys.readouterr().err
    assert "needs about 110 MB of memory, more than the 100 MB available" in err
    assert "--ignore-memory-limit" in err and not deck.with_suffix(".h5").exists()
    assert main(["run", str(deck), "-q", "--ignore-memory-limit"]) == 0
    assert "running anyway" in capsys.readouterr().err
    assert deck.with_suffix(".h5").exists()


@pytest.mark.parametrize("deck_text", [
    # a generator: the count is a field, the elements are never made
    "SET n 1000000\nX 1 0 0 0\nX 3 1 0 0\nBEAMS 1 1 2 3 4 {n} 0 1 0\nDYNE 1:{n} 1:6\n"
    "FIX 1\nFIX 2\nEND\nHALT\nESTIFF 1:{n} 1 1 1 1\nDELXF 3 0 1 0\nEND\nEND\n",
    # plain element lines (the parser's tables)
    "X 1 0 0 0\n" + "".join(f"X {2 * i + 1} {i} 0 0\n" for i in range(1, 3001))
    + "".join(f"BEAM {i} {2 * i - 1} {2 * i} {2 * i + 1} {2 * i + 2} 0 1 0\n"
              for i in range(1, 3001))
    + "FIX 1\nFIX 2\nEND\nHALT\nDELXF 3 0 1 0\nEND\nEND\n",
])
def test_run_refuses_a_too_large_model_before_building_it(tmp_path, capsys, monkeypatch,
                                                          deck_text):
    """Report N11: the memory refusal of 10^6 generated elements came after 32 s of building
    them; the element count of the parsed deck decides it, before any element is made."""
    import spacarpy.deck.generators as generators
    import spacarpy.deck.semantics.arrays as arrays
    import spacarpy.memory as memory
    from spacarpy.deck.semantics import build
    monkeypatch.setattr(memory, "available_bytes", lambda: 10 * 2**20)

    def never(*args, **kw):
        raise AssertionError("the elements were built before the memory check")

    monkeypatch.setattr(build, "expand_generators", never)
    monkeypatch.setattr(arrays, "build_arrays", never)
    monkeypatch.setattr(generators, "expand_generators", never)
    deck = tmp_path / "big.dat"
    deck.write_text(deck_text)
    assert main(["run", str(deck), "-q"]) == 2
    err = capsys.readouterr().err
    assert "more than the 10 MB available" in err and "Traceback" not in err
    assert not deck.with_suffix(".h5").exists()


def test_check_prints_the_memory_estimate(tmp_path, capsys):
    assert main(["check", str(copy_deck(tmp_path))]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-2] == "  memory estimate     about 110 MB at the peak of a run"


# -- D9: an EXPECT line that --set makes unevaluable warns ---------------------------------

def test_unevaluable_expect_under_set_warns(tmp_path, capsys):
    deck = tmp_path / "s.dat"
    shutil.copy(DECKS / "sweep_column_load_ratio.dat", deck)
    assert main(["run", str(deck), "-q", "--set", "ratio=-2", "-o", str(tmp_path / "a.h5")]) == 0
    err = capsys.readouterr().err
    assert f"{deck}:26:35: warning: EXPECT line skipped under --set: cannot evaluate " \
           "sqrt(-1)" in err
    with h5py.File(tmp_path / "a.h5", "r") as f:     # the deck stored as written
        assert f["deck"][()].decode() == deck.read_text()


def test_unevaluable_expect_without_set_is_an_error(tmp_path, capsys):
    deck = tmp_path / "s.dat"
    text = (DECKS / "sweep_column_load_ratio.dat").read_text()
    deck.write_text(text.replace("SET ratio ", "SET ratio -2 %", 1))
    assert "SET ratio -2 %" in deck.read_text()
    assert main(["run", str(deck), "-q"]) == 2
    assert "26:35: error: cannot evaluate sqrt(-1)" in capsys.readouterr().err


# -- D11: sweep tables give the reason of each failure ---------------------------------------

def test_sweep_table_shows_the_reason_of_each_failure():
    import numpy as np

    from spacarpy.batch.sweep import SweepAxis, SweepResult, failure_reason, format_sweep_table
    msg = ("exit code 2: d.dat:3:5: error: cannot evaluate sqrt(-1): outside its domain\n"
           "    BEAM 1 ...\n        ^")
    result = SweepResult("d.dat", [SweepAxis("n", (0.0, 8.0))],
                         data={"eigen/frequency": np.array([[np.nan], [1.5]])},
                         status=np.array([2, 0]), errors=np.array([msg, ""], dtype=object))
    assert failure_reason(msg) == "d.dat:3:5: error: cannot evaluate sqrt(-1): outside its domain"
    assert failure_reason("exit code 1: step 3\nno convergence") == "no convergence"
    text = format_sweep_table(result)
    assert text.splitlines()[-2:] == [
        "failed runs:",
        "  n=0: exit 2: d.dat:3:5: error: cannot evaluate sqrt(-1): outside its domain"]
    csv = format_sweep_table(result, csv=True).splitlines()
    assert csv[0] == "n,frequency[1],status,error"
    assert csv[1] == "0,nan,exit 2,d.dat:3:5: error: cannot evaluate sqrt(-1): outside its domain"
    assert csv[2] == "8,1.5,ok,"


# -- D12: messages ---------------------------------------------------------------------------

def test_interrupted_transient_says_how_many_time_steps_were_kept(tmp_path, caplog):
    from spacarpy.deck import load
    from spacarpy.run import RunOptions, run_job

    calls = []

    def progress(t, t_end):
        calls.append(t)
        if len(calls) == 5:
            raise KeyboardInterrupt

    job = load(DECKS / "cantilever_free_vibration.dat")
    with pytest.raises(KeyboardInterrupt), caplog.at_level("WARNING"):
        run_job(job, tmp_path / "t.h5", RunOptions(progress=progress))
    with h5py.File(tmp_path / "t.partial.h5", "r") as f:
        n_time = f["transient/time"].shape[0]
        t_end = f["transient/time"][-1]
        n_static = f["static/load_factor"].shape[0]
        assert f.attrs["error"] == "interrupted by user"
    assert n_time >= 1
    assert [r.getMessage() for r in caplog.records if "not completed" in r.getMessage()] == [
        f"run not completed; {n_static} static steps, {n_time} time steps (to t = "
        f"{t_end:.6g} s) kept in "
        f"{tmp_path / 't.partial.h5'}"]


def test_deck_errors_are_capped(tmp_path, capsys):
    deck = tmp_path / "many.dat"
    deck.write_text("X 1 0 0 0\n" + "".join(f"BEAM {i} 1 2 3 4 q\n" for i in range(1, 121))
                    + "END\nEND\n")
    assert main(["run", str(deck), "-q"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 50 * 3 + 1
    assert err[-1] == "... and 70 more errors (120 errors)"
    assert err[-4].startswith(f"{deck}:51:")


def test_a_failure_message_is_printed_once(tmp_path, capsys):
    deck = copy_deck(tmp_path)
    deck.write_text(deck.read_text().replace("ITERSTEP 20 10 1e-09", "ITERSTEP 3 10 1e-30"))
    assert main(["run", str(deck)]) == 1
    err = capsys.readouterr().err
    assert err.count("did not converge") == 1
    assert "run not completed; 1 static steps kept in" in err


@pytest.mark.parametrize("args", [["--sizes", "0"], ["--sizes", "-5"], ["--steps", "0"],
                                  ["--case-sizes", "cantilever=0"]])
def test_bench_refuses_nonpositive_sizes(capsys, args):
    assert main(["bench", *args]) == 2
    err = capsys.readouterr().err
    assert "spacarpy bench:" in err and "Traceback" not in err


def test_extract_compliance_names_the_right_option(tmp_path, capsys):
    deck = copy_deck(tmp_path)
    assert main(["run", str(deck), "-q"]) == 0
    assert main(["extract", str(deck.with_suffix(".h5")), "compliance"]) == 2
    err = capsys.readouterr().err
    assert "--compliance POS ROT" in err and "--mode compliance" not in err


def test_gravity_without_mass_warns(tmp_path, capsys):
    deck = copy_deck(tmp_path)
    text = deck.read_text()
    i = text.index("\nEND")
    deck.write_text(text[:i] + "\nGRAVITY 0 -9.81 0" + text[i:])
    assert main(["run", str(deck), "-q"]) == 0
    assert "GRAVITY has no effect: the model has no mass" in capsys.readouterr().err


def test_run_help_lists_every_mode(capsys):
    assert main(["run", "--help"]) == 0
    help_text = " ".join(capsys.readouterr().out.split())
    assert "transient (1), check" in help_text
    assert "state_space (9" in help_text
