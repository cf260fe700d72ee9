"""Planar models: PLBEAM, PLTRUSS and PLHINGE in the x-y plane (docs/deck.md, Planar models)."""
import re

import numpy as np
import pytest
from scipy.optimize import brentq

from spacarpy.bench.cases import TABLE1
from spacarpy.cli import main
from spacarpy.deck import job_from_text
from spacarpy.elements.registry import KINDS
from spacarpy.rotation import from_axis_angle
from spacarpy.solvers.linear.eigen import eigenmodes
from spacarpy.solvers.linear.linearize import MassAssembler, linearize
from spacarpy.solvers.statics.static import solve_static

from helpers import deck_errors, fd_columns, planar_four_bar_equilibrium


def planar_cantilever(n, variant, L=2.0, ei=1.725e6, ea=2.07e9, force=None):
    """Table 1's cantilever (L = 2 m, 0.1 m square steel, F = 3 EI / L^2) with PLBEAMs."""
    force = 3 * ei / L**2 if force is None else force
    lines = [f"DEFORMATIONS {variant}"]
    lines += [f"X {2 * i + 1} {L * i / n!r} 0" for i in range(n + 1)]
    lines += [f"PLBEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * i + 3} {2 * i + 4}" for i in range(n)]
    lines += [f"DYNE 1:{n} 1 2 3", "FIX 1", "FIX 2", "END", "HALT",
              f"ESTIFF 1:{n} {ea} {ei}", f"DELXF {2 * n + 1} 0 {force!r}",
              "ITERSTEP 20 10 1e-10", "END", "END", ""]
    return "\n".join(lines)


# ------------------------------------------------------------------ kernels
@pytest.mark.parametrize("keyword", ["PLBEAM", "PLTRUSS", "PLHINGE"])
def test_planar_kernels_have_exact_derivatives(keyword):
    """e, D and the weighted Hessian of every planar kind agree with central differences
    (in-plane configurations with some out-of-plane noise: the kernels are exact anyway)."""
    kind = KINDS[keyword]
    rng = np.random.default_rng(7)
    n = 12
    if keyword == "PLHINGE":
        x0 = [None, None]
        x = np.concatenate([from_axis_angle(rng.normal(size=(n, 3)), rng.normal(size=n)),
                            from_axis_angle(rng.normal(size=(n, 3)), rng.normal(size=n))], 1)
    else:
        xp = np.c_[rng.normal(size=(n, 2)), np.zeros(n)]
        xq = xp + np.c_[rng.uniform(0.5, 1.5, size=(n, 2)), np.zeros(n)]
        x0 = [xp, None, xq, None] if keyword == "PLBEAM" else [xp, xq]
        parts = [xp + 0.1 * rng.normal(size=(n, 3)), xq + 0.1 * rng.normal(size=(n, 3))]
        if keyword == "PLBEAM":
            qs = [from_axis_angle(rng.normal(size=(n, 3)), 0.3 * rng.normal(size=n))
                  for _ in range(2)]
            parts = [parts[0], qs[0], parts[1], qs[1]]
        x = np.concatenate(parts, axis=1)
    ref, _ = kind.reference(x0, np.full((n, 3), np.nan))
    prev = {}
    for variant in ("basic", "modified"):
        st = kind.state(x, ref, variant, prev)
        assert st.e.shape == (n, kind.n_def) and st.D.shape == (n, kind.n_def, kind.n_ldof)
        fd = fd_columns(lambda y: kind.state(y, ref, variant, prev).e, x)
        assert np.abs(fd - st.D).max() <= 1e-7 * np.abs(st.D).max()
        w = rng.normal(size=(n, kind.n_def))
        hess = kind.hessian(st, w)
        fd_h = fd_columns(lambda y: np.einsum("nk,nkj->nj", w,
                                              kind.state(y, ref, variant, prev).D), x)
        assert np.abs(fd_h - hess).max() <= 1e-6 * np.abs(hess).max()


# ------------------------------------------------------------------ verification
@pytest.mark.parametrize("variant", ["modified", "basic"])
def test_plbeam_cantilever_reproduces_table1(variant):
    """Table 1 of the paper with 8 PLBEAMs: the tip displacement to its six printed digits,
    the same as with the spatial BEAM."""
    model, settings = job_from_text(planar_cantilever(8, variant))
    assert model.planar
    res = solve_static(model, settings)
    tip = res.steps[-1].x[res.problem.num.pos_idx[list(model.position_ids).index(17)]]
    ref_u, ref_v = TABLE1[variant][8]
    assert 2.0 - tip[0] == pytest.approx(ref_u, abs=5e-7)
    assert tip[1] == pytest.approx(ref_v, abs=5e-7)
    assert tip[2] == 0.0
    prob = res.problem
    assert set(prob.reaction_component) == {"Fx", "Fy", "Mz"}       # no out-of-plane ones


def test_pltruss_two_bar_truss_matches_the_exact_nonlinear_equilibrium():
    """The shallow two-bar truss of test_multibody.py with PLTRUSS elements."""
    EA, h, half, P = 1e4, 0.3, 1.0, 50.0
    text = "\n".join([f"X 1 {-half} 0", f"X 3 0 {h}", f"X 5 {half} 0", "PLTRUSS 1 1 3",
                      "PLTRUSS 2 5 3", "DYNE 1 1", "DYNE 2 1", "FIX 1", "FIX 5", "END", "HALT",
                      f"ESTIFF 1:2 {EA}", f"DELXF 3 0 {-P}", "ITERSTEP 20 4 1e-12", "END",
                      "END", ""])
    res = solve_static(*job_from_text(text))
    apex = res.steps[-1].x[res.problem.num.pos_idx[1]]
    l0 = np.hypot(half, h)
    v = brentq(lambda v: 2 * EA * (np.hypot(half, h - v) - l0) / l0 * (h - v)
               / np.hypot(half, h - v) + P, 0.0, 0.1)
    assert apex[1] == pytest.approx(h - v, rel=1e-9)


