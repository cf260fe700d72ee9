"""``spacarpy bench``: it runs its cases in child processes and writes the Markdown tables
(times are never asserted; the results each row reaches are)."""
import numpy as np
import pytest

from spacarpy.cli import main


@pytest.mark.slow
def test_bench_writes_the_tables_with_the_results_each_case_reaches(tmp_path, capsys):
    md = tmp_path / "performance.md"
    assert main(["bench", "--cases", "cantilever", "eigen", "--sizes", "8", "--repeat", "1",
                 "--markdown", str(md)]) == 0
    out = capsys.readouterr().out
    assert "Static cantilever" in out and "eigenfrequencies" in out
    text = md.read_text()
    assert text.startswith("# Performance") and text.count("| 8 |") == 2
    row = next(ln for ln in text.splitlines() if ln.startswith("| 8 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    # 8 elements: Table 1's 1.211296 m (shear rigid); GA = 10 EA adds about 5e-5 m
    assert 0 < float(cells[13]) - 1.211296 < 2e-4
    # the whole-process column: `spacarpy run` as a subprocess, start-up and solve included
    assert float(cells[16]) > float(cells[3]) > 0
    f_row = [ln for ln in text.splitlines() if ln.startswith("| 8 |")][1]
    f1 = float(f_row.strip("|").split("|")[5])
    assert abs(f1 - 20.73) < 0.05           # first bending frequency of the steel cantilever


def test_bench_case_sizes_are_checked(capsys):
    assert main(["bench", "--case-sizes", "beam=10"]) == 2       # an input error, no traceback
    assert "expected CASE=N" in capsys.readouterr().err


@pytest.mark.slow
def test_bench_pendulum_case_times_the_whole_spacarpy_run(capsys):
    from spacarpy.bench.runner import run_bench
    rows = run_bench(cases=("pendulum",), repeat=1)["pendulum"]
    assert len(rows) == 1 and "error" not in rows[0], rows
    assert rows[0]["command"] == "spacarpy run decks/pendulum_rigid_90deg.dat"
    assert rows[0]["whole"] == rows[0]["median"] > 0
    assert "spacarpy run decks/pendulum_rigid_90deg.dat" in capsys.readouterr().out


@pytest.mark.slow
def test_bench_spinup_case_reports_steps_iterations_and_the_peer(capsys):
    """The spinup case to t = 1 s (20 steps of 0.05 s) on 4 elements, beside Exudyn when it is
    installed: steps, Newton iterations per step, and the lag both codes reach by then."""
    from spacarpy.bench.peers.exudyn_cantilever import available
    from spacarpy.bench.runner import run_bench
    peer = "exudyn" if available()[0] else None
    rows = run_bench(cases=("spinup",), sizes={"spinup": (4,)}, peer=peer,
                     spinup_t_end=1.0)["spinup"]
    assert len(rows) == 1 and "error" not in rows[0], rows
    row = rows[0]
    assert row["steps"] == 20 and row["iterations"] >= 20
    assert row["iters_per_step"] == pytest.approx(row["iterations"] / 20)
    assert np.isnan(row["its_constant"])        # t = 1 s: no step at constant speed
    assert "Spin-up of a flexible beam" in capsys.readouterr().out
    if peer:
        p = row["peer"]
        assert p["ok"] and p["steps"] == 20, p
        # t = 1 s: the tip barely lags (the rate is 0.17 rad/s); the codes agree to 1e-4 m
        assert abs(p["result"] - row["result"]) < 1e-4 + 1e-2 * abs(row["result"])
