"""User routines in Python (USERSIG, USERINP; docs/user-routines.md): a routine's load or
motion gives the same results as the same load or motion written in the deck; code named in
a deck runs only with --allow-user-code (run, batch, sweep); a failing routine stops the run
with one clear message and its completed steps kept."""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.errors import EXIT_USER_CODE_REFUSED, EXIT_USER_ROUTINE
from spacarpy.results import open_results

# a two-element cantilever along x, clamped at node 1 (orientation node 2)
BASE = """\
BEAM 1 1 2 3 4 0 1 0
BEAM 2 3 4 5 6 0 1 0
X 1 0 0 0
X 3 0.5 0 0
X 5 1 0 0
FIX 1
FIX 2
DYNE 1 1 2 3 4 5 6
DYNE 2 1 2 3 4 5 6
{inputs}END
HALT
ESTIFF 1 1e6 10 10 10
ESTIFF 2 1e6 10 10 10
EM 1 1 0.01
EM 2 1 0.01
{data}END
END
"""


def deck(tmp_path, name, data, inputs="", routines=None) -> Path:
    path = tmp_path / f"{name}.dat"
    path.write_text(BASE.format(data=data, inputs=inputs))
    for mod, code in (routines or {}).items():
        (tmp_path / f"{mod}.py").write_text(textwrap.dedent(code))
    return path


def run(path, *extra, out=None) -> int:
    out = out or path.with_suffix(".h5")
    return main(["run", str(path), "-o", str(out), "-q", *extra])


# ---------------------------------------------------------------- same as the deck's form
def test_static_routine_load_equals_the_deck_load(tmp_path):
    """A force and a moment (as Euler-parameter forces 2 Lambda^T M at the current
    orientation) growing with the load factor t equal DELXF lines over 5 load steps."""
    ref = deck(tmp_path, "ref", "DELXF 5 0 1 0\nDELXF 6 0 0 2\nITERSTEP 10 5\n")
    usr = deck(tmp_path, "usr", "USERSIG ld\nITERSTEP 10 5\n", routines={"ld": """
        from spacarpy.user_routines import euler_moment

        def ld(t, state):
            m = euler_moment(state.x[6], [0, 0, 2 * t])
            return [[5, 2, t]] + [[6, k + 1, v] for k, v in enumerate(m)]
        """})
    assert run(ref) == 0 and run(usr, "--allow-user-code") == 0
    with open_results(ref.with_suffix(".h5")) as a, open_results(usr.with_suffix(".h5")) as b:
        pa, pb = a.static.position(), b.static.position()
        assert np.abs(pa[-1, -1] - pa[0, -1]).max() > 0.1        # a large deflection
        np.testing.assert_allclose(pb, pa, rtol=0, atol=1e-10)
        np.testing.assert_allclose(b.static.euler(), a.static.euler(), rtol=0, atol=1e-10)
        np.testing.assert_allclose(b.static.load_factor, a.static.load_factor)


def test_transient_routine_load_equals_the_deck_load(tmp_path):
    """F(t) = sin(4 pi t) on the tip from a routine equals DELXF with TIMEFUNCTION sine 2,
    step by step; the routine sees the stored velocities (it records xd of the tip)."""
    data = "TIMESTEP 0.5 50\n"
    ref = deck(tmp_path, "ref", "DELXF 5 0 1 0\nTIMEFUNCTION sine 2\n" + data)
    usr = deck(tmp_path, "usr", "USERSIG ldt\n" + data, routines={"ldt": """
        import math

        SEEN = []

        def ldt(t, state):
            SEEN.append((t, state.xd[5][1], state.e[2][0], state.ed[2][2]))
            return [[5, 2, math.sin(2 * math.pi * 2 * t)]]
        """})
    assert run(ref, "--mode", "transient") == 0
    assert run(usr, "--mode", "transient", "--allow-user-code") == 0
    with open_results(ref.with_suffix(".h5")) as a, open_results(usr.with_suffix(".h5")) as b:
        pa, pb = a.transient.position(), b.transient.position()
        assert np.abs(pa[:, -1, 1]).max() > 0.05
        np.testing.assert_allclose(pb, pa, rtol=0, atol=1e-10)
        np.testing.assert_allclose(b.transient.velocity(), a.transient.velocity(), rtol=0,
                                   atol=1e-8)


