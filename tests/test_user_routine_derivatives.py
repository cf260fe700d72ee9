"""User routines' load derivatives and USERINP on prescribed deformations
(docs/user-routines.md): a stiff state-dependent routine load converges in statics (its
derivative in the Newton matrix, from derivative rows or difference quotients) to the closed
form; the difference quotients perturb only the coordinates a routine reads; the FIS contact
routines' derivative rows equal central differences of their loads; USERINP driving an
INPUTE deformation equals the deck's DELINPE with a time function."""
from __future__ import annotations

import sys

import numpy as np
import pytest
from test_user_routines import BASE, FIS, deck, run

from spacarpy.results import open_results

# the tip spring: k = 100 times the cantilever's tip stiffness 3 EI / L^3 = 30 N/m
SPRING = 3000.0
SPRING_ROUTINES = {
    "rows": """
        def spr(t, state):
            y = state.x[5][1]
            rows = [[5, 2, 0.1 * t - {k} * y]]
            if state.derivatives:
                return rows, [[5, 2, 5, 2, -{k}, 0.0]]
            return rows
        """,
    "quotients": """
        def spr(t, state):
            y = state.x[5][1]
            return [[5, 2, 0.1 * t - {k} * y]]
        """,
}


@pytest.mark.parametrize("form", sorted(SPRING_ROUTINES))
def test_static_routine_spring_has_its_derivative(tmp_path, form):
    """A tip spring 100 times stiffer than the cantilever, written as a routine load, with a
    tip force 0.1 N: the tip deflects P / (3 EI/L^3 + k). (Newton with the dead-load matrix
    alone diverges here: each iteration multiplies the error by about k L^3/3EI = 100.)"""
    path = deck(tmp_path, "spr", "USERSIG spr\nITERSTEP 10 2\n",
                routines={"spr": SPRING_ROUTINES[form].format(k=SPRING)})
    assert run(path, "--allow-user-code") == 0
    with open_results(path.with_suffix(".h5")) as r:
        y = r.static.position()[-1, -1, 1]
    # (small deflection: the geometric nonlinearity is (y/L)^2 ~ 1e-9)
    assert y == pytest.approx(0.1 / (3 * 10.0 + SPRING), rel=1e-6)


def test_difference_quotients_perturb_only_what_the_routine_reads(tmp_path):
    """The adapter's tangent of a routine that reads only node 5 costs one call plus one per
    free coordinate of node 5 (3), not one per free coordinate of the model (14), and
    equals the routine's derivative."""
    from spacarpy.deck import load
    from spacarpy.solvers.statics.equilibrium import StaticProblem
    from spacarpy.user_routines import loaded_routines
    path = deck(tmp_path, "spr", "USERSIG spr\nITERSTEP 10 2\n",
                routines={"spr": SPRING_ROUTINES["quotients"].format(k=SPRING)})
    job = load(path)
    prob = StaticProblem(job.model)
    user, _ = loaded_routines(job.model, prob.num, "static", path)
    x = prob.num.x0.copy()
    states = prob.evaluate(x, np.zeros(prob.n_multiplier), prob.loads.at(1.0, 0.0)).states
    free = np.flatnonzero(prob.free)
    calls = user.calls
    k = user.tangent(0.5, x, None, states, 0.0, free).toarray()
    assert user.calls - calls == 1 + 3 and user.gives_derivatives is False
    tip_y = prob.num.pos_idx[list(job.model.position_ids).index(5)][1]
    expected = np.zeros_like(k)
    expected[tip_y, list(free).index(tip_y)] = -SPRING
    np.testing.assert_allclose(k, expected, rtol=0, atol=1e-6 * SPRING)


