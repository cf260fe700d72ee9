"""``spacarpy bench``: it runs its cases in child processes and writes the Markdown tables
(times are never asserted; the results each row reaches are)."""
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
    assert 0 < float(cells[12]) - 1.211296 < 2e-4
    # the whole-process column: `spacarpy run` as a subprocess, start-up and solve included
    assert float(cells[14]) > float(cells[3]) > 0
    f_row = [ln for ln in text.splitlines() if ln.startswith("| 8 |")][1]
    f1 = float(f_row.strip("|").split("|")[5])
    assert abs(f1 - 20.73) < 0.05           # first bending frequency of the steel cantilever


def test_bench_case_sizes_are_checked(capsys):
    assert main(["bench", "--case-sizes", "beam=10"]) == 2       # an input error, no traceback
    assert "expected CASE=N" in capsys.readouterr().err


@pytest.mark.slow
def test_bench_pendulum_case_times_the_whole_spacarpy_run(capsys):
    from spacarpy.bench import run_bench
    rows = run_bench(cases=("pendulum",), repeat=1)["pendulum"]
    assert len(rows) == 1 and "error" not in rows[0], rows
    assert rows[0]["command"] == "spacarpy run decks/pendulum_rigid_90deg.dat"
    assert rows[0]["whole"] == rows[0]["median"] > 0
    assert "spacarpy run decks/pendulum_rigid_90deg.dat" in capsys.readouterr().out
