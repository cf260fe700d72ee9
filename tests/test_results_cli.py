"""The result-file commands: validate, show, extract; and a real ``spacarpy run`` interrupted
with Ctrl-C (SIGINT) or killed (SIGKILL) in the middle of its load steps."""
from __future__ import annotations

import csv
import io
import json
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.results import open_results, read_results, validate_file

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def files(result_files):
    return result_files


# --- validate --------------------------------------------------------------------------------

def test_validate(files, capsys, tmp_path):
    assert main(["validate", str(files["bend"])]) == 0
    assert "valid spacarpy results file, schema 3.1, completed run" in capsys.readouterr().out
    assert main(["validate", str(files["failed"])]) == 0
    assert "incomplete run: spurious" in capsys.readouterr().out
    assert main(["validate", str(files["failed"]), "--require-complete"]) == 2
    out = capsys.readouterr().out
    assert "INVALID (1 problem)" in out and "run incomplete: spurious" in out
    broken = tmp_path / "broken.h5"
    shutil.copy(files["bend"], broken)
    with h5py.File(broken, "r+") as f:
        del f["static/euler"].attrs["units"]
    assert main(["validate", str(broken)]) == 2
    assert "/static/euler has no units attribute" in capsys.readouterr().out
    junk = tmp_path / "junk.h5"
    junk.write_text("no")
    assert main(["validate", str(junk)]) == 2


def test_newer_major_version_exits_2_with_a_clear_message(files, tmp_path, capsys):
    path = tmp_path / "future.h5"
    shutil.copy(files["bend"], path)
    with h5py.File(path, "r+") as f:
        f.attrs["schema_version"] = np.array([4, 2], dtype=np.int32)
    for command in (["show"], ["extract", "_", "position"], ["validate"]):
        argv = [command[0], str(path)] + command[2:]
        assert main(argv) == 2
        text = capsys.readouterr()
        assert "schema version 4.2 is newer than schema version 3.1" in text.out + text.err


# --- show ----------------------------------------------------------------------------------------

def test_show_static(files, capsys):
    assert main(["show", str(files["bend"])]) == 0
    out = capsys.readouterr().out
    assert "static, modified deformations; completed" in out
    assert "9 position nodes, 9 orientation nodes, 8 elements, 63 coordinates, 7 fixed" in out
    assert "Static load steps: 11 committed" in out
    last = [line for line in out.splitlines() if line.strip().startswith("10 ")][0].split()
    assert last[:2] == ["10", "1"] and last[-1] == "3"                 # tip node moves most
    assert "reaction force Fy      -600     N     node 1, step 10" in out
    assert "bending moment |Mz|" in out


def test_show_stresses_and_linearized(files, capsys):
    assert main(["show", str(files["frame"])]) == 0
    assert "max von Mises stress" in capsys.readouterr().out
    assert main(["show", str(files["column"])]) == 0
    out = capsys.readouterr().out
    assert "Natural frequencies at 5 linearized step(s):" in out
    assert "Buckling load multipliers at 5 linearized step(s)" in out
    assert "Compliance of nodes 3/4 at step 4" in out
    assert main(["show", str(files["failed"])]) == 0
    assert "INCOMPLETE: " in capsys.readouterr().out


# --- extract -------------------------------------------------------------------------------------

def test_extract_csv_round_trips_exactly(files, capsys):
    assert main(["extract", str(files["bend"]), "position", "--node", "3", "--csv"]) == 0
    rows = list(csv.reader(io.StringIO(capsys.readouterr().out)))
    assert rows[0] == ["step", "load_factor", "node", "x [m]", "y [m]", "z [m]"]
    values = np.array([[float(v) for v in r[3:]] for r in rows[1:]])
    np.testing.assert_array_equal(values, open_results(files["bend"]).static.position(node=3))