def test_fis_contact_derivative_rows_equal_central_differences(monkeypatch):
    """FFESFVA's derivative rows (d/dx, d/dxd of each node's wall loads) against central
    differences of the whole routine, over 12 nodes in the three zones, moving and
    turning, the tip with its reduced radius."""
    monkeypatch.syspath_prepend(str(FIS))
    sys.modules.pop("fis_channel", None)
    import fis_channel as fc
    rng = np.random.default_rng(7)
    nodes = np.arange(1, 24, 2)                      # position nodes; orientation node + 1
    ids = np.arange(1, 26)
    x = {int(n): np.array([-0.004 * (n - 1), 0.0, 0.0]) for n in ids[::2]}
    for n in nodes:                                  # from zone I to deep in zone III
        x[int(n)][1:] += (fc.R_B - fc.R_OUTER) * rng.uniform(0.5, 1.6) * np.array(
            [np.cos(n), np.sin(n)])
    for n in ids[1::2]:
        q = np.array([1, 0.01, 0.02, -0.01]) + 1e-3 * rng.standard_normal(4)
        x[int(n)] = q / np.linalg.norm(q)
    xd = {n: 0.05 * rng.standard_normal(v.size) for n, v in x.items()}

    class State:
        def __init__(self, x, xd, derivatives):
            self.derivatives = derivatives
            self.x, self.xd = _Rows(x), _Rows(xd)

    loads, drows = fc.contact_rows(State(x, xd, True), nodes, 2, 40.0)
    assert drows.shape[1] == 6 and len(drows) > 100
    key = {(int(n), int(c)): i for i, (n, c, _) in enumerate(loads)}
    for which, h in ((0, 1e-9), (1, 1e-7)):          # d/dx (positions), d/dxd
        for n_w, c_w in {(int(r[2]), int(r[3])) for r in drows}:
            def f(step):
                xs = {k: v.copy() for k, v in x.items()}
                xds = {k: v.copy() for k, v in xd.items()}
                (xs, xds)[which][n_w][c_w - 1] += step
                return fc.contact_rows(State(xs, xds, False), nodes, 2, 40.0)[:, 2]
            hh = h if n_w % 2 else 1e-8 * (1 if which == 0 else 10)   # Euler parameters
            fd = (f(hh) - f(-hh)) / (2 * hh)
            got = np.zeros_like(fd)
            for r in drows[(drows[:, 2] == n_w) & (drows[:, 3] == c_w)]:
                got[key[(int(r[0]), int(r[1]))]] += r[4 + which]
            scale = max(np.abs(fd).max(), 1.0)
            np.testing.assert_allclose(got, fd, rtol=0, atol=1e-5 * scale)


class _Rows:
    def __init__(self, d):
        self.d = d

    def __getitem__(self, n):
        return np.stack([self.d[int(k)] for k in n]) if np.ndim(n) else self.d[int(n)]


# ---------------------------------------------------------------- USERINP on INPUTE
INPUTE_BASE = BASE.replace("DYNE 2 1 2 3 4 5 6", "DYNE 2 2 3 4 5 6")


def test_routine_motion_of_a_deformation_equals_the_deck_motion(tmp_path):
    """USERINP giving element 2's elongation e1 = 0.01 sin(2 pi t) with its exact rates
    (``{"e": rows}``) equals INPUTE with DELINPE 0.01 and TIMEFUNCTION sine 1: the tip's x
    follows 1 + e1."""
    def make(name, data, routines=None):
        path = tmp_path / f"{name}.dat"
        path.write_text(INPUTE_BASE.format(inputs="INPUTE 2 1\n", data=data))
        for mod, code in (routines or {}).items():
            (tmp_path / f"{mod}.py").write_text(code)
        return path
    data = "TIMESTEP 0.5 40\n"
    # (VELOCITY on the clamped node: the reference, too, starts with the velocities made
    # consistent with the prescribed rate, as a routine's motion does)
    ref = make("ref", "INPUTE 2 1 0 0 0\nDELINPE 2 1 0.01\nTIMEFUNCTION sine 1\n"
               "VELOCITY 1 0 0 0\n" + data)
    usr = make("usr", "USERINP mv\n" + data, {"mv": (
        "import math\n\n\ndef mv(t):\n    w = 2 * math.pi\n"
        "    return {'e': [[2, 1, 0.01 * math.sin(w * t), 0.01 * w * math.cos(w * t),\n"
        "                   -0.01 * w * w * math.sin(w * t)]]}\n")})
    assert run(ref, "--mode", "transient") == 0
    assert run(usr, "--mode", "transient", "--allow-user-code") == 0
    with open_results(ref.with_suffix(".h5")) as a, open_results(usr.with_suffix(".h5")) as b:
        t = a.transient.time
        pa, pb = a.transient.position(), b.transient.position()
        np.testing.assert_allclose(pa[:, -1, 0], 1 + 0.01 * np.sin(2 * np.pi * t), atol=5e-5)
        np.testing.assert_allclose(pb, pa, rtol=0, atol=1e-9)
        np.testing.assert_allclose(b.transient.velocity(), a.transient.velocity(), rtol=0,
                                   atol=1e-7)


def test_routine_motion_of_an_undeclared_deformation_is_refused(tmp_path, capsys):
    path = tmp_path / "mv.dat"
    path.write_text(INPUTE_BASE.format(inputs="INPUTE 2 1\n", data="USERINP mv\n"
                                       "TIMESTEP 0.1 2\n"))
    (tmp_path / "mv.py").write_text("def mv(t):\n    return {'e': [[1, 1, 0.0, 0, 0]]}\n")
    assert run(path, "--mode", "transient", "--allow-user-code") == 6
    assert "gives element 1 mode 1, which is not a prescribed deformation (declare it " \
           "with INPUTE)" in capsys.readouterr().err
    (tmp_path / "mv.py").write_text("def mv(t):\n    return {'y': []}\n")
    assert run(path, "--mode", "transient", "--allow-user-code") == 6
    assert "returned a dict with the key(s) ['y']" in capsys.readouterr().err
