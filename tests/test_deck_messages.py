"""Deck and command messages that were silent or confusing (report N11): INPUTF on a fixed
coordinate, GRAVITY without mass, a UTF-16 deck, a file INCLUDEd twice, an INCLUDEd FIFO,
``run --mode check -o``."""
import os
import shutil
import threading
from pathlib import Path

import pytest

from spacarpy.cli import main

DECKS = Path(__file__).resolve().parents[1] / "decks"
CANTILEVER = "table1_cantilever_2el_modified.dat"


def test_inputf_on_a_fixed_coordinate_is_an_error(tmp_path, capsys):
    text = (DECKS / "state_space_cantilever.dat").read_text()
    assert "INPUTF 1 9 2" in text
    deck = tmp_path / "d.dat"
    deck.write_text(text.replace("INPUTF 1 9 2", "INPUTF 1 1 2"))
    assert main(["check", str(deck)]) == 2
    captured = capsys.readouterr()
    err = captured.out + captured.err
    assert "INPUTF: coordinate 2 of node 1 is fixed (FIX at line 23)" in err
    assert err.count("error:") == 1


def test_gravity_without_mass_names_the_line(tmp_path, capsys):
    text = (DECKS / CANTILEVER).read_text()
    deck = tmp_path / "g.dat"
    deck.write_text(text.replace("DELXF 5 0 1293750 0", "DELXF 5 0 1293750 0\n"
                                 "GRAVITY 0 -9.81 0"))
    line = deck.read_text().splitlines().index("GRAVITY 0 -9.81 0") + 1
    assert main(["check", str(deck)]) == 0
    err = capsys.readouterr().err
    assert f"g.dat:{line}:1: warning: GRAVITY has no effect: the model has no mass" in err
    assert main(["run", str(deck), "-q", "-o", str(tmp_path / "g.h5")]) == 0
    assert capsys.readouterr().err.count("GRAVITY has no effect") == 1   # once, not twice


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be"])
def test_utf16_deck_is_named(tmp_path, encoding, capsys):
    deck = tmp_path / "u.dat"
    deck.write_bytes((DECKS / CANTILEVER).read_text().encode(encoding))
    assert main(["check", str(deck)]) == 2
    err = capsys.readouterr().err
    assert "UTF-16" in err and "save it as UTF-8" in err and "NUL" not in err


def test_a_file_included_twice_names_both_include_lines(tmp_path, capsys):
    (tmp_path / "nodes.dat").write_text("X 1 0 0 0\nX 3 1 0 0\n")
    deck = tmp_path / "d.dat"
    deck.write_text('INCLUDE "nodes.dat"\nINCLUDE "nodes.dat"\nBEAM 1 1 2 3 4 0 1 0\n'
                    "END\nEND\n")
    assert main(["check", str(deck)]) == 2
    err = capsys.readouterr().err
    assert f"d.dat:2:9: error: INCLUDE 'nodes.dat': {tmp_path / 'nodes.dat'} is already " \
           f"included (at {deck}:1:9)" in err
    assert "lines 1 and 1" not in err


def test_an_included_fifo_is_refused_without_blocking(tmp_path, capsys):
    fifo = tmp_path / "ff.dat"
    os.mkfifo(fifo)
    deck = tmp_path / "d.dat"
    deck.write_text('X 1 0 0 0\nINCLUDE "ff.dat"\nEND\nEND\n')
    done = []
    t = threading.Thread(target=lambda: done.append(main(["check", str(deck)])), daemon=True)
    t.start()
    t.join(30)
    if t.is_alive():                    # unblock it: open the FIFO for writing, then fail
        fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
        os.close(fd)
        t.join(5)
        pytest.fail("check blocked on an INCLUDEd FIFO")
    assert done == [2]
    assert "a FIFO (named pipe): not opened" in capsys.readouterr().err


def test_a_fifo_deck_is_refused(tmp_path, capsys):
    fifo = tmp_path / "d.dat"
    os.mkfifo(fifo)
    assert main(["check", str(fifo)]) == 2
    assert "FIFO" in capsys.readouterr().err


def test_run_mode_check_says_o_is_ignored(tmp_path, capsys):
    deck = tmp_path / CANTILEVER
    shutil.copy(DECKS / CANTILEVER, deck)
    out = tmp_path / "x.h5"
    assert main(["run", str(deck), "--mode", "check", "-o", str(out)]) == 0
    assert f"-o {out} is ignored" in capsys.readouterr().err
    assert not out.exists()


# -- sizing warnings of a transient --------------------------------------------------------