def test_routine_state_holds_the_solver_state(tmp_path):
    """What a routine sees at the converged state of a stored step is that step's state:
    the tip's velocity, element 2's deformation and deformation rate."""
    usr = deck(tmp_path, "usr", "USERSIG rec\nTIMESTEP 0.2 4\n", routines={"rec": """
        import json, math, os

        def rec(t, state):
            with open(os.path.join(os.path.dirname(__file__), "seen.jsonl"), "a") as f:
                f.write(json.dumps([t, list(state.x[5]), list(state.xd[5]), list(state.e[2]),
                                    list(state.ed[2]), list(state.x[[5, 3]].shape)]) + "\\n")
            return [[5, 2, math.sin(10 * t)]]
        """})
    assert run(usr, "--mode", "transient", "--allow-user-code") == 0
    import json
    seen = [json.loads(ln) for ln in (tmp_path / "seen.jsonl").read_text().splitlines()]
    with h5py.File(usr.with_suffix(".h5")) as f:
        rate = f["transient/elements/BEAM/deformation_rate"][:]
    with open_results(usr.with_suffix(".h5")) as r:
        tr = r.transient
        times = tr.time
        for k in range(1, len(times)):
            # the last call at a stored time is at the step's last Newton iterate: its
            # positions are the stored ones to the tolerance, its velocities (updated
            # with the last increment) to 1e-3 relative
            calls = [s for s in seen if s[0] == pytest.approx(times[k], abs=1e-12)]
            t, x, xd, e, ed, shape = calls[-1]
            np.testing.assert_allclose(x, tr.position()[k, 2], atol=1e-9)
            np.testing.assert_allclose(xd, tr.velocity()[k, 2], rtol=1e-3, atol=1e-7)
            np.testing.assert_allclose(e, tr.deformation(2, k), atol=1e-9)
            np.testing.assert_allclose(ed, rate[k, 1], rtol=1e-3, atol=1e-7)
            assert abs(ed[4]) > 1e-3
            assert shape == [2, 3]


def test_routine_motion_equals_the_deck_motion(tmp_path):
    """USERINP giving y = 0.1 sin(2 pi t) with its exact rates on the tip equals INPUTX with
    DELINPX 0.1 and TIMEFUNCTION sine 1."""
    data = "TIMESTEP 0.5 40\n"
    # (VELOCITY on the clamped node: the reference, too, starts with the velocities made
    # consistent with the prescribed one, as a routine's motion does)
    ref = deck(tmp_path, "ref", "INPUTX 5 2 0 0 0\nDELINPX 5 2 0.1\nTIMEFUNCTION sine 1\n"
               "VELOCITY 1 0 0 0\n" + data, inputs="INPUTX 5 2\n")
    usr = deck(tmp_path, "usr", "USERINP mv\n" + data, inputs="INPUTX 5 2\n",
               routines={"mv": """
        import math

        def mv(t):
            w = 2 * math.pi
            return [[5, 2, 0.1 * math.sin(w * t), 0.1 * w * math.cos(w * t),
                     -0.1 * w * w * math.sin(w * t)]]
        """})
    assert run(ref, "--mode", "transient") == 0
    assert run(usr, "--mode", "transient", "--allow-user-code") == 0
    with open_results(ref.with_suffix(".h5")) as a, open_results(usr.with_suffix(".h5")) as b:
        pa, pb = a.transient.position(), b.transient.position()
        np.testing.assert_allclose(pa[:, -1, 1], 0.1 * np.sin(2 * np.pi * a.transient.time),
                                   atol=1e-12)
        assert np.abs(pa[:, 1, 1]).max() > 0.01          # the middle node follows
        np.testing.assert_allclose(pb, pa, rtol=0, atol=1e-8)


