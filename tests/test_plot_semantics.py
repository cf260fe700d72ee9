"""What the figures say (issue 35, item 4), not how they look: planar models on 2-D axes and
3-D models on 3-D axes, a torsion mode drawn as a twist of its section band by exactly the
mode's rotation times the stated amplitude, bounded magnifications, one unit per y axis with
its label, the energy balance T + U + D - W of the file on its own axis, and progress from
``plot animate``. Needs matplotlib (the ``plot`` extra, part of ``test``)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="plots need the optional matplotlib (pip install "
                                         "\"spacarpy[plot]\")")

from spacarpy.cli import main  # noqa: E402
from spacarpy.results import open_results  # noqa: E402
from spacarpy.results.plot import make_figure  # noqa: E402
from spacarpy.results.plot_geometry import (  # noqa: E402
    from_rotation_vector,
    magnify,
    mode_configuration,
    mode_rotation,
    plane_of,
    rotation_vector,
    section_ribbons,
)
from spacarpy.results.plot_shapes import auto_scale, mode_amplitude  # noqa: E402

DECKS = Path(__file__).resolve().parents[1] / "decks"


@pytest.fixture(scope="module")
def files(result_files):
    return result_files


@pytest.fixture(scope="module")
def cantilever(tmp_path_factory) -> Path:
    """decks/cantilever_modes_16el.dat: mode 1 is the 0.353 Hz torsion mode."""
    out = tmp_path_factory.mktemp("cantilever") / "cantilever.h5"
    assert main(["run", str(DECKS / "cantilever_modes_16el.dat"), "-o", str(out), "-q"]) == 0
    return out


def _is_3d(ax) -> bool:
    return ax.name == "3d"


@pytest.mark.parametrize("key, kind, options, plane", [
    ("transient", "shape", {"time": [0.05, 0.1]}, (0, 1)),   # the pendulum swings in x-y
    ("planar", "shape", {}, (0, 1)),                          # PLBEAM, PLHINGE
    ("frame", "shape", {}, (0, 2)),                           # the portal frame is in x-z
    ("pltruss", "shape", {}, (0, 1)),                         # PLTRUSS
    ("bend", "shape", {}, None),                              # the 45-degree bend is 3-D
    ("fourbar", "shape", {}, (0, 1))])                        # HINGE, RBEAM in x-y
def test_planar_models_are_drawn_in_their_plane(files, key, kind, options, plane):
    fig = make_figure(open_results(files[key]), kind, **options)
    ax = fig.axes[0]
    assert fig.spacarpy_plane == plane
    assert _is_3d(ax) == (plane is None)
    if plane is not None:
        assert ax.get_xlabel() == f"{'xyz'[plane[0]]} [m]"
        assert ax.get_ylabel() == f"{'xyz'[plane[1]]} [m]"
        assert ax.get_aspect() == 1.0                           # equal scales


def test_plane_of_needs_points_and_rotations_in_the_plane():
    line = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    assert plane_of(line) == (0, 1)
    assert plane_of(line, [[0.0, 0.0, 0.3]]) == (0, 1)           # turning about z
    assert plane_of(line, [[0.0, 0.3, 0.0]]) == (0, 2)           # turning about y
    assert plane_of(line, [[0.3, 0.0, 0.0]]) is None             # a twist: 3-D
    assert plane_of([[0.0, 0, 0], [1.0, 1.0, 1e-3]]) is None


def test_torsion_mode_is_drawn_as_twist(cantilever):
    res = open_results(cantilever)
    e, s = res.eigen, res.static
    k = int(e.step[e.row(None)])
    shape = e.shape(mode=1, step=k)
    pos, eul = s.position(step=k), s.euler(step=k)
    rot = mode_rotation(eul, shape.euler)                   # rad per unit amplitude
    tip = int(np.argmax(np.linalg.norm(rot, axis=1)))
    assert abs(rot[tip, 0]) > 1e6 * np.max(np.abs(shape.position))  # a pure torsion
    fig = make_figure(res, "mode", mode=1)
    amp = fig.spacarpy_scale
    assert _is_3d(fig.axes[0]) and fig.spacarpy_plane is None
    # bounded: the largest rotation drawn is 0.5 rad, not 5e7 times a tiny displacement
    assert amp * np.linalg.norm(rot[tip]) == pytest.approx(0.5, rel=1e-12)
    assert amp * np.max(np.linalg.norm(shape.position, axis=1)) <= 0.15
    assert "rotation 28.6 deg" in fig.axes[0].get_title()
    # the band at the tip is turned about the beam's axis by amplitude x the mode's rotation
    drawn_pos, drawn_eul = mode_configuration(pos, eul, shape, amp)
    _, across = section_ribbons(res, drawn_pos, drawn_eul, 1.0)
    _, across0 = section_ribbons(res, pos, eul, 1.0)
    a, b = across0[-1, -1], across[-1, -1]                  # the last beam's free end
    twist = np.arctan2(np.dot(np.cross(a, b), [1.0, 0, 0]), np.dot(a, b))
    np.testing.assert_allclose(abs(twist), amp * abs(rot[-1, 0]), rtol=1e-9)
    assert abs(twist) > 0.45                                # visible: about 28 degrees


def test_bending_mode_keeps_the_displacement_rule(cantilever):
    res = open_results(cantilever)
    fig = make_figure(res, "mode", mode=2)
    shape = res.eigen.shape(mode=2, step=None)
    u = np.max(np.linalg.norm(shape.position, axis=1))
    assert fig.spacarpy_scale * u == pytest.approx(0.15 * 1.0, rel=1e-12)   # L = 1 m
    assert fig.spacarpy_plane is not None                   # a bending mode in a plane


@pytest.mark.parametrize("u, size, rot, factor", [
    (0.0, 1.0, 0.01, 50.0),            # a pure small twist: 0.5 / 0.01 = 50
    (0.0007143, 0.12, 0.0365, 10.0),   # the leaf-spring guidance: both rules give 10
    (1e-3, 1.0, 0.02, 20.0),           # the rotation limits: 0.5 / 0.02 = 25 -> 20
    (0.0, 1.0, 0.2, 1.0),              # a rotation of 0.2 rad is visible at true scale
    (0.0, 1.0, 0.0, 1.0)])
def test_auto_scale_counts_rotations(u, size, rot, factor):
    assert auto_scale(u, size, rot) == factor
    assert factor * rot <= 0.5 and factor * u <= 0.1 * size


def test_mode_amplitude_is_bounded():
    assert mode_amplitude(2.79e-10, 2.0, 1.0) == 0.25          # torsion: 0.5 rad
    assert mode_amplitude(1.0, 0.1, 2.0) == pytest.approx(0.3)  # bending: 15 % of L
    assert mode_amplitude(0.0, 0.0, 1.0) == 1.0


def test_magnify_multiplies_rotation_vectors_exactly(files):
    res = open_results(files["bend"])
    m = res.model
    eul = from_rotation_vector(np.tile([0.0, 0.0, 0.01], (m.n_rot, 1)))
    pos, big = magnify(m, m.position_x0, eul, 20.0)
    np.testing.assert_allclose(rotation_vector(big)[:, 2], 0.2, rtol=1e-12)
    np.testing.assert_array_equal(pos, m.position_x0)


def test_history_has_one_unit_per_labelled_axis(files):
    fig = make_figure(open_results(files["bend"]), "history", quantity="section_forces",
                      element=1)
    labels = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel()]
    assert labels == ["section forces: force [N]", "section forces: moment [N m]"]
    names = [[ln.get_label() for ln in ax.lines] for ax in fig.axes[:2]]
    assert names == [["N"], ["T", "My_p", "My_q", "Mz_p", "Mz_q"]]
    fig = make_figure(open_results(files["transient"]), "history", quantity="position",
                      node=3)
    assert fig.axes[0].get_ylabel() == "position [m]"
    assert fig.axes[0].get_xlabel() == "time [s]"


def test_energy_plot_shows_the_balance_of_the_file(files):
    res = open_results(files["transient"])
    tr = res.transient
    fig = make_figure(res, "history", quantity="energy")
    top, low = fig.axes[:2]
    assert top.get_ylabel() == "energy [J]" and low.get_ylabel() == "energy balance [J]"
    balance = tr.kinetic_energy + tr.elastic_energy + tr.dissipated_energy - tr.external_work
    x, y = low.lines[0].get_data()
    np.testing.assert_array_equal(x, tr.time)
    np.testing.assert_allclose(y, balance, rtol=0, atol=1e-12 * np.max(tr.kinetic_energy))
    assert low.get_ylim()[1] - low.get_ylim()[0] < 0.01 * np.max(tr.kinetic_energy)
    drift = np.max(np.abs(balance - balance[0]))
    assert f"largest |change| {drift:.3g} J" in low.get_title()


def test_shapes_at_several_times_are_labelled(files):
    res = open_results(files["transient"])
    fig = make_figure(res, "shape", time=[0.05, 0.1])
    bars = [ax for ax in fig.axes if ax.get_ylabel() == "time [s]"]
    assert len(bars) == 1
    np.testing.assert_allclose(bars[0].get_yticks(), [0.05, 0.1], rtol=1e-9)


def test_animate_prints_progress_unless_quiet(files, tmp_path, capsys):
    out = tmp_path / "pendulum.gif"
    assert main(["plot", str(files["transient"]), "animate", "--frames", "4", "-o",
                 str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.out.strip() == str(out)
    assert "animate: frame 4/4" in captured.err
    assert main(["plot", str(files["transient"]), "animate", "--frames", "4", "-q", "-o",
                 str(out)]) == 0
    assert capsys.readouterr().err == ""