def _pendulum(tmp_path, timestep):
    text = (DECKS / "pendulum_rigid_90deg.dat").read_text()
    assert "TIMESTEP 2.2 440" in text
    deck = tmp_path / "p.dat"
    deck.write_text(text.replace("TIMESTEP 2.2 440", f"TIMESTEP {timestep}"))
    return deck


def test_a_coarse_transient_warns_about_its_energy_error(tmp_path, capsys):
    # two steps of 1.1 s over a period of about 2 s: meaningless either way (1.69 J with the
    # linear update of the Euler parameters before issue 32, 35.4 J on the rotation group
    # with a step that turned the rod by 4.8 rad, 0.932 J since such a step is cut at pi)
    deck = _pendulum(tmp_path, "2.2 2")
    assert main(["run", str(deck), "-q", "-o", str(tmp_path / "p.h5")]) == 0
    err = capsys.readouterr().err
    assert "the energy balance T + U + D - W drifted by 0.932 J" in err
    assert "TIMESTEP" in err and "ERROR" in err


def test_the_shipped_pendulum_has_no_energy_warning(tmp_path, capsys):
    deck = _pendulum(tmp_path, "2.2 440")
    assert main(["run", str(deck), "-q", "-o", str(tmp_path / "p.h5")]) == 0
    assert "energy balance" not in capsys.readouterr().err


def test_a_large_transient_announces_its_file_size(tmp_path, capsys, monkeypatch):
    """The estimate is about bytes per step x steps; above OUTPUT_SIZE_WARNING (5 GB; here
    lowered, so that the run stays short) a warning gives it before the run."""
    import sys
    run_module = sys.modules["spacarpy.cli.run"]
    deck = _pendulum(tmp_path, "2.2 10")
    out = tmp_path / "p.h5"
    monkeypatch.setattr(run_module, "OUTPUT_SIZE_WARNING", 1000)
    assert main(["run", str(deck), "-q", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "TIMESTEP 2.2 10 stores 11 time steps: the result file will be about" in err
    # the estimate is an upper bound of the right order (fixed parts of the file aside)
    from spacarpy.deck.expect import load_with_expectations
    per_step = run_module._step_bytes(load_with_expectations(deck)[0].model)
    assert 500 < per_step < 1000
    monkeypatch.setattr(run_module, "OUTPUT_SIZE_WARNING", 5 * 2**30)
    assert main(["run", str(deck), "-q", "-o", str(out)]) == 0
    assert "stores" not in capsys.readouterr().err


# -- show: arc-length critical points, sweep files -----------------------------------------

@pytest.mark.slow
def test_show_lists_the_critical_points_of_an_arclength_run(tmp_path, capsys):
    """Lee's frame: the two limit points (P L^2/EI = 18.49 at load factor ~0.924)."""
    out = tmp_path / "lee.h5"
    assert main(["run", str(DECKS / "lees_frame_arclength.dat"), "-q", "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["show", str(out)]) == 0
    text = capsys.readouterr().out
    assert "Critical points of the path: 2" in text
    rows = text.split("Critical points of the path: 2")[1].splitlines()[2:4]
    assert "limit point (load maximum)" in rows[0] and "limit point (load minimum)" in rows[1]
    assert abs(float(rows[0].split()[-1]) - 0.9243) < 2e-3


def test_show_reads_a_sweep_file(tmp_path, capsys):
    """A sweep file written by spacarpy.batch.sweep.write_sweep (no runs needed)."""
    import numpy as np

    from spacarpy.batch.sweep import SweepAxis, SweepResult, write_sweep
    result = SweepResult(str(DECKS / CANTILEVER), [SweepAxis("ratio", (-0.5, -0.4, -0.3))],
                         {"/static/load_factor": np.array([1.0, 1.0, np.nan]),
                          "/eigen/frequency": np.array([[1.1, 5.8], [1.2, 5.9],
                                                        [np.nan, np.nan]])},
                         np.array([0, 0, 1]), np.array(["", "", "no convergence"]))
    out = write_sweep(result, tmp_path / "s.h5")
    assert main(["show", str(out)]) == 0
    text = capsys.readouterr().out
    assert "parameters ratio (3 values, -0.5 .. -0.3)" in text
    assert "points     3: 2 ran, 1 failed" in text
    assert "/eigen/frequency" in text and "/static/load_factor" in text
    assert "exit 1" in text and "1.1" in text
    result.status[2] = -2                       # an interrupted sweep's point
    write_sweep(result, out)
    assert main(["show", str(out)]) == 0
    assert "points     3: 2 ran, 0 failed, 1 not run (interrupted)" in capsys.readouterr().out