# ---------------------------------------------------------------- the security refusal
def _sig_deck(tmp_path):
    return deck(tmp_path, "usr", "USERSIG ld\nITERSTEP 10 2\n",
                routines={"ld": "def ld(t, state):\n    return [[5, 2, t]]\n"})


def test_run_refuses_user_code_without_the_flag(tmp_path, capsys):
    path = _sig_deck(tmp_path)
    (tmp_path / "ld.py").write_text("open('ran', 'w')\ndef ld(t, state):\n    return []\n")
    assert run(path) == EXIT_USER_CODE_REFUSED == 5
    err = capsys.readouterr().err
    assert f"{path}:16:1: error: USERSIG ld names user code" in err
    assert "--allow-user-code" in err and "Traceback" not in err
    assert not list(tmp_path.glob("*.h5")) and not (tmp_path / "ran").exists()
    assert not (Path.cwd() / "ran").exists()


def test_batch_and_sweep_refuse_user_code_without_the_flag(tmp_path, capsys):
    path = _sig_deck(tmp_path)
    out = tmp_path / "reports"
    assert main(["batch", str(tmp_path), "-j", "1", "-q", "--output-dir", str(out)]) == 5
    err = capsys.readouterr().err
    assert f"{path}:16:1: USERSIG ld: error: names user code" in err
    assert "--allow-user-code" in err and not out.exists()
    assert main(["batch", str(tmp_path), "-j", "1", "-q", "--allow-user-code"]) == 0
    swept = tmp_path / "sweep"
    swept.mkdir()
    sw = swept / "sw.dat"
    sw.write_text("SET F 1\n" + path.read_text().replace("ITERSTEP 10 2", "DELXF 3 0 {F} 0"))
    (swept / "ld.py").write_text((tmp_path / "ld.py").read_text())
    target = swept / "sw_sweep.h5"
    assert main(["sweep", str(sw), "--set", "F=1,2", "-j", "1", "-q"]) == 5
    err = capsys.readouterr().err
    assert f"{sw}:17:1: USERSIG ld: error: names user code" in err and not target.exists()
    assert main(["sweep", str(sw), "--set", "F=1,2", "-j", "1", "-q",
                 "--allow-user-code"]) == 0
    with h5py.File(target) as f:
        assert list(f["sweep/status"][:]) == [0, 0]


def test_check_reports_the_routines_without_running_them(tmp_path, capsys):
    path = deck(tmp_path, "usr", "USERSIG ld\nUSERINP mv\nTIMESTEP 1 2\n",
                inputs="INPUTX 5 2\n",
                routines={"ld": "open('ran', 'w')\ndef ld(t, state):\n    return []\n"})
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"USERSIG ld (line 17, loads): found in {tmp_path / 'ld.py'}" in out
    assert "USERINP mv (line 18, prescribed motion): NOT FOUND" in out
    assert not (tmp_path / "ran").exists()
    other = tmp_path / "lib"
    other.mkdir()
    (other / "routines.py").write_text("def mv(t):\n    return []\n")
    assert main(["check", str(path), "--user-module", str(other / "routines.py")]) == 0
    assert f"USERINP mv (line 18, prescribed motion): found in {other / 'routines.py'}" \
        in capsys.readouterr().out


# ---------------------------------------------------------------- failing routines
FAILING = {
    "raises": ("raise ValueError('the channel table ends here')",
               "user routine USERSIG bad raised ValueError: the channel table ends here (at "
               "{mod}:7;"),
    "shape": ("return [[5, 2]]", "returned an array of shape (1, 2); expected (k, 3): rows "
                                 "[node, direction, value]"),
    "nan": ("return [[5, 2, float('nan')]]", "returned nan in row 1, column 3"),
    "node": ("return [[7, 2, 1.0]]", "names node 7, which is not a node of the model"),
}


