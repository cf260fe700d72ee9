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
