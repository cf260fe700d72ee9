"""Command-line edges that used to end in a traceback (report N8): ``plot animate --fps``
values and a SIGTERM while :func:`spacarpy.cli.main` restores the previous handler."""
import os
import signal
import sys

import pytest

from spacarpy.cli import main

m = sys.modules["spacarpy.cli.main"]        # the module (spacarpy.cli.main is the function)


@pytest.mark.parametrize("fps", ["0", "-3", "nan", "inf", "x"])
def test_plot_fps_must_be_a_finite_positive_number(tmp_path, fps, capsys):
    # argparse refuses before the file is opened: the file need not exist
    assert main(["plot", str(tmp_path / "r.h5"), "animate", "--fps", fps]) == 2
    err = capsys.readouterr().err
    assert "expected a finite number > 0" in err and "Traceback" not in err


def test_sigterm_while_the_handler_is_restored_is_exit_143(monkeypatch, capsys):
    """The SIGTERM lands after the command's work, as main() puts the old handler back:
    exit 143 and one line, not a Terminated traceback."""
    def work(args):
        return 0

    real_restore = m._restore_sigterm

    def restore(previous):
        os.kill(os.getpid(), signal.SIGTERM)     # our handler is still installed here
        real_restore(previous)

    monkeypatch.setattr(m, "_main", work)
    monkeypatch.setattr(m, "_restore_sigterm", restore)
    before = signal.getsignal(signal.SIGTERM)
    try:
        assert m.main(["validate", "x.h5"]) == 143
    finally:
        signal.signal(signal.SIGTERM, before)
    assert "terminated (SIGTERM)" in capsys.readouterr().err
    assert signal.getsignal(signal.SIGTERM) == before


# -- N7: bench outside a checkout, failed cases ---------------------------------------------

def test_bench_finds_the_decks_in_the_working_directory(tmp_path, monkeypatch):
    """After a non-editable install the decks are not beside the package: the current
    directory's decks/ is looked in."""
    from spacarpy.bench import runner
    monkeypatch.chdir(tmp_path)
    assert tmp_path / "decks" in runner.deck_dirs()


def test_bench_with_a_missing_deck_fails_and_writes_no_table(tmp_path, monkeypatch, capsys):
    from spacarpy.bench import runner
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(runner, "deck_dirs", lambda: [tmp_path / "a", tmp_path / "decks"])
    md = tmp_path / "perf.md"
    assert main(["bench", "--cases", "pendulum", "--repeat", "1", "--markdown",
                 str(md)]) == 1
    captured = capsys.readouterr()
    assert "no deck pendulum_rigid_90deg.dat" in captured.out
    assert str(tmp_path / "decks") in captured.out
    assert "not written: 1 case(s) failed" in captured.out
    assert "bench: 1 case(s) failed: pendulum" in captured.err
    assert not md.exists()


@pytest.mark.parametrize("value", ["-1", "0", "nan", "inf"])
def test_bench_spinup_t_end_is_checked(value, capsys):
    assert main(["bench", "--cases", "spinup", "--spinup-t-end", value]) == 2
    assert "expected a finite number > 0" in capsys.readouterr().err


# -- N12: units of the time histories of element quantities ---------------------------------

def test_hinge_time_histories_carry_units(tmp_path, capsys):
    """The pendulum's HINGE: the joint angle in rad, the moments in N m."""
    from pathlib import Path
    deck = Path(__file__).resolve().parents[1] / "decks" / "pendulum_rigid_90deg.dat"
    out = tmp_path / "p.h5"
    assert main(["run", str(deck), "-q", "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["extract", str(out), "time_deformation", "--csv"]) == 0
    head = capsys.readouterr().out.splitlines()[0]
    assert head == "time [s],step,element,e1 [rad],e2,e3"
    assert main(["extract", str(out), "time_stress_resultant", "--csv"]) == 0
    head = capsys.readouterr().out.splitlines()[0]
    assert head == "time [s],step,element,s1 [N m],s2 [N m],s3 [N m]"


def test_the_energy_plot_legend_leaves_the_curves_free(tmp_path):
    """The pendulum's energy history: the legend lies outside the axes (it covered the
    curve), and is kept in the saved image (bbox_inches='tight')."""
    pytest.importorskip("matplotlib")
    from pathlib import Path

    from spacarpy.results import open_results
    from spacarpy.results.plot import make_figure
    deck = Path(__file__).resolve().parents[1] / "decks" / "pendulum_rigid_90deg.dat"
    out = tmp_path / "p.h5"
    assert main(["run", str(deck), "-q", "-o", str(out)]) == 0
    with open_results(out) as res:
        fig = make_figure(res, "history", quantity="energy")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    ax = fig.axes[0]
    renderer = canvas.get_renderer()
    legend = ax.get_legend().get_window_extent(renderer)
    axes = ax.get_window_extent(renderer)
    assert legend.x0 >= axes.x1                     # right of the axes: no overlap
    assert len(ax.get_legend().get_texts()) >= 3    # kinetic, potential, total ...
    assert main(["plot", str(out), "history", "--quantity", "energy", "-o",
                 str(tmp_path / "e.png")]) == 0


@pytest.mark.parametrize("argv, expected", [
    (["batch", "d", "--run-args", "--modes-per-step"], "--modes-per-step"),
    (["batch", "d", "--run-args", "--modes-per-step --modes 4"], "--modes-per-step --modes 4"),
    (["batch", "d", "--run-args=--modes 4"], "--modes 4"),
    (["sweep", "d", "--set", "a=1,2", "--run-args", "-v"], "-v"),
])
def test_run_args_take_a_value_that_starts_with_a_dash(argv, expected):
    """Report N11: ``--run-args '--modes-per-step'`` (one quoted option, as the help shows)
    failed with "expected one argument"; it is the value of --run-args."""
    from spacarpy.cli.common import join_option_strings
    args = m.build_parser().parse_args(join_option_strings(argv))
    assert args.run_args == expected


@pytest.mark.slow
def test_batch_passes_a_quoted_run_option_to_its_runs(tmp_path):
    """End to end: the quoted option reaches every run (frequencies at every load step)."""
    import shutil
    from pathlib import Path

    import h5py
    deck = Path(__file__).resolve().parents[1] / "decks" / "column_pinned_axial_load_16el.dat"
    shutil.copy(deck, tmp_path / deck.name)
    assert main(["batch", str(tmp_path / deck.name), "-q", "-j", "1", "--output-dir",
                 str(tmp_path / "out"), "--run-args", "--modes-per-step"]) == 0
    (result,) = (tmp_path / "out").glob("*.h5")
    with h5py.File(result, "r") as f:
        n_steps = f["static/load_factor"].shape[0]
        assert n_steps > 1 and f["eigen/frequency"].shape[0] == n_steps