@pytest.mark.parametrize("case", sorted(FAILING))
def test_failing_routine_stops_with_a_clear_message_and_keeps_its_steps(tmp_path, capsys,
                                                                        case):
    body, message = FAILING[case]
    path = deck(tmp_path, "bad", "USERSIG bad\nTIMESTEP 0.5 50\n", routines={"bad": f"""
        import math


        def bad(t, state):
            if t > 0.2:
                {body}
            return [[5, 2, math.sin(4 * math.pi * t)]]
        """})
    assert run(path, "--mode", "transient", "--allow-user-code") == EXIT_USER_ROUTINE == 6
    err = capsys.readouterr().err
    assert message.format(mod=tmp_path / "bad.py") in err, err
    assert "Traceback" not in err and "deck line" in err
    partial = tmp_path / "bad.partial.h5"
    assert "21 time steps (to t = 0.2 s) kept in" in err
    with h5py.File(partial) as f:
        assert f["transient/time"].shape == (21,)
        np.testing.assert_allclose(f["transient/time"][-1], 0.2)


def test_unloadable_and_misplaced_routines(tmp_path, capsys):
    path = deck(tmp_path, "usr", "USERSIG ld\nITERSTEP 10 2\n")
    assert run(path, "--allow-user-code") == 6
    assert "USERSIG ld: no file defines it: expected ld.py beside the deck" in \
        capsys.readouterr().err
    (tmp_path / "ld.py").write_text("import math\nx = 1 / 0\n")
    assert run(path, "--allow-user-code") == 6
    err = capsys.readouterr().err
    assert f"loading {tmp_path / 'ld.py'} raised ZeroDivisionError: division by zero (at " \
           f"{tmp_path / 'ld.py'}:2)" in err
    (tmp_path / "ld.py").write_text("def other(t, state):\n    return []\n")
    assert run(path, "--allow-user-code") == 6
    assert "defines no function ld" in capsys.readouterr().err
    mv = deck(tmp_path, "mv", "USERINP mv\nTIMESTEP 0.1 2\n", inputs="INPUTX 5 2\n",
              routines={"mv": "def mv(t):\n    return [[5, 1, 1.0, 0, 0]]\n"})
    assert run(mv, "--mode", "transient", "--allow-user-code") == 6
    assert "gives node 5 coordinate 1, which is not an input coordinate (declare it with " \
           "INPUTX)" in capsys.readouterr().err
    assert run(mv, "--allow-user-code") == 6          # MODE static
    assert "USERINP mv acts in a transient analysis, not in MODE static" in \
        capsys.readouterr().err


def test_deck_errors_of_user_routine_lines(tmp_path, capsys):
    path = deck(tmp_path, "usr", "USERINP mv\nUSERSIG a\nUSERSIG b\n")
    assert run(path, "--allow-user-code") == 2
    err = capsys.readouterr().err
    assert f"{path}:16:1: error: USERINP: the routine gives the motion of input coordinates " \
           "or prescribed deformations, and the deck declares none" in err
    assert f"{path}:18:1: error: USERSIG is given twice (lines 17 and 18)" in err


# ---------------------------------------------------------------- the FIS routines
FIS = Path(__file__).resolve().parents[1] / "decks" / "user-routines" / "fis"


@pytest.fixture()
def fis(monkeypatch):
    monkeypatch.syspath_prepend(str(FIS))
    import fis_channel
    return fis_channel


