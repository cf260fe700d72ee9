"""Command line: exit codes, messages, and the result-file contract of ``spacarpy run``."""
import hashlib
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.cli import main

DECKS = Path(__file__).resolve().parents[1] / "decks"


def copy_deck(tmp_path, name):
    dst = tmp_path / name
    shutil.copy(DECKS / name, dst)
    return dst


def test_run_writes_the_documented_static_contract(tmp_path, capsys):
    deck = copy_deck(tmp_path, "table1_cantilever_8el_modified.dat")
    assert main(["run", str(deck)]) == 0
    out = deck.with_suffix(".h5")
    assert out.exists() and not (tmp_path / "table1_cantilever_8el_modified.partial.h5").exists()
    with h5py.File(out, "r") as f:
        assert f.attrs["completed"]
        assert f.attrs["analysis"] == "static" and f.attrs["deformations"] == "modified"
        assert f.attrs["deck_path"].endswith("table1_cantilever_8el_modified.dat")
        assert f["deck"][()].decode() == deck.read_text()
        assert f.attrs["deck_text"] == deck.read_text()
        assert f.attrs["program_version"] and f.attrs["deck_path"]
        assert list(f["model/position_nodes"][:]) == list(range(1, 18, 2))
        assert list(f["model/orientation_nodes"][:]) == list(range(2, 19, 2))
        assert list(f["model/elements/BEAM/ids"][:]) == list(range(1, 9))
        np.testing.assert_allclose(f["static/load_factor"][:], np.linspace(0, 1, 11))
        assert f["static/position"].shape == (11, 9, 3)
        assert f["static/euler"].shape == (11, 9, 4)
        assert f["static/elements/BEAM/deformation"].shape == (11, 8, 6)
        assert f["static/elements/BEAM/stress_resultant"].shape == (11, 8, 6)
        tip = f["static/position"][-1, -1]
        assert round(2.0 - tip[0], 6) == 0.512121 and round(tip[1], 6) == 1.211296
        comps = [c.decode() for c in f["static/reaction_component"][:]]
        reac = dict(zip(comps, f["static/reaction"][-1]))
        assert reac["Fy"] == pytest.approx(-1.29375e6, rel=1e-9)
        q = f["static/euler"][-1]
        np.testing.assert_allclose(np.sum(q * q, axis=1), 1.0, atol=1e-14)
    assert "step 10/10" in capsys.readouterr().err


def test_syntax_error_exits_2_with_file_line_column(tmp_path, capsys):
    deck = tmp_path / "bad.dat"
    deck.write_text("X 1 0 0 0\nX 3 1 0 0\nBEEM 1 1 2 3 4 0 1 0\nEND\nEND\n")
    assert main(["run", str(deck)]) == 2
    err = capsys.readouterr().err
    assert f"{deck}:3:1: error: unknown keyword 'BEEM' (did you mean BEAM?)" in err
    assert not deck.with_suffix(".h5").exists()


def test_missing_deck_and_bad_mode_are_input_errors(tmp_path, capsys):
    assert main(["run", str(tmp_path / "nothere.dat")]) == 2
    deck = copy_deck(tmp_path, "table1_cantilever_2el_modified.dat")
    assert main(["run", str(deck), "--mode", "transient"]) == 2
    assert "MODE transient needs the time span: TIMESTEP t_end n_steps" in \
        capsys.readouterr().err
    assert main(["run", str(deck), "--mode", "eigen"]) == 2          # the deck has no EM
    assert "needs mass" in capsys.readouterr().err
    assert main(["run", str(deck), "--mode", "banana"]) == 2


def test_spacar_mode_number_and_deformation_override(tmp_path):
    deck = copy_deck(tmp_path, "table1_cantilever_4el_modified.dat")
    out = tmp_path / "basic.h5"
    assert main(["run", str(deck), "--mode", "10", "--deformations", "basic", "-o", str(out),
                 "-q"]) == 0
    with h5py.File(out, "r") as f:
        assert f.attrs["deformations"] == "basic"
        assert round(2.0 - f["static/position"][-1, -1, 0], 6) == 0.521435


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_failed_run_keeps_converged_steps_and_never_overwrites_a_good_file(tmp_path, capsys):
    good = copy_deck(tmp_path, "table1_cantilever_2el_modified.dat")
    out = tmp_path / "result.h5"
    assert main(["run", str(good), "-o", str(out), "-q"]) == 0
    before = digest(out)
    bad = copy_deck(tmp_path, "table1_cantilever_1el_basic.dat")
    assert main(["run", str(bad), "-o", str(out)]) == 1          # spurious equilibrium
    assert "spurious equilibrium" in capsys.readouterr().err
    assert digest(out) == before
    partial = tmp_path / "result.partial.h5"
    with h5py.File(partial, "r") as f:
        assert not f.attrs["completed"]
        assert "spurious" in f.attrs["error"]
        n = f["static/load_factor"].shape[0]
        assert 1 <= n < 11
        assert f["static/position"].shape[0] == n


def test_mechanism_exits_3_naming_the_nodes(tmp_path, capsys):
    deck = tmp_path / "free.dat"
    deck.write_text("X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4 0 1 0\nDYNE 1 1 2 3 4 5 6\nEND\nHALT\n"
                    "ESTIFF 1 1e6 1e3 1e3 1e3\nDELXF 3 0 1 0\nEND\nEND\n")
    assert main(["run", str(deck)]) == 3
    assert "mechanism" in capsys.readouterr().err


def test_python_dash_m_entry_point():
    out = subprocess.run([sys.executable, "-m", "spacarpy", "--version"], capture_output=True,
                         text=True, check=True)
    assert out.stdout.startswith("spacarpy ")


def test_verbose_shows_spacarpy_debug_lines_but_not_h5py_ones(tmp_path, capsys):
    import logging

    deck = DECKS / "table1_cantilever_1el_modified.dat"
    assert main(["run", str(deck), "-o", str(tmp_path / "o.h5"), "-v"]) == 0
    logging.getLogger("h5py._conv").debug("Creating converter from 5 to 3")   # as h5py does
    err = capsys.readouterr().err
    assert "iteration 0: residual" in err                # spacarpy's own debug lines
    assert "Creating converter" not in err
    assert not logging.getLogger("h5py._conv").isEnabledFor(logging.DEBUG)