def test_extract_json_and_filters(files, capsys):
    assert main(["extract", str(files["bend"]), "displacement", "--step", "-1", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["columns"] == ["step", "load_factor", "node", "ux", "uy", "uz"]
    assert doc["units"][3:] == ["m", "m", "m"] and len(doc["data"]) == 9
    assert {r[0] for r in doc["data"]} == {10}
    assert main(["extract", str(files["column"]), "buckling", "--step", "0", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["data"][0][3] is None and doc["data"][0][4] is None     # NaN, inf -> null


@pytest.mark.parametrize("what, extra, n_rows", [
    ("load_factor", [], 11), ("euler", ["--node", "4"], 11), ("deformation", ["--step", "3"], 8),
    ("stress_resultant", ["--element", "2"], 11), ("section_forces", [], 88),
    ("strain_energy", ["--step", "-1"], 8), ("reaction", ["--node", "2"], 33),
    ("nodes", [], 9), ("elements", [], 8), ("coordinates", ["--node", "3"], 3),
])
def test_extract_static_quantities(files, capsys, what, extra, n_rows):
    assert main(["extract", str(files["bend"]), what, "--csv", *extra]) == 0
    rows = list(csv.reader(io.StringIO(capsys.readouterr().out)))
    assert len(rows) - 1 == n_rows


@pytest.mark.parametrize("what, extra, n_rows", [
    ("frequency", [], 15), ("frequency", ["--mode", "1"], 5), ("buckling", ["--step", "2"], 3),
    ("mode_shape", ["--mode", "2", "--step", "4"], 5), ("buckling_shape", ["--node", "3"], 1),
    ("compliance", ["--step", "-1"], 6),
])
def test_extract_linearized_quantities(files, capsys, what, extra, n_rows):
    assert main(["extract", str(files["column"]), what, "--csv", *extra]) == 0
    rows = list(csv.reader(io.StringIO(capsys.readouterr().out)))
    assert len(rows) - 1 == n_rows


def test_extract_stress_and_output_file(files, tmp_path, capsys):
    out = tmp_path / "stress.txt"
    assert main(["extract", str(files["frame"]), "stress", "--step", "-1", "-o", str(out)]) == 0
    text = out.read_text()
    assert text.startswith("largest stresses at the surface of the cross-section\n")
    assert "max_von_mises_stress [Pa]" in text.splitlines()[1]


def test_extract_errors_exit_2(files, capsys):
    bend = str(files["bend"])
    for argv, message in (
            (["extract", bend, "position", "--node", "4"], "position node 4 is not in"),
            (["extract", bend, "position", "--step", "99"], "step 99 does not exist"),
            (["extract", bend, "frequency"], "has no /eigen results"),
            (["extract", bend, "stress"], "no element of this model has a known cross-section"),
            (["extract", bend, "reaction", "--node", "3"], "node 3 has no support reactions"),
            (["extract", str(files["column"]), "mode_shape", "--mode", "9"], "modes are "
                                                                              "numbered 1..3")):
        assert main(argv) == 2, argv
        assert message in capsys.readouterr().err
    assert main(["extract", bend, "banana"]) == 2


def test_extract_deck(files, capsys):
    assert main(["extract", str(files["bend"]), "deck"]) == 0
    out = capsys.readouterr().out
    assert "BEAMARC" in out
    with h5py.File(files["bend"], "r") as f:
        text = f["/deck"][()].decode()
    assert out.splitlines() == text.splitlines()     # verbatim, left-aligned, no header
    assert any(line.startswith(("X ", "BEAM")) for line in out.splitlines())


# --- a real run interrupted or killed --------------------------------------------------------

SLOW_DECK = """# a long cantilever under a tip force, many small load steps
X 1 0 0 0
BEAMS 1  1 2 3 4  300  0 1 0
X 3 10 0 0
DYNE 1:300 1:6
FIX 1
FIX 2
END
HALT
ESTIFF 1:300 1e9 1e6 1e6 1e6
DELXF 3 0 1e3 0
ITERSTEP 20 400 1e-10
END
END
"""


def start_run(tmp_path, out):
    deck = tmp_path / "slow.dat"
    deck.write_text(SLOW_DECK)
    # SIGINT at its default in the run: a suite started as a background job of a shell
    # without job control inherits SIGINT ignored, hands that on, and the run would then
    # never see the Ctrl-C this test sends (it would finish and replace the old output)
    return subprocess.Popen([sys.executable, "-m", "spacarpy", "run", str(deck), "-o", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            cwd=REPO, preexec_fn=_default_sigint)


def _default_sigint():
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def wait_for_steps(proc, n: int) -> None:
    """Read the run's progress lines until step ``n`` has been reported."""
    while True:
        line = proc.stderr.readline()
        assert line, f"the run ended early (exit {proc.poll()})"
        if line.startswith(f"step {n:>3}/"):
            return


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(signal, "SIGINT") or sys.platform == "win32",
                    reason="needs POSIX signals")
@pytest.mark.parametrize("sig", ["SIGINT", "SIGKILL"])
def test_real_run_stopped_mid_way_keeps_steps_and_the_old_output(files, tmp_path, sig):
    out = tmp_path / "result.h5"
    shutil.copy(files["bend"], out)                 # a previous good result
    good = out.read_bytes()
    proc = start_run(tmp_path, out)
    try:
        wait_for_steps(proc, 3)
        proc.send_signal(getattr(signal, sig))
        code = proc.wait(timeout=30)
        rest = proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stderr.close()
    assert out.read_bytes() == good                 # never replaced by an unfinished run
    partial = tmp_path / "result.partial.h5"
    assert validate_file(partial) == []
    res = read_results(partial)
    assert res.completed is False and res.static.n_step >= 4
    assert res.static.load_factor[3] == pytest.approx(3 / 400)
    if sig == "SIGINT":
        assert code == 130 and "interrupted" in rest
        assert res.error == "interrupted by user"
        with h5py.File(partial, "r"):               # closed cleanly: any HDF5 tool opens it
            pass
    else:
        assert code == -signal.SIGKILL and res.error is None
    assert validate_file(partial, require_complete=True)[0].startswith("run incomplete")