def test_fis_channel_geometry(fis):
    """The S: d2 sin t1 + 2r(1 - cos t1) = w and d1 + d3 + d2 cos t1 + 2r sin t1 = ht; the
    centreline ends at (X_START + (-X_START + D1) + ht - D1, w, 0) = (0.12, 0.03, 0) heading
    along +x, 5 N + 1 points."""
    d2, t1 = fis.s_shape()
    r = fis.R_CURVE
    assert d2 * math.sin(t1) + 2 * r * (1 - math.cos(t1)) == pytest.approx(0.03, abs=1e-15)
    assert 0.04 + d2 * math.cos(t1) + 2 * r * math.sin(t1) == pytest.approx(0.12, abs=1e-15)
    assert d2 == pytest.approx(0.0360555, abs=1e-7) and t1 == pytest.approx(0.5059194, abs=1e-7)
    c = fis.CENTRELINE
    assert c.shape == (101, 3)
    np.testing.assert_allclose(c[0], [-0.19, 0, 0], atol=1e-15)
    np.testing.assert_allclose(c[20], [0.01, 0, 0], atol=1e-15)
    np.testing.assert_allclose(c[-1], [0.12, 0.03, 0], atol=1e-14)
    np.testing.assert_allclose(c[-1] - c[-2], [0.0015, 0, 0], atol=1e-14)
    # the first arc: on the circle of radius r about (0.01, r, 0)
    np.testing.assert_allclose(np.linalg.norm(c[20:41] - [0.01, r, 0], axis=1), r, atol=1e-14)


class _State:
    def __init__(self, x, xd):
        self._x, self._xd = x, xd
        self.x = _Rows(x)
        self.xd = _Rows(xd)


class _Rows:
    def __init__(self, d):
        self.d = d

    def __getitem__(self, n):
        return np.stack([self.d[int(k)] for k in n])


def _straight_state(y_tip, vx=0.0, vy=0.0):
    """Tip node 1 at (-0.05, y_tip, 0) in the straight part, node 3 behind it along -x."""
    x = {1: np.array([-0.05, y_tip, 0.0]), 3: np.array([-0.055, y_tip, 0.0]),
         2: np.array([1.0, 0, 0, 0]), 4: np.array([1.0, 0, 0, 0])}
    xd = {1: np.array([vx, vy, 0.0]), 3: np.zeros(3), 2: np.zeros(4), 4: np.zeros(4)}
    return _State(x, xd)


def test_fis_contact_forces(fis):
    """At rest in the straight part: no force inside the zone a = ra - ro; k (b - a) xi^2 / 2
    in the transition zone; k (b - a)(xi - 1/2) beyond it; the tip's radius is ro (its axis
    is across n). Friction against a sliding velocity, with the moment (ro n) x F."""
    ro, k = fis.R_OUTER, fis.STIFFNESS
    a, b = fis.R_A - ro, fis.R_B - ro
    for y, fn in ((0.5 * a, 0.0), (a + 0.25 * (b - a), k / 2 * (b - a) * 0.25**2),
                  (b + 0.5 * (b - a), k * (b - a) * 1.0)):
        rows = fis.contact_rows(_straight_state(y), np.array([1]), 2, 20.0)
        force = {(int(n), int(c)): v for n, c, v in rows}
        assert force[(1, 2)] == pytest.approx(-fn, rel=1e-12, abs=1e-15)
        assert force[(1, 1)] == 0 and force[(1, 3)] == 0
        assert all(force[(2, c)] == 0 for c in (1, 2, 3, 4))
    # sliding along +x at 20 * 2 mm/s (real: 2 mm/s, twice the breakaway velocity) in zone III
    y = b + 0.5 * (b - a)
    fn = k * (b - a)
    rows = fis.contact_rows(_straight_state(y, vx=20 * 0.002), np.array([1]), 2, 20.0)
    force = {(int(n), int(c)): v for n, c, v in rows}
    u = 0.002 / (0.001 * math.sqrt(2))
    ff = (math.sqrt(2 * math.e) * (0.094 - 0.074) * fn * math.exp(-u * u) * u
          + 0.074 * fn * math.tanh(20.0))
    assert force[(1, 1)] == pytest.approx(-ff, rel=1e-12)
    assert force[(1, 2)] == pytest.approx(-fn, rel=1e-12)
    # M = (ro n) x F with n = +y: M_z = -ro F_x; Euler forces at the identity: 2 (0, M)
    assert force[(2, 4)] == pytest.approx(2 * (-ro * force[(1, 1)]), rel=1e-12)
    assert force[(2, 1)] == 0 and force[(2, 2)] == 0 and force[(2, 3)] == 0
    # damping: moving outward at 20 * 1 mm/s adds c vn in zone III
    rows = fis.contact_rows(_straight_state(y, vy=20 * 0.001), np.array([1]), 2, 20.0)
    assert rows[1, 2] == pytest.approx(-(fn + 10.0 * 0.001), rel=1e-12)


