"""The kinematic check (SPACAR mode 0) of mechanisms with redundant constraints (issue 17,
point 7): degrees of freedom and redundant constraints from the rank of the constraint
Jacobian, checked against the Grübler/Kutzbach count.

The spatial Grübler/Kutzbach count used below: n_b bodies including the ground, n_h revolute
joints (each removes 5 of the 6 relative motions of two bodies) give

    DOF - redundant = 6 (n_b - 1) - 5 n_h,

the count being exact when the redundant constraints are counted too. A planar four-bar in
space: n_b = 4, n_h = 4, so DOF - redundant = 18 - 20 = -2 (1 DOF, 3 redundant).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.deck import load_deck
from spacarpy.solvers.statics.diagnose import canonical_motions, dependent_rows, numerical_rank
from spacarpy.solvers.statics.equilibrium import StaticProblem
from spacarpy.solvers.statics.kinematic_check import kinematic_analysis

DECKS = Path(__file__).resolve().parents[1] / "decks"
PARALLELOGRAM = DECKS / "parallelogram_four_bar_3d.dat"


def grubler_spatial(n_bodies: int, n_hinges: int) -> int:
    """DOF - redundant of n_bodies (ground included) joined by n_hinges revolute joints."""
    return 6 * (n_bodies - 1) - 5 * n_hinges


def four_bar_without_last_releases() -> str:
    """decks/four_bar_linkage.dat without its last two RLSE lines ('RLSE 13 2 3', 'RLSE 12 2')."""
    text = (DECKS / "four_bar_linkage.dat").read_text()
    assert "RLSE 13 2 3 " in text and "RLSE 12 2\n" in text
    lines = [ln for ln in text.splitlines()
             if not ln.startswith(("RLSE 13 2 3", "RLSE 12 2"))]
    return "\n".join(lines) + "\n"


def test_parallelogram_four_bar_has_one_dof_and_three_redundant_constraints(capsys):
    """Point 7: three rigid BEAM links, four z-axis HINGEs with released rotations, no
    spring. Mode check reports 1 DOF (the crank angle) and 3 redundant constraints, exit 0;
    DOF - redundant = 6 (4 - 1) - 5 * 4 = -2 (Grübler/Kutzbach, spatial)."""
    assert main(["run", str(PARALLELOGRAM), "--mode", "check", "-q"]) == 0
    out = capsys.readouterr().out
    assert "kinematic check: a mechanism with 1 free motion, 3 redundant constraints\n" in out
    assert "constraints         32 (26 rigid deformation modes + 6 Euler normalizations), " \
           "rank 29: 3 redundant\n" in out
    assert "degrees of freedom  1 (30 free coordinates - rank 29 of the constraints), 1 of " \
           "them free motion that no stiffness resists (a mechanism)\n" in out
    assert "free motion 1       HINGE 21 mode 1 (the others held); nodes that move: 3, 5, " \
           "11, 12, 15, 16; released modes that change: HINGE 21 mode 1, HINGE 22 mode 1, " \
           "HINGE 23 mode 1, HINGE 24 mode 1\n" in out
    assert ("  redundant           HINGE 23 mode 2: 'RLSE 23 2' releases it\n"
            "                      HINGE 24 mode 2: 'RLSE 24 2' releases it\n"
            "                      HINGE 24 mode 3: 'RLSE 24 3' releases it\n") in out

    model = load_deck(PARALLELOGRAM)
    ka = kinematic_analysis(StaticProblem(model))
    assert ka.clear
    assert (ka.dof, len(ka.motions), len(ka.redundant)) == (1, 1, 3)
    assert ka.dof - len(ka.redundant) == grubler_spatial(4, 4) == -2
    assert ka.rank.dropped < 1e-14 and ka.rank.kept > 0.1          # a wide gap


def test_parallelogram_free_motion_is_the_crank_rotation():
    """The motion at unit crank rate (rad): B and C move at omega x r_AB = (-0.5, 0, 0) m,
    the crank's and the rocker's orientation nodes turn about z (dq3 = 1/2), the coupler
    translates without turning (its nodes 13, 14 keep their orientation)."""
    model = load_deck(PARALLELOGRAM)
    prob = StaticProblem(model)
    (motion,) = kinematic_analysis(prob).motions
    assert motion["driver"] == ("HINGE", 21, 1)
    v, num = motion["velocity"], prob.num
    pos = dict(zip(model.position_ids.tolist(), v[num.pos_idx]))
    rot = dict(zip(model.orientation_ids.tolist(), v[num.rot_idx]))
    np.testing.assert_allclose(pos[3], [-0.5, 0, 0], atol=1e-12)
    np.testing.assert_allclose(pos[5], [-0.5, 0, 0], atol=1e-12)
    for node in (11, 12, 15, 16):
        np.testing.assert_allclose(rot[node], [0, 0, 0, 0.5], atol=1e-12)
    for node in (9, 13, 14):
        np.testing.assert_allclose(rot[node], 0, atol=1e-12)


def test_parallelogram_with_the_advised_releases_has_no_redundant_constraint(tmp_path):
    deck = tmp_path / "released.dat"
    text = PARALLELOGRAM.read_text()
    assert "\nFIX 1\n" in text
    deck.write_text(text.replace("\nFIX 1\n", "\nRLSE 23 2\nRLSE 24 2 3\nFIX 1\n", 1))
    ka = kinematic_analysis(StaticProblem(load_deck(deck)))
    assert (ka.dof, len(ka.motions), ka.redundant) == (1, 1, [])
    assert ka.clear


def test_parallelogram_static_run_is_refused_with_the_same_diagnosis(tmp_path, capsys):
    """A static run cannot solve a mechanism under load: exit 3, the same report."""
    assert main(["run", str(PARALLELOGRAM), "-q", "-o", str(tmp_path / "p.h5")]) == 3
    err = capsys.readouterr().err
    assert "mechanism: 1 free motion(s) that no flexible element resists; nodes that move: " \
           "3, 5, 11, 12, 15, 16; motion 1 driven by HINGE 21 mode 1." in err
    assert "over-constrained: 3 redundant constraint(s): HINGE 23 mode 2 ('RLSE 23 2' " \
           "releases it); HINGE 24 mode 2 ('RLSE 24 2' releases it); HINGE 24 mode 3 " \
           "('RLSE 24 3' releases it)" in err


def test_four_bar_without_its_last_releases_satisfies_grubler(tmp_path, capsys):
    """decks/four_bar_linkage.dat without 'RLSE 13 2 3' and 'RLSE 12 2': 3 RBEAM links and
    4 HINGEs, the crank angle with a spring (a degree of freedom, but no free motion).
    DOF - redundant = 6 (4 - 1) - 5 * 4 = -2: 1 DOF and 3 redundant constraints; with the
    shipped releases 1 DOF and none."""
    deck = tmp_path / "fb.dat"
    deck.write_text(four_bar_without_last_releases())
    ka = kinematic_analysis(StaticProblem(load_deck(deck)))
    assert ka.clear
    assert (ka.dof, len(ka.motions), len(ka.redundant)) == (1, 0, 3)
    assert ka.dof - len(ka.redundant) == grubler_spatial(4, 4)
    assert main(["run", str(deck), "--mode", "check", "-q"]) == 0
    assert "degrees of freedom  1 (18 free coordinates - rank 17 of the constraints), no " \
           "free motion\n" in capsys.readouterr().out
    shipped = kinematic_analysis(StaticProblem(load_deck(DECKS / "four_bar_linkage.dat")))
    assert (shipped.dof, len(shipped.motions), shipped.redundant) == (1, 0, [])


def test_near_dead_point_says_the_rank_is_not_clear(tmp_path, capsys):
    """Two rigid trusses almost in line between fixed ends (a toggle 1e-8 from its dead
    point): a singular value 1e-8 of the largest lies in the gap, and the report says so
    instead of letting round-off decide."""
    deck = tmp_path / "toggle.dat"
    deck.write_text("X 1 0 0 0\nX 2 1 1e-8 0\nX 3 2 0 0\nTRUSS 1 1 2\nTRUSS 2 2 3\nFIX 1\n"
                    "FIX 3\nFIX 2 3\nEND\nHALT\nEND\nEND\n")
    ka = kinematic_analysis(StaticProblem(load_deck(deck)))
    assert not ka.clear
    assert main(["run", str(deck), "--mode", "check", "-q"]) == 0
    assert "NOT CLEAR: a singular value lies between the two" in capsys.readouterr().out


def test_rank_decision_has_a_gap_that_round_off_cannot_cross():
    rank, null, _ = numerical_rank(np.diag([1.0, 1e-3, 1e-16]))
    assert (rank.rank, rank.clear) == (2, True) and null.shape == (3, 1)
    assert rank.kept == pytest.approx(1e-3) and rank.dropped == pytest.approx(1e-16)
    rank, _, _ = numerical_rank(np.diag([1.0, 1e-7]))
    assert (rank.rank, rank.clear) == (1, False)           # inside the gap: zero, flagged


def redundant(rows) -> tuple[list, bool]:
    M = np.array(rows, dtype=float)
    M /= np.linalg.norm(M, axis=1)[:, None]
    _, _, left = numerical_rank(M, right=False, left=True)
    return dependent_rows(left)


def test_dependent_rows_are_the_later_rows_of_a_dependent_set():
    """Walking the rows in order, a row that repeats earlier ones is named, whatever basis
    of the left null space the SVD returns."""
    a, b, c, d = [1.0, 0, 0, 0], [0, 1.0, 0, 0], [1.0, 1.0, 0, 0], [0, 0, 1.0, 0]
    assert redundant([a, b, c]) == ([2], True)
    assert redundant([c, a, b]) == ([2], True)
    assert redundant([a, a, b]) == ([1], True)
    assert redundant([a, d, b, c, a, d]) == ([3, 4, 5], True)
    assert redundant([a, b, d]) == ([], True)


def test_canonical_motions_do_not_depend_on_the_null_space_basis():
    """Two orthonormal bases of one null space give the same motions."""
    rng = np.random.default_rng(3)
    n1, _ = np.linalg.qr(rng.standard_normal((6, 2)))
    rot = np.array([[np.cos(0.7), -np.sin(0.7)], [np.sin(0.7), np.cos(0.7)]])
    drivers = np.eye(6)
    m1, c1 = canonical_motions(n1, drivers)
    m2, c2 = canonical_motions(n1 @ rot, drivers)
    assert c1 == c2 == [0, 1]
    np.testing.assert_allclose(m1, m2, atol=1e-12)
    np.testing.assert_allclose(m1[:2], np.eye(2), atol=1e-12)


def test_the_report_in_docs_is_the_real_one(monkeypatch, capsys):
    """docs/multibody.md shows the parallelogram's report verbatim."""
    doc = (DECKS.parent / "docs" / "multibody.md").read_text()
    cmd = "$ spacarpy run decks/parallelogram_four_bar_3d.dat --mode check -q\n"
    shown = doc[doc.index(cmd) + len(cmd):].split("```", 1)[0]
    monkeypatch.chdir(DECKS.parent)
    assert main(["run", "decks/parallelogram_four_bar_3d.dat", "--mode", "check", "-q"]) == 0
    assert capsys.readouterr().out == shown
