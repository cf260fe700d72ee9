"""spacarpy plot: every kind of figure is written (PNG/PDF) from real result files; requests
the file cannot answer exit with 2. Needs matplotlib (the ``plot`` extra, part of ``test``)."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="plots need the optional matplotlib (pip install "
                                         "\"spacarpy[plot]\")")

from spacarpy.cli import main  # noqa: E402
from spacarpy.results import open_results  # noqa: E402
from spacarpy.results.plot import centre_lines, make_figure  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def files(result_files):
    return result_files


@pytest.mark.parametrize("key, argv", [
    ("bend", ["shape", "--all-steps", "--view", "25", "-125"]),
    ("bend", ["load-displacement", "--node", "3"]),
    ("bend", ["history", "--node", "1", "--quantity", "reaction"]),
    ("frame", ["shape", "--scale", "100"]),
    ("frame", ["history", "--element", "1", "--quantity", "stress"]),
    ("column", ["frequency"]),
    ("column", ["buckling"]),
    ("column", ["mode", "--mode", "2", "--step", "2"]),
    ("column", ["buckling-mode"]),
    ("failed", ["shape"]),
])
def test_plot_kinds_write_images(files, tmp_path, capsys, key, argv):
    out = tmp_path / "figure.png"
    assert main(["plot", str(files[key]), *argv, "-o", str(out)]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    assert out.read_bytes()[:8] == PNG and out.stat().st_size > 10_000


def test_default_name_and_pdf(files, tmp_path, capsys):
    pdf = tmp_path / "bend.pdf"
    assert main(["plot", str(files["bend"]), "load-displacement", "-o", str(pdf)]) == 0
    assert pdf.read_bytes()[:5] == b"%PDF-"
    assert main(["plot", str(files["column"]), "frequency"]) == 0       # default name
    default = files["column"].with_name("column_frequency.png")
    assert capsys.readouterr().out.split()[-1] == str(default) and default.exists()
    default.unlink()


def test_plot_errors_exit_2(files, tmp_path, capsys):
    out = str(tmp_path / "x.png")
    for argv, message in (
            ([str(files["bend"]), "frequency"], "has no frequencies"),
            ([str(files["bend"]), "history", "--quantity", "stress"], "give --element"),
            ([str(files["bend"]), "load-displacement", "--node", "4"], "position node 4"),
            ([str(files["column"]), "mode", "--mode", "7"], "modes are numbered 1..3")):
        assert main(["plot", *argv, "-o", out]) == 2, argv
        assert message in capsys.readouterr().err


def test_centre_lines_pass_through_the_nodes_with_the_nodal_tangents(files):
    res = open_results(files["bend"])
    s, m = res.static, res.model
    lines = centre_lines(res, s.position(step=-1), s.euler(step=-1), n_sub=8)
    rows = m.element_position_rows
    np.testing.assert_allclose(lines[:, 0], s.position(step=-1)[rows[:, 0]], atol=1e-12)
    np.testing.assert_allclose(lines[:, -1], s.position(step=-1)[rows[:, 1]], atol=1e-12)
    # undeformed: the curve of a straight element is the straight chord
    euler0 = np.tile([1.0, 0, 0, 0], (m.n_rot, 1))
    flat = centre_lines(res, m.position_x0, euler0, n_sub=4)
    chord = m.position_x0[rows[:, 1]] - m.position_x0[rows[:, 0]]
    np.testing.assert_allclose(flat[:, 2], m.position_x0[rows[:, 0]] + chord / 2, atol=1e-12)


def test_figures_are_built_without_pyplot(files):
    import sys
    fig = make_figure(open_results(files["bend"]), "shape")
    assert fig.axes and "matplotlib.pyplot" not in sys.modules