def test_fis_insertion_motion(fis, monkeypatch):
    monkeypatch.syspath_prepend(str(FIS))
    import FFESMVA
    import FRESMVA
    assert FRESMVA.FRESMVA(0.0) == [[49, 1, -0.12, 0.1, 0.0]]
    assert FRESMVA.FRESMVA(0.6)[0][2] == pytest.approx(-0.06, abs=1e-15)
    assert FRESMVA.FRESMVA(1.3) == [[49, 1, pytest.approx(0.0, abs=1e-15), 0.0, 0.0]]
    assert FFESMVA.FFESMVA(0.3)[0][2:] == [pytest.approx(-0.06, abs=1e-15), 0.2, 0.0]
    assert FFESMVA.FFESMVA(0.9) == [[49, 1, pytest.approx(0.0, abs=1e-15), 0.0, 0.0]]


# ---------------------------------------------------------------- the FIS corpus decks
CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "spacar-decks"


def _corpus_job(tmp_path, name, timestep=None):
    """A FIS corpus deck loaded from a copy in tmp_path (TIMESTEP shortened when given).
    Where spacarpy refuses DYNX (before its merge), the copy leaves the DYNX lines out: they
    only say which coordinates SPACAR integrates as independent ones."""
    from spacarpy.deck import load
    from spacarpy.deck.keywords import KEYWORDS
    src = CORPUS / name
    if not src.is_file():
        pytest.skip(f"the SPACAR deck corpus {CORPUS} is absent (../shared not beside the repo)")
    lines = src.read_text().splitlines()
    if not KEYWORDS["DYNX"].supported:
        lines = [ln for ln in lines if not ln.split()[:1] == ["DYNX"]]
    if timestep is not None:
        lines = [f"TIMESTEP {timestep}" if ln.split()[:1] == ["TIMESTEP"] else ln
                 for ln in lines]
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path, load(path)


def test_fis_flex_routines_on_the_flex_deck(tmp_path):
    """FFESFVA and FFESMVA through the adapters on fis_flex_cat_s_3d.dat's model: no load on
    the centreline; the tip pushed into zone III gets -k (b - a) along y and no moment; node
    49's x follows the insertion."""
    from spacarpy.solvers.statics.equilibrium import StaticProblem
    from spacarpy.user_routines import loaded_routines
    path, job = _corpus_job(tmp_path, "fis_flex_cat_s_3d.dat")
    prob = StaticProblem(job.model)
    num = prob.num
    loads, motion = loaded_routines(job.model, num, "transient", path, [FIS])
    x = num.x0.copy()
    states = prob.evaluate(x, np.zeros(prob.n_multiplier), prob.loads.at(1.0, 0.0)).states
    assert not np.any(loads(0.0, x, np.zeros_like(x), states))
    import fis_channel as fc
    a, b = fc.R_A - fc.R_OUTER, fc.R_B - fc.R_OUTER
    ids = list(job.model.position_ids)
    tip, second = (num.pos_idx[ids.index(n)] for n in (1, 3))
    x[tip[1]] = x[second[1]] = b + 0.5 * (b - a)       # the tip's axis stays along x
    f = loads(0.0, x, np.zeros_like(x), states)
    assert f[tip[1]] == pytest.approx(-fc.STIFFNESS * (b - a), rel=1e-12)
    assert f[second[1]] == pytest.approx(-fc.STIFFNESS * (b - a), rel=1e-12)
    assert np.count_nonzero(f) == 2
    idx, xi, vi, ai = motion(0.3)
    assert list(idx) == [num.pos_idx[list(job.model.position_ids).index(49)][0]]
    np.testing.assert_allclose([xi[0], vi[0], ai[0]], [-0.06, 0.2, 0.0], atol=1e-15)