FOUR_BAR = """\
# the four-bar of decks/four_bar_linkage.dat as a planar model: rigid PLBEAM links, each with
# its own angle nodes (the joints at B, C and D turn freely), a PLHINGE spring at A
X 1 0 0            # A
X 3 0 0.3          # B
X 5 1 0.8          # C
X 7 1 0            # D
PLBEAM 1 1 4 3 14  # crank A-B
PLBEAM 2 3 6 5 16  # coupler B-C
PLBEAM 3 7 8 5 18  # rocker D-C
PLHINGE 11 2 4     # ground (2) - crank at A, with the torsion spring
DYNE 11 1
FIX 1
FIX 7
FIX 2
END
HALT
ESTIFF 11 2.0
DELXF 5 1.5 0
ITERSTEP 20 5 1e-12
END
END
"""


def test_planar_four_bar_has_one_dof_no_redundancy_and_the_loop_closure_equilibrium(
        tmp_path, capsys):
    """In the plane the four-bar is not over-constrained (Grübler 3*3 - 2*4 = 1 DOF; here 4
    free position and 6 angle coordinates, 9 rigid link modes), unlike its spatial model (3
    redundant constraints); its equilibrium is the closed-form one."""
    deck = tmp_path / "fb.dat"
    deck.write_text(FOUR_BAR)
    assert main(["run", str(deck), "--mode", "check"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"degrees of freedom +1, no free motion", out)
    model, settings = job_from_text(FOUR_BAR)
    res = solve_static(model, settings)
    phi, c = planar_four_bar_equilibrium()
    x = res.steps[-1].x
    num = res.problem.num
    np.testing.assert_allclose(x[num.pos_idx[list(model.position_ids).index(5)]],
                               [c[0], c[1], 0.0], atol=1e-9)
    q = x[num.rot_idx[list(model.orientation_ids).index(4)]]
    assert 2 * np.arctan2(q[3], q[0]) == pytest.approx(phi, abs=1e-9)


def test_planar_pendulum_frequency_and_prescribed_angle():
    """A rigid PLBEAM rod (mass m at the tip) on a PLHINGE spring k: omega^2 = k / (m L^2).
    Turning the rod by INPUTX on its angle gives the spring moment k phi as reaction."""
    k, m, L = 3.0, 0.5, 2.0
    text = "\n".join(["X 1 0 0", f"X 3 {L} 0", "PLBEAM 1 1 4 3 6", "PLHINGE 10 2 4",
                      "DYNE 10 1", "FIX 1", "FIX 2", "END", "HALT", f"ESTIFF 10 {k}",
                      f"XM 3 {m}", "ITERSTEP 20 1 1e-12", "END", "END", ""])
    model, settings = job_from_text(text)
    res = solve_static(model, settings)
    st = res.steps[-1]
    lin = linearize(res.problem, st.x, st.mu, res.problem.loads.at(1.0, 1.0),
                    MassAssembler(model, res.problem.num))
    modes = eigenmodes(lin, res.problem.num, res.problem.free, n_modes=1)
    assert modes.frequency[0] == pytest.approx(np.sqrt(k / (m * L**2)) / (2 * np.pi), rel=1e-10)
    turned, turned_settings = job_from_text(text.replace("FIX 2\n", "FIX 2\nINPUTX 4 1\n")
                   .replace("XM 3", "DELINPX 4 1 0.3\nXM 3"))
    res = solve_static(turned, turned_settings)
    prob = res.problem
    reac = dict(zip(zip(prob.reaction_node.tolist(), prob.reaction_component),
                    res.steps[-1].reaction))
    assert reac[(4, "Mz")] == pytest.approx(k * 0.3, rel=1e-10)
    assert res.steps[-1].deformation["PLHINGE"][0, 0] == pytest.approx(0.3, abs=1e-12)


def test_planar_deck_errors():
    msgs = [m for _, m in deck_errors("X 1 0 0\nX 3 1 0\nBEAM 1 1 2 3 4\nEND\nEND\n")]
    assert ("X 1: expected x y z (3 coordinates), got 2; only a planar model (PLBEAM, PLTRUSS, "
            "PLHINGE) may leave out z") in msgs
    text = ("X 1 0 0\nX 3 1 0 0.5\nX 5 2 0\nPLBEAM 1 1 2 3 4\nTRUSS 2 3 5\nDYNE 1 1 2 3\n"
            "FIX 1\nFIX 2 2\nEND\nHALT\nESTIFF 1 1 1\nEM 1 1 2 3\nXF 3 1 2 3\nXF 4 1 1\n"
            "END\nEND\n")
    errors = deck_errors(text)
    msgs = [m for _, m in errors]
    assert "X 3: a planar model lies in the x-y plane, but z = 0.5" in msgs
    assert ("TRUSS: a planar model (PLBEAM at line 4) has planar elements only (PLBEAM, PLTRUSS, "
            "PLHINGE); model it in space instead") in msgs
    assert ("FIX: node 2 is a planar orientation node with coordinate 1 (its angle), got 2"
            in msgs)
    assert "EM 1: a PLBEAM takes rhoA [rhoIz], got 3 values" in msgs
    assert ("XF: node 4 is a planar orientation node: expected XF 4 m (the moment about z), "
            "got 2 value(s)") in msgs
    spatial = [m for _, m in deck_errors("X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4\nFIX 1\nFIX 2\nEND"
                                       "\nHALT\nDELXF 3 1 2\nEND\nEND\n")]
    assert "DELXF: expected three components (DELXF 3 f1 f2 f3), got 2" in spatial