@pytest.mark.slow
def test_fis_rig_deck_runs_with_its_routines(tmp_path, fis):
    """fis_rig_cat_s_3d.dat with FRESFVA/FRESMVA to t = 0.21 s in 210 stored steps (the deck
    runs to 1.2 s in 8000; its ERROR control sets the steps taken): the proximal node follows
    the insertion, the tip enters the channel's first arc (from x = 0.01 m, at t = 0.19 s) and
    stays inside the wall (its distance from the centreline below b plus the penetration the
    wall's stiffness allows), and the insertion force (the reaction of node 49 along x) pushes
    against the wall. (96 s on the 2 cores under a load of 14; 15 minutes to t = 0.24 s
    before the routine gave its derivatives.)"""
    path, _ = _corpus_job(tmp_path, "fis_rig_cat_s_3d.dat", timestep="0.21 210")
    out = tmp_path / "rig.h5"
    assert main(["run", str(path), "--mode", "transient", "-o", str(out), "-q",
                 "--allow-user-code", "--user-module", str(FIS)]) == 0
    with open_results(out) as r:
        tr = r.transient
        t = tr.time
        np.testing.assert_allclose(tr.position(49)[:, 0], -0.12 + 0.1 * t, atol=1e-12)
        tip = tr.position(1)
        push = tr.reaction(49)[:, 0]
    assert tip[-1, 0] == pytest.approx(0.021, abs=1e-3)
    _, d, _ = fis.nearest(tip)
    assert d.max() < fis.R_B - fis.R_OUTER + 2e-5
    assert tip[-1, 1] > 5e-4                         # along the arc, bending to +y
    assert push[t > 0.2].min() > 1.0                 # N: the wall resists the insertion


@pytest.mark.slow
def test_fis_flex_deck_runs_into_the_wall(tmp_path, fis):
    """fis_flex_cat_s_3d.dat with FFESFVA/FFESMVA to t = 0.105 s in 700 steps (the deck's
    step, 0.15 ms; it runs to 1.2 s in 8000): the proximal node follows the insertion at
    0.2 m/s, the tip meets the wall of the first arc (from t = 0.073 s) and bends along
    it, no node passes the wall by more than the penetration its stiffness allows, the
    insertion force grows, and the energy balance T + U + D - W (W: the insertion's and the
    wall's work) holds to 1 % of the work done. (81 s on the 2 cores under a load of 14,
    about 15 s of CPU; docs/user-routines.md has the full run.)"""
    path, _ = _corpus_job(tmp_path, "fis_flex_cat_s_3d.dat", timestep="0.105 700")
    out = tmp_path / "flex.h5"
    assert main(["run", str(path), "--mode", "transient", "-o", str(out), "-q",
                 "--allow-user-code", "--user-module", str(FIS)]) == 0
    with open_results(out) as r:
        tr = r.transient
        t = tr.time
        np.testing.assert_allclose(tr.position(49)[:, 0], -0.12 + 0.2 * t, atol=1e-12)
        pos = np.stack([tr.position(n) for n in range(1, 48, 2)], axis=1)
        push = tr.reaction(49)[:, 0]
        bal = (tr.kinetic_energy + tr.elastic_energy + tr.dissipated_energy
               - tr.external_work)
        work = tr.external_work
    _, d, _ = fis.nearest(pos.reshape(-1, 3))
    d = d.reshape(pos.shape[:2])
    a, b = fis.R_A - fis.R_OUTER, fis.R_B - fis.R_OUTER
    first = t[np.argmax((d >= a).any(axis=1))]
    assert 0.06 < first < 0.08                       # the tip reaches the arc at x = 0.01
    assert d.max() < b + 3e-5                         # inside the wall's penetration
    assert pos[-1, 0, 0] == pytest.approx(0.021, abs=1e-3)
    assert pos[-1, 0, 1] > 2e-4                       # along the arc, bending to +y
    assert push[-1] > 0.05 and push[-1] > 5 * abs(push[t < 0.06]).max()
    assert np.ptp(bal) < 0.01 * np.abs(work).max()
